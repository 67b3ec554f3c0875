"""The package ``jaxdc`` itself: importing it (and every module) does no JAX computation."""

import subprocess
import sys

MODULES = ["jaxdc", "jaxdc.dcp.env", "jaxdc.dcg.env", "jaxdc.dcg.opponents", "jaxdc.wrappers.gymnasium",
           "jaxdc.core.paths", "jaxdc.viewer", "jaxdc.nets", "jaxdc.agents.a2c", "jaxdc.agents.nstep_q",
           "jaxdc.agents.parallel", "jaxdc.drp.tours", "jaxdc.dcp.evaluate", "jaxdc.dcg.evaluate", "jaxdc.pretrained"]


def test_import_starts_no_backend():
    # jax.distributed.initialize() must still be callable after `import jaxdc`: it refuses once a backend exists.
    code = ("import importlib, sys\n"
            f"for m in {MODULES!r}: importlib.import_module(m)\n"
            "from jax._src import xla_bridge as xb\n"
            "print('backends', len(xb._backends))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert "backends 0" in out.stdout, out.stdout
