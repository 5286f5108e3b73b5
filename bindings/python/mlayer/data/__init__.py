"""Sample data shipped with mlayer: one CMU motion clip, free for all uses.

``cmu_131_01_mj_style_walk.bvh``: CMU subject 131, trial 01 ("start, walk, stop", 994 frames at
120 fps). The data used in this project was obtained from mocap.cs.cmu.edu. The database was
created with funding from NSF EIA-0196217. See README.md beside this file for its provenance.
"""
from __future__ import annotations

import pathlib

from ..io.bvh import read_bvh
from ..model.motion import Motion

__all__ = ["SAMPLE", "sample_path", "load_sample"]

SAMPLE = "cmu_131_01_mj_style_walk.bvh"


def sample_path() -> pathlib.Path:
    """Path of the bundled CMU clip.

    Returns
    -------
    pathlib.Path
        A real file inside the installed package.
    """
    return pathlib.Path(__file__).resolve().parent / SAMPLE


def load_sample() -> Motion:
    """The bundled CMU clip, read.

    Returns
    -------
    Motion
        994 frames at 120 fps.

    Examples
    --------
    >>> import mlayer
    >>> m = mlayer.data.load_sample()
    >>> m.n_frames, round(m.fps)
    (994, 120)
    """
    return read_bvh(sample_path())
