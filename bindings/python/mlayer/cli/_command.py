"""How a command of the `mlayer` command line is declared, and the checks every command shares.

A command is declared once, by the :func:`command` decorator over its ``run(args) -> int``::

    @command("stylize", "exaggerate or flatten a clip's style ...", arguments=_arguments,
             reads_clips=True, inputs=("input",), outputs={"output": BVH})
    def cmd_stylize(args) -> int: ...

- ``arguments(parser)`` adds the command's own arguments (argparse);
- ``reads_clips`` adds the shared reading options --strict, --up, --trim and --units (their
  values reach read_bvh through context variables set by main, see ``_main.py``);
- ``inputs`` names the arguments that hold input paths (a string or a list of strings);
- ``outputs`` maps each argument that holds an output path to an :class:`Output`: the
  extensions it accepts, whether '-' means standard output, whether the command creates
  missing folders itself;
- ``requires`` lists the optional modules the command needs (:class:`Needs`), each
  unconditionally or when an argument is given (``Needs("matplotlib", when="plot")``) or when
  a test of the arguments holds.

Before any work, :func:`check_outputs` checks each output given: its extension, that its
folder exists, and that it is not one of the inputs; then :func:`check_requires` imports each
optional module needed (``mlayer._optional.require``). A failure is an error of exit status 1
with one line naming the option or the extra to install (the same status as the library errors
the commands raise), and nothing is written.

An output declared with ``stdout=True`` given as ``-``: the command writes its BVH with
:func:`write_bvh_output`, which puts it on the standard output, and everything else the
command prints goes to stderr (``_main`` redirects it), so the standard output is the BVH
only.
The module imports nothing of the package's commands, so the commands import it and the
package's main imports the commands: no circle.
"""
from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass, field
from collections.abc import Callable
from typing import Any

from .._optional import require
from ..errors import InvalidArgumentError, MlayerIOError
from ..io.bvh import write_bvh, write_bvh_string
from ..manifold.primitives import CMU_NAMES


@dataclass(frozen=True)
class Output:
    """What an output argument accepts.

    extensions    accepted endings, lower case with the dot (case-insensitive match); () for
                  any (folders and path prefixes)
    what          the output in words, for the error message ("a BVH file")
    stdout        '-' means standard output (no file is checked)
    kind          "file"; "dir" (a folder the command writes into); "prefix" (a path prefix
                  the command appends names to; '' means no such output)
    makes_dirs    the command creates missing folders, so a missing folder is no error
    """
    extensions: tuple[str, ...] = ()
    what: str = "a file"
    stdout: bool = False
    kind: str = "file"
    makes_dirs: bool = False

    def __post_init__(self) -> None:
        if self.kind not in ("file", "dir", "prefix"):
            raise ValueError(f"Output kind must be file, dir or prefix, got {self.kind!r}")
        if self.kind != "file" and self.extensions:
            raise ValueError("only a file output has extensions")
        if any(not e.startswith(".") or e != e.lower() for e in self.extensions):
            raise ValueError(f"extensions are lower case with the dot, got {self.extensions}")


BVH = Output((".bvh",), "a BVH file")
#: a BVH output that may be '-', the standard output (the commands that write one BVH)
BVH_OR_STDOUT = Output((".bvh",), "a BVH file", stdout=True)
GIF = Output((".gif",), "an animated GIF file")
NPZ = Output((".npz",), "a numpy .npz file")
MLRGEN = Output((".mlrgen",), "a runtime model file (.mlrgen)")
PNG = Output((".png",), "a PNG figure")
FIGURE = Output((".png", ".svg", ".pdf"), "a figure")
FOLDER = Output(kind="dir", makes_dirs=True)
PREFIX = Output(kind="prefix")


@dataclass(frozen=True)
class Needs:
    """An optional module a command needs (see mlayer._optional).

    module   the module imported to check it ("matplotlib", "PIL", "distributed", ...)
    when     None: always; an argument's dest: when that argument is given (not None, False
             or ''); a callable(args) -> bool
    feature  what needs it, for the message (default: the option as the user writes it when
             `when` is a dest, "mlayer CMD" otherwise)
    extra    the mlayer extra to install (default: the module's in mlayer._optional.EXTRAS)
    """
    module: str
    when: object = None
    feature: str = ""
    extra: str | None = None

    def applies(self, args: argparse.Namespace) -> bool:
        if self.when is None:
            return True
        if callable(self.when):
            return bool(self.when(args))
        v = getattr(args, str(self.when), None)
        return v is not None and v is not False and v != ""


@dataclass(frozen=True)
class Command:
    """One subcommand: what the parser and the shared checks need, and its run(args)."""
    name: str
    help: str
    run: Callable[[argparse.Namespace], int]
    arguments: Callable[[argparse.ArgumentParser], None] | None = None
    reads_clips: bool = True
    inputs: tuple[str, ...] = ()
    outputs: dict[str, Output] = field(default_factory=dict)
    requires: tuple[Needs, ...] = ()

    def __call__(self, args: argparse.Namespace) -> int:
        return self.run(args)


