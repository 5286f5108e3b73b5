"""Shared pieces of the Python benchmark scripts: the shared clips' folder and a median timer.

The scripts run as `python bench/python/<script>.py`, so this folder is on sys.path.
"""
from __future__ import annotations

import os
import pathlib
import time

import numpy as np

REPO = pathlib.Path(__file__).resolve().parents[2]


def mocap_dir() -> pathlib.Path:
    """The shared real clips: $MLR_TEST_MOCAP_DIR, or ../shared/data/mocap beside the repo."""
    env = os.environ.get("MLR_TEST_MOCAP_DIR")
    return pathlib.Path(env) if env else REPO.parent / "shared" / "data" / "mocap"


def median_seconds(fn, repeat: int) -> float:
    """Median wall time of `repeat` calls of fn() (the machines are shared: medians, not means)."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))
