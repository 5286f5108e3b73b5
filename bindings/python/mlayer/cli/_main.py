"""The `mlayer` command line: argparse over the Python API.

Exit codes: 0 success, 1 a library or data error (one line on stderr naming the file, the
line and the status), 2 a usage error. Outputs are written to a temporary file and renamed
into place, so a failed run never leaves a half-written file; before any work, every output
path is checked (its extension, its folder, not an input: ``_command.check_outputs``) and
every optional module the command needs with its arguments is imported
(``_command.check_requires``: a missing one is one line naming the extra to install).

The library's steps (the ``mlayer`` logger, INFO and above) are shown on stderr, one line
each, as the message alone. A BVH output given as ``-`` goes to the standard output; what the
command prints then goes to stderr.

The commands are declared in their modules (``_command.command``) and listed in COMMANDS.
"""
from __future__ import annotations

from typing import Any

import argparse
import contextlib
import logging
import os
import re
import shutil
import sys
import tempfile

from .._version import __version__, library_version
from ..errors import Error, InvalidArgumentError, MlayerWarning
from ..io.bvh import reading_units, strict_reading
from ..model.trimming import reading_trim
from ..model.up_axis import reading_up
from . import (batch, contacts, convert, demo, info, layers, mirror, primitives, render, retarget,
               retiming, rootmotion, stream, view)
from ._command import (add_parser, check_outputs, check_requires, command, show_parse_warning,
                       show_trim, stdout_outputs)


@command("version", "print the package and C library versions", reads_clips=False)
def cmd_version(args) -> int:
    print(f"mlayer {__version__} (C library {library_version()})")
    return 0


#: Every subcommand, in the order of `mlayer --help`.
COMMANDS = (
    cmd_version,
    info.cmd_info,
    layers.cmd_denoise,
    layers.cmd_stylize,
    layers.cmd_layers,
    render.cmd_render,
    stream.cmd_stream,
    contacts.cmd_contacts,
    retiming.cmd_resample,
    retiming.cmd_timewarp,
    mirror.cmd_mirror,
    retarget.cmd_retarget,
    rootmotion.cmd_rootmotion,
    view.cmd_view,
    batch.cmd_batch,
    primitives.cmd_primitives,
    primitives.cmd_generate,
    demo.cmd_demo,
    convert.cmd_convert,
)


class Parser(argparse.ArgumentParser):
    """The parser of the command line and of each command (argparse gives a subcommand's
    parser the class of its parent's): a usage error is one line on stderr, the message and a
    pointer to ``--help`` (``mlayer stylize: error: ... (see mlayer stylize --help)``), and
    exit status 2, not argparse's usage block."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")

    def parse_args(self, args=None, namespace=None):
        """argparse's, with arguments no parser knows reported by the command's parser (a
        command without positional arguments leaves them to the top level)."""
        ns, extra = self.parse_known_args(args, namespace)
        if extra:
            sub = _command_parser(self, getattr(ns, "command", None) or "") or self
            sub.error("unrecognized arguments: " + " ".join(extra))
        return ns


def build_parser() -> argparse.ArgumentParser:
    """The parser of the ``mlayer`` command line, with every command of :data:`COMMANDS`.

    Returns
    -------
    argparse.ArgumentParser
        A new parser.
    """
    p = Parser(prog="mlayer",
               description="Smooth motion layers for character animation.")
    p.add_argument("--version", action="version",
                   version=f"mlayer {__version__} (C library {library_version()})")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    for cmd in COMMANDS:
        add_parser(sub, cmd)
    return p


class _StderrHandler(logging.Handler):
    """The library's log records as lines on the current sys.stderr (looked up at each
    record, so a redirected or captured stderr gets them)."""

    def emit(self, record) -> None:
        try:
            print(self.format(record), file=sys.stderr, flush=True)
        except Exception:  # noqa: BLE001  (logging must not raise)
            self.handleError(record)


@contextlib.contextmanager
def _showing_log():
    """The `mlayer` logger's INFO records on stderr for one command."""
    log = logging.getLogger("mlayer")
    handler = _StderrHandler(logging.INFO)
    handler.setFormatter(logging.Formatter("%(message)s"))
    old = log.level
    log.addHandler(handler)
    if log.getEffectiveLevel() > logging.INFO:
        log.setLevel(logging.INFO)
    try:
        yield
    finally:
        log.removeHandler(handler)
        log.setLevel(old)


