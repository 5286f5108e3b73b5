"""The package's subpackages import only downward (docs/ARCHITECTURE.md, "The Python package"),
and its own modules are imported at the top of a file, never inside a function (issue 40).

The Python counterpart of tests/check_layers.py (the C folders). Every module of
bindings/python/mlayer is read with ast; each import of a module of the package (``from .x
import y``, ``from .. import x``, ``import mlayer.x``; those under ``if TYPE_CHECKING:``
included, they name a dependency too) must point to the module's own layer or one listed below
it in LAYERS. Function-level imports stay allowed for optional third-party packages only
(scipy, matplotlib, PIL, pandas, dask, ...), which ``_optional.require`` checks at the call.
"""
from __future__ import annotations

import ast
import pathlib

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parents[1] / "mlayer"

#: the library's layers, lowest first: each may import itself and the layers before it
ORDER = ["base", "model", "io", "data", "layers", "guards", "pipeline", "manifold", "plotting"]

#: each layer with the layers it may import (its own included)
LAYERS: dict[str, set[str]] = {name: set(ORDER[:i + 1]) for i, name in enumerate(ORDER)}
LAYERS["batching"] = set(ORDER) | {"batching"}
LAYERS["viewer"] = set(ORDER) | {"viewer"}
LAYERS["cli"] = set(ORDER) | {"batching", "viewer", "cli"}
LAYERS["main"] = {"cli"}          # mlayer/__main__.py: `python -m mlayer`
LAYERS["facade"] = set(LAYERS)    # mlayer/__init__.py: the public names, imported by no module


def layer_of(module: str) -> str:
    """The layer of a dotted module name of the package ("mlayer.guards.ik" -> "guards")."""
    parts = module.split(".")
    if parts == ["mlayer"]:
        return "facade"
    if parts[1] == "__main__":
        return "main"
    if len(parts) == 2 and parts[1] not in LAYERS:
        return "base"  # errors.py, _native.py, _arrays.py, ..., the cffi extension _mlayer
    return parts[1]


def modules(root: pathlib.Path) -> dict[str, tuple[pathlib.Path, bool]]:
    """{dotted name: (path, is_package)} of every .py file below root (the package folder)."""
    out = {}
    for p in sorted(root.rglob("*.py")):
        parts = list(p.relative_to(root.parent).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        if is_pkg:
            parts = parts[:-1]
        out[".".join(parts)] = (p, is_pkg)
    return out


def _targets(node: ast.AST, package: str, known: dict) -> list[str]:
    """The package's modules an import statement names (empty for other packages)."""
    if isinstance(node, ast.ImportFrom):
        if node.level:
            parts = package.split(".")
            base = ".".join(parts[:len(parts) - (node.level - 1)])
            target = ".".join(x for x in (base, node.module) if x)
        elif node.module and (node.module == "mlayer" or node.module.startswith("mlayer.")):
            target = node.module
        else:
            return []
        # from . import x: the module x when there is one, else the module imported from
        return [f"{target}.{a.name}" if f"{target}.{a.name}" in known else target
                for a in node.names]
    if isinstance(node, ast.Import):
        return [a.name for a in node.names
                if a.name == "mlayer" or a.name.startswith("mlayer.")]
    return []


def check_source(name: str, source: str, is_pkg: bool, known: dict) -> list[str]:
    """The problems of one module's imports: upward or sideways, or inside a function."""
    package = name if is_pkg else name.rpartition(".")[0]
    tree = ast.parse(source, name)
    errors = []
    own = layer_of(name)

    def visit(node: ast.AST, in_function: bool) -> None:
        for child in ast.iter_child_nodes(node):
            inside = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                       ast.Lambda))
            for target in _targets(child, package, known):
                where = f"{name}:{child.lineno}"
                if in_function:
                    errors.append(f"{where}: imports {target} inside a function (own modules "
                                  "are imported at the top of the file)")
                theirs = layer_of(target)
                if theirs == "facade" and own != "main":
                    errors.append(f"{where}: imports the package facade `mlayer` "
                                  "(import the module that defines the name)")
                elif theirs not in LAYERS[own]:
                    errors.append(f"{where}: {own} imports {target} of the layer {theirs} "
                                  f"(upward or sideways; {own} may import "
                                  f"{', '.join(sorted(LAYERS[own]))})")
            visit(child, inside)

    visit(tree, False)
    return errors


