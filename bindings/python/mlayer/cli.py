"""The `mlayer` command line: argparse over the Python API.

Exit codes: 0 success, 1 a library or data error (one line on stderr naming the file, the
line and the status), 2 a usage error. Outputs are written to a temporary file and renamed
into place, so a failed run never leaves a half-written file.
"""
from __future__ import annotations

import argparse
import sys

from . import __version__, library_version
from .errors import Error

# Subcommands register here: name -> (add_arguments(parser), run(args) -> int, help)
_COMMANDS: dict = {}


def command(name: str, help: str):
    """Decorator registering `run(args)` as a subcommand; `run.arguments(p)` adds its options."""
    def wrap(run):
        _COMMANDS[name] = (run, help)
        return run
    return wrap


@command("version", "print the package and C library versions")
def _cmd_version(args) -> int:
    print(f"mlayer {__version__} (C library {library_version()})")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="mlayer",
                                description="Smooth motion layers for character animation.")
    p.add_argument("--version", action="version",
                   version=f"mlayer {__version__} (C library {library_version()})")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    for name, (run, help_text) in _COMMANDS.items():
        sp = sub.add_parser(name, help=help_text, description=help_text)
        add = getattr(run, "arguments", None)
        if add is not None:
            add(sp)
        if name not in _NO_CLIPS:
            sp.add_argument("--strict", action="store_true",
                            help="refuse BVH files that deviate from the format (extra or "
                                 "missing frame lines, data after the frames) instead of "
                                 "reading them with a warning")
            sp.add_argument("--up", choices=("auto", "x", "y", "z"), default="auto",
                            help="the clips' up axis (default auto: detected from the feet, "
                                 "or the floor; `mlayer info` shows what was found)")
            sp.add_argument("--trim", type=_trim_arg, default=None, metavar="auto|N",
                            help="drop frames at the start of each clip read: auto drops the "
                                 "T-pose and blend frames a converter put there (CMU files), N "
                                 "the first N frames (default: keep every frame)")
            sp.add_argument("--units", choices=("m", "cm", "mm", "in", "ft"), default=None,
                            help="the clips' length unit (default: the one their body height "
                                 "suggests, when it does; thresholds do not depend on it)")
        sp.set_defaults(_run=run)
    return p


def _trim_arg(text: str):
    """--trim: "auto" or a frame count >= 0."""
    if text == "auto":
        return text
    try:
        n = int(text)
    except ValueError:
        n = -1
    if n < 0:
        raise argparse.ArgumentTypeError(f"expected 'auto' or a frame count >= 0, got {text!r}")
    return n


def _show_trim(command: str):
    """The report of reading_trim for the CLI: one line on stderr per clip trimmed."""
    def show(name: str, n: int) -> None:
        print(f"mlayer {command}: {name}: trimmed {n} frame{'s' if n != 1 else ''} at the start",
              file=sys.stderr)
    return show


# Subcommands that read no clip (no --strict, no --up, no --trim, no --units).
_NO_CLIPS = {"version", "generate"}  # (batch passes them to its workers)


def _show_parse_warning(command: str):
    """warnings.showwarning for the CLI: one line on stderr per warning."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"mlayer {command}: warning: {message}", file=sys.stderr)
    return show


# Modules that define subcommands, one per line (cli_demo last: it uses the others).
_SUBCOMMAND_MODULES = (
    "cli_info",
    "cli_layers",
    "cli_render",
    "cli_stream",
    "cli_contacts",
    "cli_resample",
    "cli_view",
    "cli_batch",
    "cli_primitives",
    "cli_demo",
)


def _load_subcommands() -> None:
    """Import the modules that define subcommands (each registers itself)."""
    import importlib
    for mod in _SUBCOMMAND_MODULES:
        importlib.import_module(f".{mod}", __package__)


def main(argv: list[str] | None = None) -> int:
    _load_subcommands()
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "_run", None):
        parser.print_help(sys.stderr)
        return 2
    import warnings
    from .bvh import reading_units, strict_reading
    from .up_axis import reading_up
    from .trimming import reading_trim
    from .errors import MlayerWarning
    try:
        up = getattr(args, "up", "auto")
        with warnings.catch_warnings(), strict_reading(getattr(args, "strict", False)), \
                reading_up(None if up == "auto" else up), \
                reading_trim(getattr(args, "trim", None), _show_trim(args.command)), \
                reading_units(getattr(args, "units", None)):
            warnings.simplefilter("always", MlayerWarning)
            warnings.showwarning = _show_parse_warning(args.command)
            return int(args._run(args) or 0)
    except Error as e:
        where = ""
        path, line = getattr(e, "path", None), getattr(e, "line", None)
        if path:
            where = f"{path}:{line}: " if line else f"{path}: "
            if str(e).startswith(where):  # e.g. ParseError messages already say where
                where = ""
        print(f"mlayer {args.command}: error: {where}{e}", file=sys.stderr)
        return 1
    except OSError as e:
        print(f"mlayer {args.command}: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"mlayer {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
