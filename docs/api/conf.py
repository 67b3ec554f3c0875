"""Sphinx configuration of the jaxdc API reference (docs/api).

Build (strict: any warning fails):
    sphinx-build -W --keep-going -n -b html docs/api docs/api/_build/html

Every page is ``automodule`` with ``:members:``, so the reference is the code's docstrings
(Google style, read by napoleon) and never a copy of them. tests/docs/test_api.py runs the
same strict build and checks that every module of jaxdc has its page.
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import os
import re
import sys
import typing

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
sys.path.insert(0, ROOT)
# importing jaxdc runs no JAX computation; keep autodoc on the CPU all the same
os.environ.setdefault("JAX_PLATFORMS", "cpu")

project = "jaxdc"
author = "jaxdc contributors"
copyright = "jaxdc contributors"
import jaxdc  # noqa: E402

release = version = jaxdc.__version__

extensions = ["sphinx.ext.autodoc", "sphinx.ext.napoleon"]
exclude_patterns = ["_build"]
html_theme = "alabaster"
html_static_path: list[str] = []

napoleon_google_docstring = True
napoleon_numpy_docstring = False
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autoclass_content = "class"
# A method without its own docstring is left out rather than shown with its third-party base's
# (flax's Module.setup, gymnasium's Env.step): those docstrings describe another library.
autodoc_inherit_docstrings = False

# jaxdc.wrappers.sb3 needs the optional bench extra; without it the page is built from a mock,
# so the reference builds from the dev extra alone.
autodoc_mock_imports = [] if importlib.util.find_spec("stable_baselines3") else ["stable_baselines3"]

nitpicky = True
# The build is offline (no intersphinx), so names of other libraries cannot resolve: they render as
# text (the standard library's too, e.g. ``argparse.ArgumentParser`` in the CLI signatures). Private
# helpers (``_name``) are not in the reference by design.
_THIRD_PARTY = (r"(argparse|os|subprocess|pathlib|collections|typing|jax|jaxlib|jnp|numpy|np|flax|nn|optax|"
                 r"orbax|chex|gymnasium|"
                r"stable_baselines3|matplotlib|PIL|torch|tqdm)")
nitpick_ignore_regex = [
    (r"py:.*", _THIRD_PARTY + r"(\..*)?"),
    (r"py:.*", r"(.*\.)?_[A-Za-z0-9].*"),
    (r"py:class", r"tuple\[.*"),  # a pair annotation split at its comma in a rendered signature
]

# Napoleon reads the first line of a data/attribute docstring as ``type: description`` (Google
# style for attributes). jaxdc's ``#:`` comments are prose whose first sentence may contain a colon
# ("The largest finite budget: ..."), which napoleon would turn into a type; keep them as written.
_ATTRIBUTE_KINDS = ("data", "attribute", "property")


def _keep_attribute_text(app, what, name, obj, options, lines):
    if what in _ATTRIBUTE_KINDS:
        app.env.temp_data.setdefault("jaxdc_attr_lines", {})[name] = list(lines)


def _restore_attribute_text(app, what, name, obj, options, lines):
    kept = app.env.temp_data.get("jaxdc_attr_lines", {}).pop(name, None)
    if kept is not None:
        lines[:] = kept


def _canonical(dotted: str, module: str | None, cls: str | None):
    """The documented name of ``dotted`` seen from ``module`` (and class ``cls``), following imports.

    A docstring may name an object by the name its module imported it under (``render_frame`` in
    :mod:`jaxdc.viewer`, ``navigators.POLICIES``, ``jaxdc.nets.EQN``); the reference documents it
    where it is defined. Returns None when ``dotted`` does not resolve.
    """
    scopes = []
    if module:
        if cls:
            scopes.append(module + "." + cls)
        scopes.append(module)
    scopes.append("")
    for scope in scopes:
        parts = (scope + "." + dotted).lstrip(".").split(".")
        for i in range(len(parts), 0, -1):
            try:
                obj = importlib.import_module(".".join(parts[:i]))
            except ImportError:
                continue
            except Exception:  # noqa: BLE001 - a module that fails to import resolves nothing
                break
            name = obj.__name__
            try:
                for part in parts[i:]:
                    obj = getattr(obj, part)
                    if inspect.ismodule(obj):
                        name = obj.__name__
                    elif (inspect.isclass(obj) or inspect.isfunction(obj)) and hasattr(obj, "__qualname__"):
                        name = obj.__module__ + "." + obj.__qualname__
                    else:
                        name = name + "." + part
            except AttributeError:
                break
            return name
    return None


def _is_type_variable(name: str) -> bool:
    module, _, attr = name.rpartition(".")
    try:
        return isinstance(getattr(importlib.import_module(module), attr), typing.TypeVar)
    except (ImportError, AttributeError, ValueError):
        return False


def _resolve_through_imports(app, env, node, contnode):
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].lstrip("~.")
    name = _canonical(target, node.get("py:module"), node.get("py:class"))
    if name is not None and _is_type_variable(name):
        return contnode  # a signature's TypeVar (``P``, ``S`` of core/env.py) has no page: plain text
    if name is None or name == target:
        return None
    if re.fullmatch(_THIRD_PARTY + r"(\..*)?", name):
        return contnode  # imported from another library (``Mesh`` from jax.sharding): text, as above
    domain = env.get_domain("py")
    return domain.resolve_xref(env, node["refdoc"], app.builder, node["reftype"], name, node, contnode)


def setup(app):
    app.connect("autodoc-process-docstring", _keep_attribute_text, priority=100)
    app.connect("autodoc-process-docstring", _restore_attribute_text, priority=900)
    app.connect("missing-reference", _resolve_through_imports)
