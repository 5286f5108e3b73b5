"""What the examples share: their command line (an input and an output folder)."""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import mlayer


def arguments(description: str, *, inputs: str = "clip") -> argparse.Namespace:
    """Parse ``[INPUT] [--out DIR]``: INPUT defaults to the bundled clip (CMU 131_01), DIR to a
    new temporary folder. Returns the namespace with ``input`` and ``out`` as Paths."""
    p = argparse.ArgumentParser(description=description)
    p.add_argument("input", nargs="?", type=Path, default=None,
                   help=f"the {inputs} (default: the clip bundled with mlayer)")
    p.add_argument("--out", type=Path, default=None,
                   help="folder for the outputs (default: a new temporary folder)")
    args = p.parse_args()
    if args.input is None:
        args.input = mlayer.data.sample_path()
    if args.out is None:
        args.out = Path(tempfile.mkdtemp(prefix="mlayer-example-"))
    args.out.mkdir(parents=True, exist_ok=True)
    return args
