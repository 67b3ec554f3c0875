"""Hostile input for the file helpers (jaxdc.io): outputs that would overwrite an input, output paths that could
only fail after the work, JSON nested too deeply."""

from __future__ import annotations

import errno
import os
import signal

import pytest

from jaxdc import io

# ----------------------------------------------------------------------------- an output that is an input


def test_output_that_is_an_input_refused(tmp_path):
    src = tmp_path / "in.json"
    src.write_text("{}")
    with pytest.raises(ValueError, match=r"--out .* would overwrite the input --graph"):
        io.check_output_path(src, "--out", {"--graph": str(src)})
    # the same file through a symbolic link, a hard link, a relative path with ..
    (tmp_path / "sym.json").symlink_to(src)
    os.link(src, tmp_path / "hard.json")
    (tmp_path / "sub").mkdir()
    for other in (tmp_path / "sym.json", tmp_path / "hard.json", tmp_path / "sub" / ".." / "in.json"):
        with pytest.raises(ValueError, match="would overwrite the input"):
            io.check_output_path(other, "--out", {"--graph": [str(src)]})
    # a file inside an input folder; a folder's files
    with pytest.raises(ValueError, match="--out file .* would overwrite the input --runs"):
        io.check_output_folder(tmp_path, "--out", files=("sub/x.json",), inputs={"--runs": str(tmp_path / "sub")})
    with pytest.raises(ValueError, match="would overwrite the input"):
        io.check_output_folder(tmp_path, "--out", files=("in.json",), inputs={"--graph": str(src)})
    # another file is fine; None entries are skipped
    assert io.check_output_path(tmp_path / "other.json", "--out", {"--graph": [str(src), None], "--x": None})


# ----------------------------------------------------------------------------- paths that fail only after the work


def test_dangling_symbolic_link_refused(tmp_path):
    (tmp_path / "dangling").symlink_to(tmp_path / "nowhere")
    with pytest.raises(ValueError, match="symbolic link .* does not exist"):
        io.check_output_folder(tmp_path / "dangling", "--out")
    with pytest.raises(ValueError, match="symbolic link .* does not exist"):
        io.check_output_path(tmp_path / "dangling" / "x.json", "--out")
    with pytest.raises(ValueError, match="symbolic link .* does not exist"):
        io.check_output_path(tmp_path / "dangling", "--draw")


def test_name_too_long_refused(tmp_path):
    with pytest.raises(ValueError, match="more than the file system's limit"):
        io.check_output_folder(tmp_path / ("x" * 300) / "y", "--out")
    with pytest.raises(ValueError, match="more than the file system's limit"):
        io.check_output_path(tmp_path / ("x" * 256 + ".json"), "--out")
    # a name at the limit is written (its temporary file's name is shortened)
    path = tmp_path / ("y" * 250 + ".json")
    io.check_output_path(path, "--out")
    io.atomic_write(path, "{}")
    assert path.read_text() == "{}"


def test_folder_at_a_file_name_refused(tmp_path):
    (tmp_path / "table.json").mkdir()
    with pytest.raises(ValueError, match="--out file .*table.json.* is a folder"):
        io.check_output_folder(tmp_path, "--out", files=("table.json",))


def test_folder_where_no_folder_can_be_made_refused(tmp_path, monkeypatch):
    """Permission bits do not tell everything (root passes them; a read-only mount, /proc): the check makes and
    removes a folder, and a failure is refused naming the folder, before any work."""
    def fail(**kwargs):
        raise OSError(errno.EROFS, "Read-only file system")

    monkeypatch.setattr(io.tempfile, "mkdtemp", fail)
    with pytest.raises(ValueError, match=r"--out '.*new' cannot be written: making a folder in .* failed "
                                         r"\(Read-only file system\)"):
        io.check_output_folder(tmp_path / "new", "--out")
    monkeypatch.undo()
    io.check_output_folder(tmp_path / "new", "--out")  # the probe leaves nothing behind
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc")
def test_folder_under_proc_refused():
    with pytest.raises(ValueError, match="'/proc/jaxdc_no_such_folder'"):
        io.check_output_folder("/proc/jaxdc_no_such_folder", "--out")


def test_empty_path_refused():
    with pytest.raises(ValueError, match="--out is empty"):
        io.check_output_folder("", "--out")


# ----------------------------------------------------------------------------- JSON nested too deeply


@pytest.mark.parametrize("text", ["[" * 100_000 + "]" * 100_000, '{"a":' * 100_000 + "1" + "}" * 100_000])
def test_deeply_nested_json_refused_naming_the_file(tmp_path, text):
    path = tmp_path / "deep.json"
    path.write_text(text)
    with pytest.raises(ValueError, match=r"deep\.json: nested too deeply to be read; rerun"):
        io.read_json(str(path), "rerun")


def test_deeply_nested_sidecar_refused_naming_the_file(tmp_path):
    from jaxdc import pretrained

    (tmp_path / "net.msgpack").write_bytes(b"")
    (tmp_path / "net.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ValueError, match=r"net\.msgpack: metadata unreadable: .*net\.json: nested too deeply"):
        pretrained.read_metadata(str(tmp_path / "net.msgpack"))


def test_signals_deferred_delivers_each_signal_after_the_block():
    """SIGINT and SIGTERM sent during the block do not interrupt it; each reaches its own handler once, after."""
    got, done = [], []
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: got.append(signum))
    try:
        with pytest.raises(KeyboardInterrupt):
            with io.signals_deferred():
                for s in (signal.SIGTERM, signal.SIGINT, signal.SIGTERM):
                    os.kill(os.getpid(), s)
                done.append(True)
        assert done == [True] and got == [signal.SIGTERM]
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGTERM, previous)
