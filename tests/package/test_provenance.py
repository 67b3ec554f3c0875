"""jaxdc.provenance: what every result JSON records about where it came from."""

import json

import jax

from jaxdc import __version__
from jaxdc.io import json_text
from jaxdc.provenance import git_commit, provenance


def test_provenance_names_versions_commit_device_and_command():
    p = provenance(["python", "-m", "eval.dcp", "--table", "4.3", "--out", "a b"])
    assert p["jaxdc_version"] == __version__ and p["jax_version"] == jax.__version__
    assert p["command"] == "python -m eval.dcp --table 4.3 --out 'a b'"
    assert p["device"]["platform"] == jax.devices()[0].platform and p["device"]["count"] >= 1
    g = git_commit()
    assert g is None or (len(g["commit"]) == 40 and isinstance(g["dirty"], bool))
    assert json.loads(json_text(p)) == p  # strict JSON