_NAMED = re.compile(r"\b(?:the )?(?:option|flag) ([a-z][a-z0-9_]*)\b")


def cli_spelling(message: str, flags) -> str:
    """A library message with the option and flag names it quotes ("option lam_c", "flag
    allow_extreme": the C and Python name) spelled as the command line does ("--lam-c"), for
    the names that are flags of the command (``flags``: its option strings). The rule is the
    mechanical one of docs/OPTIONS.md, so no message is rewritten case by case."""
    def spell(m):
        flag = "--" + m.group(1).replace("_", "-")
        return flag if flag in flags else m.group(0)
    return _NAMED.sub(spell, message)


def _command_parser(parser: argparse.ArgumentParser,
                    command: str) -> argparse.ArgumentParser | None:
    """A subcommand's parser, or None."""
    p: Any = parser  # argparse keeps the subparsers in private attributes
    for action in p._subparsers._group_actions if p._subparsers is not None else ():
        sp = action.choices.get(command)
        if sp is not None:
            return sp
    return None


def _flags(parser: argparse.ArgumentParser, command: str) -> set:
    """The option strings of a subcommand's parser."""
    sp: Any = _command_parser(parser, command)
    return set(sp._option_string_actions) if sp is not None else set()


def main(argv: list[str] | None = None) -> int:
    """Run the ``mlayer`` command line (the console script and ``python -m mlayer``).

    Errors of mlayer and of the operating system become one line on stderr
    (``mlayer COMMAND: error: ...``) and exit status 1; an interrupt gives 130.

    Parameters
    ----------
    argv : list of str, optional
        The arguments without the program name; default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit status: 0 on success, 2 without a command.
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    cmd = getattr(args, "_command", None)
    if cmd is None:
        parser.print_help(sys.stderr)
        return 2
    import warnings
    stdin_dir = tempfile.TemporaryDirectory(prefix="mlayer-stdin-")
    stdin_path = ""
    try:
        stdin_path = _stdin_inputs(cmd, args, stdin_dir.name)
        check_outputs(cmd, args)
        check_requires(cmd, args)
        up = getattr(args, "up", "auto")
        # a BVH on the standard output: the command's own lines go to stderr
        args._stdout = sys.stdout
        to_stderr = contextlib.redirect_stdout(sys.stderr) if stdout_outputs(cmd, args) \
            else contextlib.nullcontext()
        with warnings.catch_warnings(), strict_reading(getattr(args, "strict", False)), \
                reading_up(None if up == "auto" else up), \
                reading_trim(getattr(args, "trim", None), show_trim(args.command)), \
                reading_units(getattr(args, "units", None)), _showing_log(), to_stderr:
            warnings.simplefilter("always", MlayerWarning)
            warnings.showwarning = show_parse_warning(args.command)
            return int(cmd.run(args) or 0)
    except Error as e:
        where = ""
        path, line = getattr(e, "path", None), getattr(e, "line", None)
        if path and stdin_path and str(path) == stdin_path:
            path = "<stdin>"
            e = type(e)(str(e).replace(stdin_path, path))
        if path:
            where = f"{path}:{line}: " if line else f"{path}: "
            if str(e).startswith(where):  # e.g. ParseError messages already say where
                where = ""
        msg = cli_spelling(str(e), _flags(parser, args.command))
        print(f"mlayer {args.command}: error: {where}{msg}", file=sys.stderr)
        return 1
    except OSError as e:
        print(f"mlayer {args.command}: error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"mlayer {args.command}: interrupted", file=sys.stderr)
        return 130
    finally:
        stdin_dir.cleanup()


def _stdin_inputs(cmd: Any, args: argparse.Namespace, folder: str) -> str:
    """An input clip given as ``-``: the standard input, saved as a BVH file in folder, the
    argument pointing to it (once per command). Returns that file's path, or ""."""
    if not cmd.reads_clips:
        return ""
    path = ""
    for dest in cmd.inputs:
        value = getattr(args, dest, None)
        values = value if isinstance(value, list) else [value]
        if "-" not in values:
            continue
        if path or values.count("-") > 1:
            raise InvalidArgumentError("the standard input ('-') can be read only once")
        path = os.path.join(folder, "stdin.bvh")
        with open(path, "wb") as f:
            shutil.copyfileobj(sys.stdin.buffer, f)
        setattr(args, dest, [path if v == "-" else v for v in values]
                if isinstance(value, list) else path)
    return path
