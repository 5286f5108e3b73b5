"""Every public callable of mlayer has a numpy-style docstring and full type hints.

The public API is walked at run time:

- the modules: ``mlayer`` and every module under it whose dotted name has no part starting
  with an underscore, except the command modules under ``mlayer.cli`` (the command line is
  documented by ``mlayer --help``; ``mlayer.cli`` itself, with ``main`` and ``build_parser``,
  is walked);
- a module's public names: its ``__all__``, or, without one, the names not starting with an
  underscore of the functions and classes defined in it;
- of each public class: the class (the parameters of a constructor defined in its own body),
  and the public methods,
  class and static methods and properties defined in its own body (plus ``__call__``).

A docstring is numpy-style when it has a one-line summary, a ``Parameters`` section (underlined
with dashes) naming every parameter (but those starting with an underscore) when the callable
takes any (for a class: the constructor's, in a ``Parameters`` or ``Attributes`` section of the
class docstring), and a
``Returns`` (or ``Yields``) section when it returns something (the return annotation is not
``None``; properties and classes are exempt). Annotations: every parameter but ``self`` /
``cls`` and the return.

Run as a script (``python test_docstrings.py``) to print the counts and what fails.
"""
from __future__ import annotations

import functools
import importlib
import inspect
import pkgutil
import re
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import pytest

#: command modules of the command line, documented by ``mlayer --help``, not as Python API
_SKIP_PREFIXES = ("mlayer.cli.",)


@dataclass
class Entry:
    """One public callable: where it is, what it is and what is wrong with it."""

    name: str
    kind: str  # function, class, method, property
    problems_doc: list[str] = field(default_factory=list)
    problems_hints: list[str] = field(default_factory=list)


def public_modules() -> list[Any]:
    """``mlayer`` and its public submodules, imported."""
    import mlayer

    mods = [mlayer]
    for info in pkgutil.walk_packages(mlayer.__path__, "mlayer."):
        parts = info.name.split(".")
        if any(p.startswith("_") for p in parts) or info.name.startswith(_SKIP_PREFIXES):
            continue
        mods.append(importlib.import_module(info.name))
    return mods


def _public_names(mod: Any) -> list[str]:
    names = getattr(mod, "__all__", None)
    if names is not None:
        return list(names)
    return [n for n, obj in vars(mod).items()
            if not n.startswith("_") and (inspect.isfunction(obj) or inspect.isclass(obj))
            and getattr(obj, "__module__", None) == mod.__name__]


def _sections(doc: str) -> dict[str, list[str]]:
    """The numpy-style sections of a (cleaned) docstring: title -> its lines."""
    lines = doc.splitlines()
    out: dict[str, list[str]] = {}
    current = None
    i = 0
    while i < len(lines):
        line = lines[i]
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if (line.strip() and not line.startswith(" ") and re.fullmatch(r"-{3,}", nxt.strip())
                and len(nxt.strip()) == len(line.strip())):
            current = line.strip()
            out[current] = []
            i += 2
            continue
        if current is not None:
            out[current].append(line)
        i += 1
    return out


def _documented_names(lines: list[str]) -> set[str]:
    """Names of a Parameters section: the unindented lines ``name : type`` or ``a, b``."""
    names: set[str] = set()
    for line in lines:
        if not line.strip() or line.startswith(" "):
            continue
        head = line.split(" : ")[0].rstrip(":").strip()
        for part in head.split(","):
            names.add(part.strip().lstrip("*").strip("`"))
    return names


