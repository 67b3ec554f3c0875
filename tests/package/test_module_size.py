"""No Python module of the checkout is over :data:`MAX_LINES` lines (issue 27, "Done when"; docs/extending.md's
checklist): a module that grows past it is split by concept, as the problems' ``types.py`` or the DCG's
``optimum`` subcommand were."""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: The most lines one module may have.
MAX_LINES = 450
#: The folders whose modules are counted: the package, its command shims, the benchmarks and the tests.
FOLDERS = ("jaxdc", "train", "eval", "benchmarks", "tests")


def long_modules(root: Path, limit: int = MAX_LINES) -> list[str]:
    """``"path: lines"`` for each ``.py`` file under ``root``'s :data:`FOLDERS` with more than ``limit`` lines."""
    out = []
    for folder in FOLDERS:
        for path in sorted((root / folder).rglob("*.py")):
            lines = len(path.read_text(encoding="utf-8").splitlines())
            if lines > limit:
                out.append(f"{path.relative_to(root)}: {lines}")
    return out


def test_no_module_is_over_the_limit():
    assert long_modules(ROOT) == []


def test_the_count_sees_a_long_module(tmp_path):
    (tmp_path / "jaxdc").mkdir()
    (tmp_path / "jaxdc" / "big.py").write_text("x = 1\n" * (MAX_LINES + 1))
    (tmp_path / "jaxdc" / "ok.py").write_text("x = 1\n" * MAX_LINES)
    assert long_modules(tmp_path) == [f"jaxdc/big.py: {MAX_LINES + 1}"]
