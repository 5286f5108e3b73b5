"""Finding the clips of a batch: folders, globs, files, the output folder left out, and the
symbolic links that are not read as clips said, not silently lost."""
from __future__ import annotations

import glob
import os
import pathlib
from collections.abc import Iterable

from ..errors import InvalidArgumentError

__all__ = ["find_inputs"]


def _is_bvh(p: pathlib.Path) -> bool:
    return p.suffix.lower() == ".bvh" and p.is_file()


def _under(path: str | os.PathLike[str], folder: str | os.PathLike[str] | None) -> bool:
    """Whether path (resolved) is folder (resolved) or inside it."""
    if folder is None:
        return False
    p, f = os.path.realpath(path), os.path.realpath(folder)
    return p == f or p.startswith(f.rstrip(os.sep) + os.sep)


def _walk(folder: pathlib.Path, exclude: str | os.PathLike[str] | None,
          links: list[tuple[str | pathlib.Path, str]]
          ) -> list[tuple[pathlib.Path, pathlib.PurePath]]:
    """The .bvh files below folder (hidden parts and `exclude` left out). Symbolic links to
    folders are not followed (a link may lead out of the tree or back into it) and dangling
    links cannot be read: both are appended to ``links`` as (path, note)."""
    if _under(folder, exclude):
        exclude = None  # the output folder is this folder (or holds it): the overwrite check
    out: list[tuple[pathlib.Path, pathlib.PurePath]] = []
    for f in sorted(folder.rglob("*")):
        rel = f.relative_to(folder)
        if any(part.startswith(".") for part in rel.parts) or _under(f, exclude):
            continue
        if f.is_symlink():
            if not f.exists():
                links.append((f, "dangling link (its target does not exist): skipped"))
                continue
            if f.is_dir():
                links.append((f, "link to a folder: not followed, its clips are skipped"))
                continue
            if not _under(f, folder):
                links.append((f, "link leading out of the input folder: refused, not read"))
                continue
        if _is_bvh(f):
            out.append((f, rel))
    return out


def _glob(pattern: str, exclude: str | os.PathLike[str] | None,
          links: list[tuple[str | pathlib.Path, str]]
          ) -> list[tuple[pathlib.Path, pathlib.PurePath]]:
    """The .bvh files matching a glob, relative to its fixed prefix. Python's glob follows
    links to folders ("**" included): each one crossed is noted in ``links``, as are dangling
    links that match."""
    root = pathlib.Path(pattern)
    while glob.has_magic(str(root)):
        root = root.parent
    if _under(root, exclude):
        exclude = None
    out: list[tuple[pathlib.Path, pathlib.PurePath]] = []
    crossed: set[pathlib.Path] = set()
    for name in sorted(glob.glob(pattern, recursive=True)):
        f = pathlib.Path(name)
        if _under(f, exclude):
            continue
        if f.is_symlink() and not f.exists():
            links.append((f, "dangling link (its target does not exist): skipped"))
            continue
        if f.is_symlink() and f.is_file() and not _under(f, root):
            links.append((f, "link leading out of the pattern's folder: refused, not read"))
            continue
        if not _is_bvh(f):
            continue
        rel = f.relative_to(root)
        for k in range(1, len(rel.parts)):
            d = root.joinpath(*rel.parts[:k])
            if d.is_symlink() and d not in crossed:
                crossed.add(d)
                links.append((d, "link to a folder: followed (the glob reaches its clips)"))
        out.append((f, rel))
    return out


def find_inputs(inputs: str | os.PathLike[str] | Iterable[str | os.PathLike[str]], *,
                exclude: str | os.PathLike[str] | None = None,
                links: list[tuple[str | pathlib.Path, str]] | None = None
                ) -> list[tuple[pathlib.Path, pathlib.PurePath]]:
    """The clips of a batch.

    Parameters
    ----------
    inputs : str, os.PathLike or a list of them
        A folder (every .bvh below it, sub-folders kept), a glob pattern (``**`` recurses;
        paths relative to the pattern's fixed prefix), a file, or a list of these.
    exclude : str or os.PathLike, optional
        A folder whose files are never inputs (batch passes its output folder, so an output
        folder inside the input folder can be resumed).
    links : list, optional
        Receives (path, note) for each symbolic link that was not simply read: links to
        folders (not followed in a folder walk; followed by a glob, as Python's glob does)
        and dangling links (skipped). Links to files inside the input folder (a glob's
        fixed prefix) are read as clips (each link a clip of its own); a link to a file
        outside it (``x.bvh -> /etc/passwd``) is refused and listed, never read.

    Returns
    -------
    list of (pathlib.Path, pathlib.PurePath)
        (input path, output path relative to OUT_DIR without extension) for every clip;
        sorted, no duplicates.

    Raises
    ------
    mlayer.InvalidArgumentError
        For an input that is no file, folder or matching glob, or a dangling link.
    """
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [inputs]
    links = [] if links is None else links
    found: dict[pathlib.Path, pathlib.PurePath] = {}
    for item in inputs:
        s = os.fspath(item)
        p = pathlib.Path(s)
        if p.is_dir():
            pairs = _walk(p, exclude, links)
        elif glob.has_magic(s):
            pairs = _glob(s, exclude, links)
        elif p.is_file():
            pairs = [(p, pathlib.PurePath(p.name))]
        elif p.is_symlink():
            raise InvalidArgumentError(f"{s}: dangling link (its target does not exist)")
        else:
            raise InvalidArgumentError(f"{s}: no such file, folder or matching glob")
        for f, rel in pairs:
            # absolute, symlinks kept: links to one file are separate clips (corpus copies)
            found.setdefault(pathlib.Path(os.path.abspath(f)), rel.with_suffix(""))
    return sorted(found.items(), key=lambda kv: str(kv[1]))
