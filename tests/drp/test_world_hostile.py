"""Hostile input for jaxdc.drp.world: validation names the field, generation refuses bad arguments, saving is
atomic and strict.
"""

import json
import os

import numpy as np
import pytest

from jaxdc.drp import world


def _strict(text):
    """Parse JSON refusing NaN and Infinity."""
    def refuse(c):
        raise AssertionError(f"non-strict JSON constant {c}")
    return json.loads(text, parse_constant=refuse)


# ----------------------------------------------------------------------------- library


@pytest.mark.parametrize("graph, exc, needle", [
    (world.Graph(np.zeros(2), np.full((2, 2), 1e300), np.ones(2), 0.99, 1.0), ValueError, "nodes[0][0]"),
    (world.Graph(np.zeros(2), np.ones((2, 2)), np.array([1.0, np.nan]), 0.99, 1.0), ValueError, "rewards[1]"),
    (world.Graph(np.zeros(2), np.ones((2, 2)), np.ones(2), 0.99, np.inf), ValueError, "alpha"),
    (world.Graph(np.zeros(2), np.ones((2, 2)), np.ones(2), True, 1.0), TypeError, "psi"),
])
def test_validate_names_the_field(graph, exc, needle):
    with pytest.raises(exc, match=__import__("re").escape(needle)):
        world.validate(graph)


@pytest.mark.parametrize("kw, needle", [({"n": 0}, "n must be"), ({"n": 10**9}, "n must be"),
                                        ({"size": float("inf")}, "size"), ({"size": 1e12}, "size"),
                                        ({"seed": -1}, "seed")])
def test_generate_refuses_bad_arguments(kw, needle):
    args = {"seed": 0, **kw}
    with pytest.raises(ValueError, match=needle):
        world.generate(args.pop("seed"), **args)


def test_save_is_atomic_and_strict(tmp_path, monkeypatch):
    path = tmp_path / "g.json"
    g = world.generate(0, n=4)
    world.save(g, path)
    before = path.read_bytes()

    def interrupted(src, dst):
        raise KeyboardInterrupt
    monkeypatch.setattr(os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        world.save(world.generate(1, n=4), path)
    monkeypatch.undo()
    assert os.listdir(tmp_path) == ["g.json"] and path.read_bytes() == before  # no temp file, old content
    with pytest.raises(ValueError, match="nodes"):
        world.save(world.Graph(np.zeros(2), np.full((1, 2), np.nan), np.ones(1), 0.99, 1.0), path)
    assert path.read_bytes() == before
    _strict(before.decode())


def test_deeply_nested_graph_file_refused(tmp_path):
    """100,000 nested brackets ended in a RecursionError traceback; the lenient read refuses them, naming the
    file (as an unreadable path or a folder)."""
    path = tmp_path / "deep.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ValueError, match="deep.json: nested too deeply"):
        world.load(str(path))
    with pytest.raises(ValueError, match="cannot read it"):
        world.load(str(tmp_path))


def test_load_refuses_an_unknown_key_naming_the_file_and_the_key(tmp_path):
    from jaxdc.drp import world as w

    path = tmp_path / "g.json"
    path.write_text('{"base": [0, 0], "nodes": [[1, 2]], "rewards": [4], "psi": 0.99, "alpha": 10, "aplha": 5}')
    with pytest.raises(ValueError, match=r"g\.json.*unknown key 'aplha'"):
        w.load(path)
