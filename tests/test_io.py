"""jaxdc.io: atomic writes leave either the old file or the whole new one, with normal permissions."""

import os
import stat

import pytest

from jaxdc.io import atomic_write, atomic_write_json


def test_atomic_write_content_and_no_temp_files(tmp_path):
    p = tmp_path / "sub" / "out.json"
    atomic_write_json(p, {"a": 1})
    assert p.read_text() == '{\n  "a": 1\n}\n'
    atomic_write(p, b"new")
    assert p.read_bytes() == b"new"
    assert sorted(os.listdir(p.parent)) == ["out.json"]


def test_atomic_write_has_the_mode_open_would_give(tmp_path):
    ref = tmp_path / "ref.txt"
    ref.write_text("x")
    out = atomic_write(tmp_path / "out.txt", "x")
    assert stat.S_IMODE(os.stat(out).st_mode) == stat.S_IMODE(os.stat(ref).st_mode)


def test_failed_write_keeps_the_old_file(tmp_path):
    p = tmp_path / "out.txt"
    p.write_text("old")
    with pytest.raises(TypeError):
        atomic_write(p, 123)  # not bytes/str: fails while writing
    assert p.read_text() == "old"
    assert sorted(os.listdir(tmp_path)) == ["out.txt"]