def _check_doc(entry: Entry, obj: Any, params: list[str], returns: bool,
               param_sections: tuple[str, ...] = ("Parameters",)) -> None:
    doc = inspect.getdoc(obj) if not isinstance(obj, property) else (obj.__doc__ or "")
    if not doc or not doc.strip():
        entry.problems_doc.append("no docstring")
        return
    doc = inspect.cleandoc(doc)
    if not doc.splitlines()[0].strip():
        entry.problems_doc.append("no summary line")
    sections = _sections(doc)
    if params:
        have = [s for s in param_sections if s in sections]
        if not have:
            entry.problems_doc.append(f"no {'/'.join(param_sections)} section")
        else:
            named: set[str] = set()
            for s in have:
                named |= _documented_names(sections[s])
            missing = [p for p in params if p not in named and not p.startswith("_")]
            if missing:
                entry.problems_doc.append(f"parameters not documented: {missing}")
    if returns and "Returns" not in sections and "Yields" not in sections:
        entry.problems_doc.append("no Returns section")
    if doc.count("``") % 2:
        entry.problems_doc.append("unbalanced ``")
    if isinstance(obj, property) or type(obj).__name__ == "cached_property":
        # napoleon reads "TYPE: text" in a property's first line as its type
        first = re.sub(r":[a-z]+:`[^`]*`|``[^`]*``|`[^`]*`", "", doc.splitlines()[0])
        if ":" in first:
            entry.problems_doc.append("a colon in the first line (napoleon reads a type)")


def _signature(obj: Any) -> inspect.Signature | None:
    try:
        return inspect.signature(obj)
    except (TypeError, ValueError):
        return None


def _params(sig: inspect.Signature, drop_first: bool) -> list[inspect.Parameter]:
    ps = list(sig.parameters.values())
    if drop_first and ps:
        ps = ps[1:]
    return ps


def _returns_something(annotation: Any) -> bool:
    return annotation not in (None, "None", inspect.Signature.empty)


def _check_function(entry: Entry, fn: Callable[..., Any], drop_first: bool,
                    doc_of: Any = None) -> None:
    sig = _signature(fn)
    if sig is None:
        entry.problems_hints.append("no signature")
        return
    ps = _params(sig, drop_first)
    for p in ps:
        if p.annotation is inspect.Parameter.empty:
            entry.problems_hints.append(f"parameter {p.name!r} not annotated")
    if sig.return_annotation is inspect.Signature.empty:
        entry.problems_hints.append("return not annotated")
    _check_doc(entry, fn if doc_of is None else doc_of, [p.name for p in ps],
               _returns_something(sig.return_annotation))


def _check_class(entry: Entry, cls: type) -> None:
    fields = getattr(cls, "_fields", None)
    if issubclass(cls, tuple) and fields is not None:  # a NamedTuple: its fields
        hints = getattr(cls, "__annotations__", {})
        params = list(fields)
        entry.problems_hints += [f"field {f!r} not annotated" for f in params if f not in hints]
        _check_doc(entry, cls, params, False, ("Parameters", "Attributes"))
        return
    init = None
    for name in ("__init__", "__new__"):
        if name in vars(cls):
            init = getattr(cls, name)
            break
    if init is None:  # inherited: documented and checked with the class that defines it
        _check_doc(entry, cls, [], False)
        return
    sig = _signature(init)
    if sig is None:
        entry.problems_hints.append("no constructor signature")
        return
    ps = _params(sig, True)
    for p in ps:
        if p.annotation is inspect.Parameter.empty:
            entry.problems_hints.append(f"parameter {p.name!r} not annotated")
    if sig.return_annotation is inspect.Signature.empty and init.__name__ == "__init__":
        entry.problems_hints.append("__init__ return not annotated (-> None)")
    _check_doc(entry, cls, [p.name for p in ps], False, ("Parameters", "Attributes"))


