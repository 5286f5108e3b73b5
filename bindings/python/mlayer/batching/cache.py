"""What makes an output up to date: its options key, its sidecar, and the temporaries a
killed writer of it may have left.

Every output ``OUT_DIR/<rel>`` has a sidecar ``OUT_DIR/.mlayer-batch/<rel>.json`` written after
the output: the input's size and modification time, the key of the options (operation, its
arguments, the variant, the read options, the mlayer version), the output's size and time and
the output's record. An output is up to date when its sidecar matches all of these.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import pathlib
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

from .._files import atomic_output, stale_temporaries
from .._version import __version__

if TYPE_CHECKING:
    from .registry import Operation

__all__ = ["SIDECAR_DIR"]

#: hidden folder of OUT_DIR holding one sidecar (.json) per output
SIDECAR_DIR = ".mlayer-batch"


def options_key(op: Operation, options: dict[str, Any], variant: dict[str, Any],
                read: dict[str, Any] | None = None) -> str:
    """The hash of what an output of `op` depends on besides its input."""
    doc = {"operation": op.name, "run": f"{op.run.__module__}.{op.run.__qualname__}",
           "options": options, "variant": variant, "mlayer": __version__}
    if read:  # (absent when the clips are read as they are: earlier keys stay valid)
        doc["read"] = read
    text = json.dumps(doc, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def sidecar_path(out_dir: pathlib.Path, out: pathlib.Path) -> pathlib.Path:
    rel = out.relative_to(out_dir)
    return out_dir / SIDECAR_DIR / rel.parent / (rel.name + ".json")


def _stat(path: str | os.PathLike[str]) -> tuple[int, int]:
    st = os.stat(path)
    return st.st_size, st.st_mtime_ns


def up_to_date(src: str, out: pathlib.Path, sidecar: pathlib.Path, key: str
               ) -> dict[str, Any] | None:
    """The stored record when `out` is complete and up to date, else None."""
    try:
        with open(sidecar, encoding="utf-8") as f:
            side = json.load(f)
        in_size, in_mtime = _stat(src)
        out_size, out_mtime = _stat(out)
    except (OSError, ValueError):
        return None
    if (side.get("options") == key and side.get("input_size") == in_size
            and side.get("input_mtime_ns") == in_mtime and side.get("output_size") == out_size
            and side.get("output_mtime_ns") == out_mtime and out_mtime >= in_mtime):
        return side.get("record") or {}
    return None


def write_sidecar(src: str, out: str, sidecar: str, key: str, record: dict[str, Any]) -> None:
    in_size, in_mtime = _stat(src)
    out_size, out_mtime = _stat(out)
    side = {"options": key, "input": src, "input_size": in_size, "input_mtime_ns": in_mtime,
            "output_size": out_size, "output_mtime_ns": out_mtime, "record": record}
    os.makedirs(os.path.dirname(sidecar), exist_ok=True)
    with atomic_output(sidecar, ".json") as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(side, f, indent=1)


def sweep(paths: Iterable[pathlib.Path]) -> None:
    """Remove the temporaries that killed writers of these outputs left
    (:func:`mlayer._files.stale_temporaries`)."""
    for out in paths:
        for t in stale_temporaries(out):
            with contextlib.suppress(OSError):
                os.unlink(t)
