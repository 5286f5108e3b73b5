"""The `mlayer` command line (the console script and ``python -m mlayer`` call :func:`main`).

One module per group of commands (info, layers, render, stream, contacts, retiming, view,
batch, primitives, demo, convert); each declares its commands with ``_command.command``: name, help,
arguments, whether it reads clips, its inputs and its outputs. ``_main`` lists them, builds the
parser and runs one, with the shared checks and error handling.
"""
from ._main import COMMANDS, build_parser, main

__all__ = ["main", "build_parser", "COMMANDS"]