def check(root: pathlib.Path) -> list[str]:
    known = modules(root)
    errors = []
    for name, (path, is_pkg) in known.items():
        if layer_of(name) not in LAYERS:
            errors.append(f"{name}: in no layer of LAYERS")
            continue
        errors += check_source(name, path.read_text(encoding="utf-8"), is_pkg, known)
    return errors


def test_imports_point_down_and_sit_at_the_top():
    errors = check(PACKAGE)
    assert not errors, "\n".join(errors)


def test_every_subpackage_is_a_layer():
    folders = {p.name for p in PACKAGE.iterdir()
               if p.is_dir() and (p / "__init__.py").is_file()}
    assert folders == set(LAYERS) - {"base", "main", "facade"}


KNOWN = {m: None for m in ("mlayer", "mlayer.model", "mlayer.model.motion", "mlayer.guards",
                           "mlayer.guards.contacts", "mlayer.manifold",
                           "mlayer.manifold.features", "mlayer.viewer", "mlayer.batching",
                           "mlayer.batching.run", "mlayer._arrays")}


@pytest.mark.parametrize("name, source, expect", [
    # downward, at the top: fine
    ("mlayer.guards.contacts", "from ..model.motion import Motion\nfrom .. import _arrays\n", ""),
    ("mlayer.guards.contacts", "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                               "    from ..model.motion import Motion\n", ""),
    # an optional third-party package inside a function: fine
    ("mlayer.model.motion", "def f():\n    import scipy\n", ""),
    # upward, at the top and for types only
    ("mlayer.model.motion", "from ..guards.contacts import detect_contacts\n", "upward"),
    ("mlayer.model.motion", "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                            "    from ..guards import contacts\n", "upward"),
    ("mlayer.guards.contacts", "import mlayer.manifold.features\n", "upward"),
    # sideways: the viewer and batching are siblings
    ("mlayer.viewer", "from ..batching import run\n", "upward or sideways"),
    # the facade
    ("mlayer.guards.contacts", "from .. import Motion\n", "facade"),
    # inside a function, even downward
    ("mlayer.guards.contacts", "def f():\n    from ..model.motion import Motion\n",
     "inside a function"),
    ("mlayer.guards.contacts", "class A:\n    def f(self):\n        from . import contacts\n",
     "inside a function"),
])
def test_the_check_sees(name, source, expect):
    """The checker itself: it passes downward imports and finds each kind of fault."""
    errors = check_source(name, source, name == "mlayer.viewer", KNOWN)
    if expect:
        assert errors and all(expect in e for e in errors), errors
    else:
        assert errors == []


def _all_modules() -> dict:
    """Every module of the installed package, imported: {dotted name: module}."""
    import importlib
    import pkgutil

    import mlayer
    names = ["mlayer"] + [i.name for i in pkgutil.walk_packages(mlayer.__path__, "mlayer.")
                          if not i.name.endswith("__main__")]  # that one runs the CLI
    return {n: importlib.import_module(n) for n in names}


def test_no_module_is_hidden_by_a_name():
    """mlayer.X is the module mlayer/X.py whenever that module exists (issue 40: the function
    mlayer.mirror hid the module mlayer/mirror.py, mlayer.retarget likewise), in every package
    of the tree."""
    import sys
    hidden = []
    for name in _all_modules():
        parent, _, leaf = name.rpartition(".")
        if parent and getattr(sys.modules[parent], leaf, None) is not sys.modules[name]:
            hidden.append(f"{name}: {parent}.{leaf} is {getattr(sys.modules[parent], leaf)!r}")
    assert not hidden, "\n".join(hidden)


def test_one_class_named_clip():
    """One class named Clip in the package: the clip of a run (mlayer.pipeline.pipeline); the
    viewer's is ViewerClip, its old name still answering with a DeprecationWarning."""
    import inspect
    clips = {f"{v.__module__}.{v.__qualname__}" for mod in _all_modules().values()
             for v in vars(mod).values()
             if inspect.isclass(v) and v.__name__ == "Clip" and v.__module__.startswith("mlayer")}
    assert clips == {"mlayer.pipeline.pipeline.Clip"}
    import mlayer.viewer
    with pytest.warns(DeprecationWarning, match="ViewerClip"):
        old = mlayer.viewer.Clip
    assert old is mlayer.viewer.ViewerClip
    with pytest.raises(AttributeError):
        mlayer.viewer.NoSuchName  # noqa: B018