def command(name: str, help: str, *, reads_clips: bool,
            arguments: Callable[[argparse.ArgumentParser], None] | None = None,
            inputs: tuple[str, ...] = (), outputs: dict[str, Any] | None = None,
            requires: tuple[Needs | str, ...] = ()
            ) -> Callable[[Callable[[argparse.Namespace], int]], Command]:
    """Decorator declaring `run(args) -> int` as the subcommand `name` (see the module's
    docstring); returns the :class:`Command`. An output given as a tuple of extensions is
    ``Output(extensions)``; a requirement given as a module name is ``Needs(module)``."""
    needs = tuple(n if isinstance(n, Needs) else Needs(n) for n in requires)
    outs: dict[str, Output] = {}
    for dest, spec in (outputs or {}).items():
        outs[dest] = spec if isinstance(spec, Output) else \
            Output(tuple(spec), f"a {'/'.join(spec)} file")

    def wrap(run: Callable[[argparse.Namespace], int]) -> Command:
        return Command(name, help, run, arguments, reads_clips, tuple(inputs), outs, needs)
    return wrap


# ---- the parser ------------------------------------------------------------------------------

def add_parser(sub, cmd: Command) -> argparse.ArgumentParser:
    """The subparser of `cmd`: its arguments, then the reading options if it reads clips."""
    sp = sub.add_parser(cmd.name, help=cmd.help, description=cmd.help)
    if cmd.arguments is not None:
        cmd.arguments(sp)
    if cmd.reads_clips:
        add_reading_options(sp)
    # how the user writes each argument: its first option string (-o), or its metavar
    written = {a.dest: a.option_strings[0] if a.option_strings else (a.metavar or a.dest)
               for a in sp._actions}
    whens = [n.when for n in cmd.requires if isinstance(n.when, str)]
    for dest in (*cmd.inputs, *cmd.outputs, *whens):
        if dest not in written:
            raise ValueError(f"mlayer {cmd.name}: no argument {dest!r} (inputs/outputs/requires)")
    sp.set_defaults(_command=cmd, _written=written)
    return sp


def add_reading_options(sp) -> None:
    """--strict, --up, --trim and --units: how the clips are read (every command that reads
    clips; batch passes them to its workers)."""
    sp.add_argument("--strict", action="store_true",
                    help="refuse BVH files that deviate from the format (extra or "
                         "missing frame lines, data after the frames) instead of "
                         "reading them with a warning")
    sp.add_argument("--up", choices=("auto", "x", "y", "z"), default="auto",
                    help="the clips' up axis (default auto: detected from the feet, "
                         "or the floor; `mlayer info` shows what was found)")
    sp.add_argument("--trim", type=trim_arg, default=None, metavar="auto|N",
                    help="drop frames at the start of each clip read: auto drops the "
                         "T-pose and blend frames a converter put there (CMU files), N "
                         "the first N frames (default: keep every frame)")
    sp.add_argument("--units", choices=("m", "cm", "mm", "in", "ft"), default=None,
                    help="the clips' length unit (default: the one their body height "
                         "suggests, when it does; thresholds do not depend on it)")


def add_rename_option(sp) -> None:
    """--rename: joint names of another naming scheme (see :func:`parse_rename`)."""
    sp.add_argument("--rename", default=None, metavar="OLD=NEW,...|FILE.json|cmu",
                    help="join clips whose joint names differ from the first clip's (the "
                         "model's): pairs OLD=NEW, a JSON file of them, or 'cmu' for CMU's two "
                         "naming schemes; a clip is renamed by the map or its inverse, "
                         "whichever gives the first clip's names")


def parse_rename(text: str | None) -> dict | None:
    """The mapping of --rename: ``cmu`` (mlayer.manifold.primitives.CMU_NAMES), a JSON file of an
    object of names (its path ends in .json), or ``OLD=NEW,OLD=NEW``; None for None."""
    if text is None:
        return None
    if text.strip().lower() == "cmu":
        return dict(CMU_NAMES)
    if text.lower().endswith(".json"):
        import json
        try:
            with open(text, encoding="utf-8") as f:
                mapping = json.load(f)
        except OSError as e:
            raise MlayerIOError(f"--rename: cannot read {text}: {e.strerror or e}") from None
        except ValueError as e:
            raise InvalidArgumentError(f"--rename: {text} is not JSON ({e})") from None
        if not isinstance(mapping, dict) or not all(
                isinstance(k, str) and isinstance(v, str) for k, v in mapping.items()):
            raise InvalidArgumentError(f"--rename: {text} must hold one JSON object of joint "
                                       f"names, {{\"old\": \"new\", ...}}")
        return mapping
    mapping = {}
    for part in (p.strip() for p in text.split(",") if p.strip()):
        old, sep, new = (v.strip() for v in part.partition("="))
        if not sep or not old or not new:
            raise InvalidArgumentError(f"--rename: {part!r} is not OLD=NEW")
        if old in mapping:
            raise InvalidArgumentError(f"--rename: {old!r} is renamed twice")
        mapping[old] = new
    if not mapping:
        raise InvalidArgumentError(f"--rename: no OLD=NEW pairs in {text!r}")
    return mapping


