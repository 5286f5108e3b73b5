"""The optional dependencies: which feature needs which module, and the one check of them.

mlayer itself needs numpy and cffi only. A feature that needs more calls :func:`require` before
it does any work; when the module cannot be imported, :class:`mlayer.MissingDependencyError`
(an ImportError) is raised with one line naming the feature and the extra that installs it::

    mlayer layers --plot needs matplotlib: pip install 'mlayer[plot]'

The extras are those of pyproject.toml's ``[project.optional-dependencies]`` (``all`` holds
every one of them):

=============  ============================  ================================================
extra          installs                      features
=============  ============================  ================================================
plot           matplotlib                    figures (mlayer.plotting.plot, the CLI's --plot
                                             options)
render         Pillow                        GIF and PNG renders (mlayer.plotting.render)
video          imageio-ffmpeg, Pillow        MP4 renders
batch          dask[distributed], crypto...  mlayer.batch on Dask (cryptography: the TLS of
                                             the embedded cluster)
progress       tqdm                          progress bars (``progress=True``)
dataframe      pandas                        Motion.to_dataframe, Motion.from_dataframe
scipy          scipy                         the scipy Rotation bridges (Motion.to_scipy,
                                             mlayer.quat.to_scipy)
=============  ============================  ================================================

The command line declares what a command needs (``requires=`` of ``cli._command.command``,
conditionally on its arguments) and checks it with the output check, before any work: a
missing module is one line on stderr and exit status 1, and nothing is written.
"""
from __future__ import annotations

import importlib
from types import ModuleType

from .errors import MissingDependencyError

__all__ = ["EXTRAS", "require", "available"]

#: module -> (what pip installs, the mlayer extra that installs it)
EXTRAS = {
    "matplotlib": ("matplotlib", "plot"),
    "PIL": ("Pillow", "render"),
    "imageio_ffmpeg": ("imageio-ffmpeg", "video"),
    "distributed": ("dask[distributed]", "batch"),
    "cryptography": ("cryptography", "batch"),
    "tqdm": ("tqdm", "progress"),
    "pandas": ("pandas", "dataframe"),
    "scipy": ("scipy", "scipy"),
}


def _import(module: str) -> ModuleType | None:
    try:
        return importlib.import_module(module)
    except ImportError:
        return None


def available(module: str) -> bool:
    """Whether `module` can be imported (it is then imported)."""
    return _import(module) is not None


def message(module: str, feature: str, extra: str | None = None) -> str:
    """The one line of a missing `module`: "FEATURE needs DIST: pip install 'mlayer[EXTRA]'"."""
    dist, default_extra = EXTRAS.get(module, (module, None))
    extra = extra or default_extra
    how = f"pip install 'mlayer[{extra}]'" if extra else f"pip install {dist}"
    return f"{feature} needs {dist}: {how}"


def require(module: str, *, feature: str, extra: str | None = None) -> ModuleType:
    """Import `module` and return it, or raise :class:`mlayer.MissingDependencyError` with the
    one line of :func:`message` (`feature`: what needs it, e.g. "mlayer layers --plot"; `extra`:
    the mlayer extra, by default the one of :data:`EXTRAS`)."""
    mod = _import(module)
    if mod is None:
        extra = extra or EXTRAS.get(module, (module, None))[1]
        raise MissingDependencyError(message(module, feature, extra), module=module,
                                     extra=extra or "", feature=feature)
    return mod