def _class_members(cls: type, qual: str) -> Iterator[Entry]:
    for name, raw in vars(cls).items():
        if name.startswith("_") and name != "__call__":
            continue
        if isinstance(raw, (property, functools.cached_property)):
            entry = Entry(f"{qual}.{name}", "property")
            fget = raw.fget if isinstance(raw, property) else raw.func
            if fget is None:
                continue
            sig = _signature(fget)
            if sig is not None and sig.return_annotation is inspect.Signature.empty:
                entry.problems_hints.append("return not annotated")
            _check_doc(entry, raw, [], False)
            yield entry
        elif isinstance(raw, (classmethod, staticmethod)):
            entry = Entry(f"{qual}.{name}", "method")
            _check_function(entry, getattr(cls, name), False)
            yield entry
        elif inspect.isfunction(raw):
            entry = Entry(f"{qual}.{name}", "method")
            _check_function(entry, raw, True)
            yield entry


def public_callables() -> list[Entry]:
    """Every public callable of the package, each once, with its problems."""
    seen: set[int] = set()
    entries: list[Entry] = []
    for mod in public_modules():
        for name in _public_names(mod):
            obj = getattr(mod, name)
            if id(obj) in seen or not (inspect.isfunction(obj) or inspect.isclass(obj)):
                continue
            seen.add(id(obj))
            qual = f"{obj.__module__}.{obj.__qualname__}"
            if inspect.isclass(obj):
                entry = Entry(qual, "class")
                _check_class(entry, obj)
                entries.append(entry)
                entries += list(_class_members(obj, qual))
            else:
                entry = Entry(qual, "function")
                _check_function(entry, obj, False)
                entries.append(entry)
    return entries


@pytest.fixture(scope="module")
def entries() -> list[Entry]:
    return public_callables()


def test_the_walk_finds_the_api(entries: list[Entry]) -> None:
    names = {e.name for e in entries}
    # a few that must be there, so that an empty or broken walk cannot pass
    for expected in ("mlayer.io.bvh.read_bvh", "mlayer.model.motion.Motion",
                     "mlayer.model.motion.Motion.positions", "mlayer.model.quat.mul",
                     "mlayer.errors.check",
                     "mlayer.layers.layers.decompose"):
        assert expected in names
    assert len(entries) > 150


def test_numpy_docstrings(entries: list[Entry]) -> None:
    bad = [f"{e.name}: {'; '.join(e.problems_doc)}" for e in entries if e.problems_doc]
    assert not bad, f"{len(bad)} public callables without a numpy-style docstring:\n" + \
        "\n".join(bad)


def test_type_hints(entries: list[Entry]) -> None:
    bad = [f"{e.name}: {'; '.join(e.problems_hints)}" for e in entries if e.problems_hints]
    assert not bad, f"{len(bad)} public callables not fully annotated:\n" + "\n".join(bad)


def test_examples_run() -> None:
    """The Examples sections are doctests: every one runs and prints what it shows."""
    import doctest

    failed, attempted = 0, 0
    for mod in public_modules():
        result = doctest.testmod(mod, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
        failed += result.failed
        attempted += result.attempted
    assert attempted > 0
    assert failed == 0


def test_sections_parser() -> None:
    doc = "Summary.\n\nParameters\n----------\nx, y : float\n    Coordinates.\n*args : Any\n" \
          "\nReturns\n-------\nfloat\n"
    sections = _sections(doc)
    assert set(sections) == {"Parameters", "Returns"}
    assert _documented_names(sections["Parameters"]) == {"x", "y", "args"}
    entry = Entry("f", "function")
    _check_doc(entry, type("T", (), {"__doc__": doc}), ["x", "y", "z"], True)
    assert entry.problems_doc == ["parameters not documented: ['z']"]


if __name__ == "__main__":
    found = public_callables()
    docs_ok = sum(not e.problems_doc for e in found)
    hints_ok = sum(not e.problems_hints for e in found)
    verbose = "-v" in sys.argv
    for e in found:
        if verbose and (e.problems_doc or e.problems_hints):
            print(f"{e.name} [{e.kind}]: {'; '.join(e.problems_doc + e.problems_hints)}")
    print(f"{len(found)} public callables: {docs_ok} with numpy-style docstrings, "
          f"{hints_ok} fully annotated")
