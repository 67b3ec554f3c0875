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


def test_json_is_strict_and_names_the_non_finite_value(tmp_path):
    from jaxdc.io import finite_or_none, json_text
    p = tmp_path / "r.json"
    with pytest.raises(ValueError, match=r"at rpe\.mean, rows\[1\]"):
        atomic_write_json(p, {"rpe": {"mean": float("nan")}, "rows": [1.0, float("inf")]})
    assert not p.exists() and os.listdir(tmp_path) == []
    assert json_text({"a": None}, indent=None) == '{"a": null}'
    assert finite_or_none(float("nan")) is None and finite_or_none(2) == 2.0 and finite_or_none(None) is None


def test_a_set_of_files_lands_together_or_not_at_all(tmp_path):
    from jaxdc.io import atomic_write_set
    a, b = tmp_path / "t.json", tmp_path / "t.md"
    atomic_write_set({a: "{}", b: "old"})
    with pytest.raises(TypeError):
        atomic_write_set({a: "{\"new\": 1}", b: object()})  # the second file cannot be written
    assert a.read_text() == "{}" and b.read_text() == "old"
    assert sorted(os.listdir(tmp_path)) == ["t.json", "t.md"]
    atomic_write_set({a: "1", b: "2"})
    assert (a.read_text(), b.read_text()) == ("1", "2")


def test_output_paths_are_checked_before_any_work(tmp_path):
    from jaxdc.io import check_output_folder, check_output_path
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(ValueError, match="is a file"):
        check_output_folder(f / "sub")
    with pytest.raises(ValueError, match="is a file, not a folder"):
        check_output_folder(f)
    with pytest.raises(ValueError, match="is a folder"):
        check_output_path(tmp_path)
    with pytest.raises(ValueError, match="is a file"):
        check_output_path(f / "out.json")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        if not os.access(ro, os.W_OK):  # root may write anyway
            with pytest.raises(ValueError, match="not writable"):
                check_output_path(ro / "out.json")
    finally:
        ro.chmod(0o700)
    assert check_output_folder(tmp_path / "new" / "deep") == str(tmp_path / "new" / "deep")
    assert not (tmp_path / "new").exists()


def test_unlimited_settings_are_written_as_the_string_inf():
    from jaxdc.io import unlimited_to_json
    assert unlimited_to_json(float("inf")) == "inf" and unlimited_to_json(8) == 8.0
    assert unlimited_to_json((8.0, float("inf"))) == [8.0, "inf"]
    assert float(unlimited_to_json(float("inf"))) == float("inf")
    with pytest.raises(ValueError):
        unlimited_to_json(float("nan"))
