"""Shipped networks with a damaged sidecar (``net.json`` beside ``net.msgpack``), for the loaders' hostile tests."""

from __future__ import annotations

import json
import os
import shutil

import pytest

from jaxdc import pretrained


def copy_with(tmp_path, problem: str, name: str, **changes) -> str:
    """The shipped network ``name`` of ``problem`` copied to ``tmp_path/net.msgpack``, its sidecar ``net.json``
    with ``changes`` (a key ``env_X`` sets ``env.X``); the path of the copy."""
    src = pretrained.shipped(problem, name)
    blob = tmp_path / "net.msgpack"
    shutil.copy(src, blob)
    with open(src[: -len(".msgpack")] + ".json") as f:
        meta = json.load(f)
    for key, value in changes.items():
        if key.startswith("env_"):
            meta.setdefault("env", {})[key[4:]] = value
        else:
            meta[key] = value
    (tmp_path / "net.json").write_text(json.dumps(meta))
    return str(blob)


def assert_refused_naming_file_and_key(load, blob: str, key: str, words: str) -> None:
    """``load(blob)`` raises a ``ValueError`` that names the sidecar file, ``key`` and ``words``."""
    sidecar = os.path.join(os.path.dirname(blob), "net.json")
    with pytest.raises(ValueError) as e:
        load(blob)
    text = str(e.value)
    assert sidecar in text and key in text, text
    assert words in text, text
    assert "parameter file" in text or text.startswith(sidecar), text
