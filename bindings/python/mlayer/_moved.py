"""The module paths of before the subpackages (issue 40), kept for one minor release.

``import mlayer.contacts`` (or ``from mlayer.contacts import ...``) gives the module that
moved to ``mlayer.guards.contacts``, with a DeprecationWarning naming the new path;
``mlayer.contacts`` as an attribute likewise (``mlayer.__getattr__``). Five old paths cannot be
kept: ``mlayer.layers``, ``mlayer.manifold`` and ``mlayer.pipeline`` are now subpackages (their
modules are ``mlayer.layers.layers``, ``mlayer.manifold.manifold``,
``mlayer.pipeline.pipeline``), and ``mlayer.mirror`` and ``mlayer.retarget`` are the
functions (the modules are ``mlayer.model.mirroring`` and ``mlayer.pipeline.retarget``).

The new module is imported by name (importlib) when an old path is asked for, so that this
base module names no layer above it (docs/ARCHITECTURE.md, "The Python package").
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings
from types import ModuleType
from typing import Any

#: old module path -> new module path
MOVED: dict[str, str] = {
    "mlayer._pipeline": "mlayer.layers._pipeline",
    "mlayer._rig": "mlayer.model._rig",
    "mlayer.alpha_curve": "mlayer.layers.alpha_curve",
    "mlayer.amass": "mlayer.io.amass",
    "mlayer.bvh": "mlayer.io.bvh",
    "mlayer.cleanup": "mlayer.guards.cleanup",
    "mlayer.clustering": "mlayer.manifold.clustering",
    "mlayer.contacts": "mlayer.guards.contacts",
    "mlayer.features": "mlayer.manifold.features",
    "mlayer.generate_guards": "mlayer.manifold.generate_guards",
    "mlayer.gltf": "mlayer.io.gltf",
    "mlayer.ik": "mlayer.guards.ik",
    "mlayer.limits": "mlayer.guards.limits",
    "mlayer.markov": "mlayer.manifold.markov",
    "mlayer.metrics": "mlayer.guards.metrics",
    "mlayer.mixture": "mlayer.manifold.mixture",
    "mlayer.motion": "mlayer.model.motion",
    "mlayer.one_euro": "mlayer.layers.one_euro",
    "mlayer.plausibility": "mlayer.guards.plausibility",
    "mlayer.plot": "mlayer.plotting.plot",
    "mlayer.primitives": "mlayer.manifold.primitives",
    "mlayer.quat": "mlayer.model.quat",
    "mlayer.render": "mlayer.plotting.render",
    "mlayer.retiming": "mlayer.pipeline.retiming",
    "mlayer.root_motion": "mlayer.model.root_motion",
    "mlayer.smoothing": "mlayer.layers.smoothing",
    "mlayer.smpl": "mlayer.io.smpl",
    "mlayer.som": "mlayer.manifold.som",
    "mlayer.stream": "mlayer.pipeline.stream",
    "mlayer.trimming": "mlayer.model.trimming",
    "mlayer.units": "mlayer.model.units",
    "mlayer.up_axis": "mlayer.model.up_axis",
}


def moved(old: str) -> ModuleType:
    """The module that ``old`` (a path of MOVED) names now, with a DeprecationWarning."""
    new = MOVED[old]
    warnings.warn(f"{old} is now {new} (the package is in subpackages since 0.3.0); the old "
                  "path goes in the next minor release", DeprecationWarning, stacklevel=3)
    return importlib.import_module(new)


class _Finder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds the old paths of MOVED; the module made is the new one itself."""

    def find_spec(self, fullname: str, path: Any, target: Any = None
                  ) -> importlib.machinery.ModuleSpec | None:
        if fullname not in MOVED:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        return moved(spec.name)

    def exec_module(self, module: ModuleType) -> None:
        pass  # the new module ran when it was imported


def install() -> None:
    """Put the finder on sys.meta_path once (a reload of the package adds no second one)."""
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.append(_Finder())