def trim_arg(text: str):
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


def show_trim(command: str):
    """The report of reading_trim for the CLI: one line on stderr per clip trimmed."""
    def show(name: str, n: int) -> None:
        print(f"mlayer {command}: {name}: trimmed {n} frame{'s' if n != 1 else ''} at the start",
              file=sys.stderr)
    return show


def show_parse_warning(command: str):
    """warnings.showwarning for the CLI: one line on stderr per warning."""
    def show(message, category, filename, lineno, file=None, line=None):
        print(f"mlayer {command}: warning: {message}", file=sys.stderr)
    return show


# ---- the output check ------------------------------------------------------------------------

def _paths(value) -> list:
    if isinstance(value, (str, os.PathLike)):
        return [os.fspath(value)]
    if isinstance(value, (list, tuple)):
        return [os.fspath(v) for v in value if isinstance(v, (str, os.PathLike))]
    return []  # None, or a flag's True (resample --report without a file)


def _same_file(a: str, b: str) -> bool:
    try:
        if os.path.exists(a) and os.path.exists(b):
            return os.path.samefile(a, b)
    except OSError:
        pass
    return os.path.realpath(a) == os.path.realpath(b)


def check_outputs(cmd: Command, args) -> None:
    """Refuse, before any work, an output path that the command cannot write: an extension it
    does not accept (InvalidArgumentError), a folder that does not exist (MlayerIOError), or
    one of the inputs (InvalidArgumentError)."""
    inputs = [p for dest in cmd.inputs for p in _paths(getattr(args, dest, None))]
    written = getattr(args, "_written", {})
    for dest, spec in cmd.outputs.items():
        for path in _paths(getattr(args, dest, None)):
            opt = written.get(dest, dest)
            if spec.stdout and path == "-":
                continue
            if spec.kind == "prefix" and path == "":
                continue
            if spec.extensions and os.path.splitext(path)[1].lower() not in spec.extensions:
                ends = spec.extensions[0] if len(spec.extensions) == 1 else \
                    ", ".join(spec.extensions[:-1]) + " or " + spec.extensions[-1]
                raise InvalidArgumentError(f"{opt} {path}: mlayer {cmd.name} writes {spec.what}"
                                           f"{'' if not spec.stdout else ' or to -'}; give a "
                                           f"path ending in {ends}")
            if not spec.makes_dirs:
                # a prefix's files are PREFIX + a name: "figs/" writes into figs
                d = os.path.dirname(os.path.abspath(path + "_" if spec.kind == "prefix"
                                                    else path))
                if not os.path.isdir(d):
                    raise MlayerIOError(f"{path}: directory {d} does not exist")
            if spec.kind == "prefix":
                continue
            for src in inputs:
                if _same_file(path, src):
                    raise InvalidArgumentError(f"{opt} {path}: the same file as the input "
                                               f"{src}; give another output path")


# ---- the optional dependencies ---------------------------------------------------------------

def check_requires(cmd: Command, args) -> None:
    """Import, before any work, every optional module the command needs with these arguments
    (its :class:`Needs`); a missing one raises mlayer.MissingDependencyError, one line naming
    the extra to install."""
    written = getattr(args, "_written", {})
    for need in cmd.requires:
        if not need.applies(args):
            continue
        feature = need.feature or (written.get(need.when, need.when)
                                   if isinstance(need.when, str) else f"mlayer {cmd.name}")
        require(need.module, feature=feature, extra=need.extra)


# ---- standard output -------------------------------------------------------------------------

def stdout_outputs(cmd: Command, args) -> list:
    """The dests of the outputs given as '-' (standard output) that the command declares
    with stdout=True."""
    return [dest for dest, spec in cmd.outputs.items()
            if spec.stdout and getattr(args, dest, None) == "-"]


def output_name(path) -> str:
    """An output path as the command's summary names it: '-' is "(standard output)"."""
    return "(standard output)" if path == "-" else str(path)


def write_bvh_output(args, motion, dest: str = "output", write=None) -> None:
    """Write `motion` to the output `dest` of the command: the file, atomically (`write`,
    default mlayer.write_bvh), or the standard output for '-' (the stream _main kept aside, as
    bytes so the text is the file's byte for byte)."""
    path = getattr(args, dest)
    if path != "-":
        (write or write_bvh)(motion, path)
        return
    out = getattr(args, "_stdout", None) or sys.stdout
    text = write_bvh_string(motion)
    buf = getattr(out, "buffer", None)
    if buf is not None:
        out.flush()
        buf.write(text.encode("utf-8", errors="surrogateescape"))
        buf.flush()
    else:
        out.write(text)
        out.flush()
