"""The clips of a benchmark run: folders of .bvh files, named, filtered and read.

Used by bench_plausibility.py. A clip is named by its path relative to the folder it was found
under (the file name for a flat folder), so that two folders' files stay apart when their names
match; a name found twice is prefixed by its folder's name.
"""
from __future__ import annotations

import fnmatch
import pathlib
import warnings
from dataclasses import dataclass

import mlayer

REPO = pathlib.Path(__file__).resolve().parents[2]


def shared_dir() -> pathlib.Path:
    """The shared real clips beside the repository: ``<repo>/../shared/data/mocap``."""
    return REPO.parent / "shared" / "data" / "mocap"


@dataclass(frozen=True)
class Clip:
    """One .bvh file of the run: its display name and its path."""
    name: str
    path: pathlib.Path


def find_clips(dirs: list[pathlib.Path], pattern: str = "*") -> list[Clip]:
    """Every .bvh under each of ``dirs`` (recursively, hidden folders and files left out,
    sorted, each file once), whose name or file name matches the glob ``pattern``. Folders
    that do not exist raise FileNotFoundError.
    """
    seen: set[pathlib.Path] = set()
    clips: list[Clip] = []
    names: set[str] = set()
    for d in dirs:
        d = pathlib.Path(d)
        if not d.is_dir():
            raise FileNotFoundError(f"no such folder: {d}")
        for p in sorted(d.rglob("*")):
            rel = p.relative_to(d)
            if p.suffix.lower() != ".bvh" or not p.is_file() or any(
                    part.startswith(".") for part in rel.parts):
                continue
            rp = p.resolve()
            if rp in seen:
                continue
            seen.add(rp)
            name = rel.as_posix()
            if name in names:
                name = f"{d.name}/{name}"
            if not (fnmatch.fnmatch(name, pattern) or fnmatch.fnmatch(p.name, pattern)):
                continue
            names.add(name)
            clips.append(Clip(name, p))
    return clips


def read_clip(path: pathlib.Path, max_frames: int | None = None
              ) -> tuple[mlayer.Motion, list[str]]:
    """``mlayer.read_bvh(path)`` cut to its first ``max_frames`` frames (all when None or 0),
    and the texts of the warnings the reader gave (a declared frame count that differs, a
    missing last line end, ...)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = mlayer.read_bvh(path)
    if max_frames and m.n_frames > max_frames:
        m = m[:max_frames]
    notes = [str(w.message).replace(str(path), path.name) for w in caught]
    return m, notes
