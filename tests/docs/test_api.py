"""The API reference (docs/api): a strict Sphinx build of the docstrings, and a page for every module.

The build is the one docs/api/conf.py documents: ``-W --keep-going -n`` (every warning, unresolved
cross-references included, fails it). Without Sphinx (the ``docs`` extra) the build tests skip;
``.ci/run`` sets ``JAXDC_REQUIRE_DOCS=1``, which turns a missing Sphinx into a failure instead.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs" / "api"
STRICT = ["-W", "--keep-going", "-n", "-b", "html"]
#: modules that are no API: ``python -m jaxdc`` runs the command when imported
NOT_DOCUMENTED = {"jaxdc.__main__"}


def _require_sphinx() -> None:
    if os.environ.get("JAXDC_REQUIRE_DOCS") == "1":
        import sphinx  # noqa: F401
    else:
        pytest.importorskip("sphinx", reason="the API reference needs Sphinx: pip install -e '.[docs]'")


def _build(src: Path, out: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, JAX_PLATFORMS="cpu")
    return subprocess.run([sys.executable, "-m", "sphinx", *STRICT, "-d", str(out / "doctrees"), str(src),
                           str(out / "html")], capture_output=True, text=True, env=env, timeout=600)


def _modules() -> set[str]:
    found = set()
    for path in (ROOT / "jaxdc").rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        found.add(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return found - NOT_DOCUMENTED


def _documented() -> list[str]:
    names = []
    for page in sorted(DOCS.glob("*.rst")):
        names += re.findall(r"^\.\. automodule:: (\S+)\s*$", page.read_text(), flags=re.M)
    return names


def test_every_module_has_exactly_one_automodule():
    documented = _documented()
    assert len(documented) == len(set(documented)), sorted(n for n in documented if documented.count(n) > 1)
    missing, stale = _modules() - set(documented), set(documented) - _modules()
    assert not missing, f"modules without a page in docs/api: {sorted(missing)}"
    assert not stale, f"docs/api documents modules that do not exist: {sorted(stale)}"


def test_every_page_is_in_the_toctree():
    index = (DOCS / "index.rst").read_text()
    pages = {p.stem for p in DOCS.glob("*.rst")} - {"index"}
    listed = set(re.findall(r"^   (\w+)\s*$", index, flags=re.M))
    assert pages == listed, (sorted(pages - listed), sorted(listed - pages))


def test_strict_build_passes(tmp_path):
    _require_sphinx()
    done = _build(DOCS, tmp_path)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-8000:]
    html = tmp_path / "html"
    # the pages hold the docstrings themselves, not only the headings
    core = (html / "core.html").read_text()
    assert "jaxdc.core.validate.check_int" in core
    assert "Bytes of the arrays" in core
    assert (html / "wrappers.html").read_text().count("JaxdcVecEnv") > 0


def test_strict_build_fails_on_a_broken_reference(tmp_path):
    """The strict flags and the ignore lists of conf.py still catch a jaxdc name that does not exist."""
    _require_sphinx()
    src = tmp_path / "src"
    src.mkdir()
    shutil.copy(DOCS / "conf.py", src / "conf.py")
    (src / "index.rst").write_text("Broken\n======\n\nSee :func:`jaxdc.core.validate.no_such_check`.\n")
    done = _build(src, tmp_path / "out")
    assert done.returncode != 0
    assert "jaxdc.core.validate.no_such_check" in done.stderr
