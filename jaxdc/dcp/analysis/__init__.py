"""DCP analysis: experiments, tables and measurements built on the environment and its yardsticks."""
