"""The package's import graph (every ``import`` of every jaxdc module, at module level and inside functions, read
with ``ast``): data flows one way (docs/architecture.md) and no module imports itself back through others."""

from __future__ import annotations

import ast
import os

import jaxdc

ROOT = os.path.dirname(os.path.abspath(jaxdc.__file__))
PROBLEMS = ("dcp", "dcg", "drp")


def _modules() -> dict[str, str]:
    """``{dotted module name: path}`` of every module of the package (a package is its ``__init__``)."""
    out = {}
    for folder, dirs, files in os.walk(ROOT):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__" and d != "assets")
        for f in files:
            if f.endswith(".py"):
                rel = os.path.relpath(os.path.join(folder, f), os.path.dirname(ROOT))[: -len(".py")]
                name = rel.replace(os.sep, ".")
                out[name.removesuffix(".__init__")] = os.path.join(folder, f)
    return out


MODULES = _modules()


def _resolve(name: str) -> str | None:
    """The jaxdc module ``name`` refers to (itself, or the nearest package above it), or ``None`` outside jaxdc."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(module: str) -> set[str]:
    """The jaxdc modules ``module`` imports (``from jaxdc.x import y`` is ``jaxdc.x.y`` when that is a module)."""
    path = MODULES[module]
    tree = ast.parse(open(path).read(), path)
    package = module if path.endswith("__init__.py") else module.rpartition(".")[0]
    out = set()
    typing_only = {id(n) for block in ast.walk(tree) if isinstance(block, ast.If) and _is_type_checking(block.test)
                   for stmt in block.body for n in ast.walk(stmt)}
    for node in ast.walk(tree):
        if id(node) in typing_only:  # `if TYPE_CHECKING:` imports are for the type checker, never run
            continue
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
            names = [f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base for a in node.names]
        else:
            continue
        for n in names:
            if n.startswith("jaxdc"):
                target = _resolve(n)
                if target is not None and target != module:
                    out.add(target)
    return out


GRAPH = {m: _imports(m) for m in MODULES}


def _layer(module: str) -> str:
    """The floor of ``module``: its subpackage (``core``, ``dcp`` ...), ``cli`` for ``python -m jaxdc``."""
    parts = module.split(".")
    if module == "jaxdc.__main__":
        return "cli"
    return parts[1] if len(parts) > 1 else ""


def _violations(rule) -> list[str]:
    return sorted(f"{m} -> {t}" for m, targets in GRAPH.items() for t in targets if rule(m, t))


def test_no_library_module_imports_the_command_lines():
    assert _violations(lambda m, t: _layer(t) == "cli" and _layer(m) != "cli") == []


def test_core_imports_no_problem():
    assert _violations(lambda m, t: _layer(m) == "core" and _layer(t) in PROBLEMS) == []


def test_problems_import_neither_each_other_nor_the_floors_above():
    above = ("training", "report", "viewer", "wrappers", "cli")
    assert _violations(lambda m, t: _layer(m) in PROBLEMS and _layer(t) != _layer(m)
                       and (_layer(t) in PROBLEMS or _layer(t) in above)) == []


def test_the_ground_floor_modules_import_nothing_above_the_problems():
    """pretrained, checkpoint, io, metadata, provenance sit below the problems (which read them)."""
    ground = {m for m in MODULES if m.count(".") == 1 and m not in ("jaxdc.__main__",)
              and not MODULES[m].endswith("__init__.py")}
    above = ("training", "report", "viewer", "wrappers", "cli")
    assert _violations(lambda m, t: m in ground and _layer(t) in above) == []


def test_nothing_below_the_package_root_imports_it():
    """The root (``jaxdc.make``) imports the environments, so a module on their floors or below that imports it
    (``from jaxdc import __version__``) runs upward; the floors above (wrappers, cli, ...) may use it."""
    below = ("core", "nets", "agents", *PROBLEMS)
    assert _violations(lambda m, t: t == "jaxdc" and (_layer(m) in below or m.count(".") == 1)
                       and m != "jaxdc.__main__") == []


def test_nets_and_agents_know_no_problem():
    assert _violations(lambda m, t: _layer(m) in ("nets", "agents") and _layer(t) in PROBLEMS) == []


def test_no_import_cycle():
    """No module reaches itself through the imports of others (module-level and function-level alike)."""
    cycles, state = [], {}

    def visit(m, stack):
        state[m] = "open"
        for t in sorted(GRAPH[m]):
            if state.get(t) == "open":
                cycles.append(" -> ".join(stack[stack.index(t):] + [t]))
            elif t not in state:
                visit(t, stack + [t])
        state[m] = "done"

    for m in sorted(GRAPH):
        if m not in state:
            visit(m, [m])
    assert cycles == []


def test_the_walk_sees_the_package():
    assert "jaxdc.training.loop" in GRAPH and "jaxdc.metadata" in GRAPH["jaxdc.pretrained"]
    assert "jaxdc.training.loop" in GRAPH["jaxdc.cli.train_common"]
