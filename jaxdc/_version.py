"""The version of jaxdc (the one place it is written in the package; ``pyproject.toml`` names the same)."""

__version__ = "0.1.0"
