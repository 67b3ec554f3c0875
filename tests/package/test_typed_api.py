"""The typed public API: every public function and method of the typed modules annotates each parameter and its
return (``.ci/run`` type-checks the same modules with mypy, which does not insist on annotations)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "jaxdc"
#: The modules whose public API is fully annotated (core's stats, sampling, validate and claims, training/ and
#: pretrained.py join when they are annotated).
TYPED = sorted(
    [p for p in (ROOT / "core").glob("*.py") if p.stem not in ("stats", "sampling", "validate", "claims")]
    + list((ROOT / "agents").glob("*.py")) + list((ROOT / "wrappers").glob("*.py"))
    + [ROOT / "dcp" / "env.py", ROOT / "dcp" / "types.py", ROOT / "dcg" / "env.py", ROOT / "dcg" / "types.py",
       ROOT / "dcg" / "picture.py", ROOT / "viewer" / "frame.py"]
    + list((ROOT / "training").glob("*.py")) + list((ROOT / "dcg" / "team").glob("*.py"))
    + [ROOT / "pretrained.py", ROOT / "checkpoint.py", ROOT / "metadata.py", ROOT / "nets" / "registry.py",
       ROOT / "dcp" / "instances.py"]
)


def unannotated(path: Path) -> list[str]:
    """``"name: what"`` for each public function or method of ``path`` that leaves a parameter or its return bare."""
    out = []

    def check(fn: ast.FunctionDef | ast.AsyncFunctionDef, owner: str) -> None:
        a = fn.args
        params = a.posonlyargs + a.args + a.kwonlyargs
        if owner and params and params[0].arg in ("self", "cls"):
            params = params[1:]
        bare = [p.arg for p in params if p.annotation is None]
        bare += ["*" + v.arg for v in (a.vararg, a.kwarg) if v is not None and v.annotation is None]
        if fn.returns is None:
            bare.append("return")
        if bare:
            out.append(f"{owner}{fn.name} (line {fn.lineno}): {', '.join(bare)}")

    functions = (ast.FunctionDef, ast.AsyncFunctionDef)
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, functions) and not node.name.startswith("_"):
            check(node, "")
        elif isinstance(node, ast.ClassDef) and not node.name.startswith("_"):
            for m in node.body:
                if isinstance(m, functions) and (not m.name.startswith("_") or m.name == "__init__"):
                    check(m, f"{node.name}.")
    return out


@pytest.mark.parametrize("path", TYPED, ids=lambda p: str(p.relative_to(ROOT)))
def test_public_api_is_annotated(path):
    assert not unannotated(path), f"{path.relative_to(ROOT)}: unannotated {unannotated(path)}"


def test_the_check_sees_a_bare_function(tmp_path):
    bare = tmp_path / "m.py"
    bare.write_text("def f(x, y: int):\n    return x\n\nclass C:\n    def g(self, z) -> int:\n        return 1\n")
    assert unannotated(bare) == ["f (line 1): x, return", "C.g (line 5): z"]
