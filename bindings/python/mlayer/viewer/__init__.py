"""`mlayer view`: an interactive viewer in the browser (paper 1, section 5.1: alpha and the
target length as sliders).

A local HTTP server (:mod:`.server`, Python stdlib) serves one page (``index.html``,
``viewer.js``, ``viewer.css``, package data in this folder: a Canvas 2D stick-figure renderer
written for mlayer, no third-party code, works offline) and a JSON API that recomputes the
processed motion through the C core on every slider move (:mod:`.session`).
"""
from __future__ import annotations

import warnings as _warnings
from typing import Any as _Any

from .server import ViewerServer, is_loopback, make_server
from .session import ViewerClip, body_parts, load_clips, parse_params

__all__ = ["ViewerServer", "make_server", "is_loopback", "ViewerClip", "body_parts", "load_clips",
           "parse_params"]


def __getattr__(name: str) -> _Any:
    """``Clip``: the old name of :class:`ViewerClip` (issue 40: ``mlayer.pipeline.pipeline.Clip``
    is the one ``Clip``), kept for one minor release with a DeprecationWarning."""
    if name == "Clip":
        _warnings.warn("mlayer.viewer.Clip is renamed mlayer.viewer.ViewerClip",
                       DeprecationWarning, stacklevel=2)
        return ViewerClip
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
