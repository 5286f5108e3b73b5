"""The output check every command shares (mlayer/cli/_command.py), driven by the declarations.

For every command that declares outputs and every output it declares: a wrong extension, a
missing folder and an output that is the input each give one line on stderr, exit status 1
and no file written, before any work. The command lines are built from the parsers, so a new
command is covered as soon as it is declared.
"""
import argparse
import os
import shutil

import pytest

from mlayer import cli
from mlayer.cli._command import BVH, Command, Output, check_outputs, command

SAMPLE = os.path.join(os.path.dirname(__import__("mlayer").__file__), "data",
                      "cmu_131_01_mj_style_walk.bvh")
WRITERS = [c for c in cli.COMMANDS if c.outputs]
# options that name an output in every command that has them
OUTPUT_OPTIONS = {"-o", "--output", "--output-dir", "--plot", "--plots", "--npz", "--report"}


def _subparsers():
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices


SUBPARSERS = _subparsers()


def _good(spec: Output, tmp_path, name: str = "ok") -> str:
    return str(tmp_path / (name + (spec.extensions[0] if spec.extensions else "")))


def _value(action) -> str:
    """A value that parses for a required argument that is neither an input nor an output."""
    if action.choices:
        return sorted(action.choices)[0]
    return "1" if action.type in (int, float) else "x"


def command_line(cmd: Command, tmp_path, dest: str, value: str, input_path: str = SAMPLE):
    """A command line of `cmd` that parses, with output `dest` set to `value`, the other
    required outputs set to good paths in tmp_path, and the inputs to input_path."""
    sp = SUBPARSERS[cmd.name]
    required_groups = [g for g in sp._mutually_exclusive_groups if g.required]
    chosen = {id(g._group_actions[0]) for g in required_groups}
    positionals, options = [], []
    for a in sp._actions:
        if isinstance(a, argparse._HelpAction) or a.dest == "command":
            continue
        if a.dest == dest:
            v = value
        elif a.dest in cmd.outputs and a.required:
            v = _good(cmd.outputs[a.dest], tmp_path, "ok_" + a.dest)
        elif a.dest in cmd.inputs and (not a.option_strings or a.required
                                       or a.dest == cmd.inputs[0]):
            v = input_path
        elif not a.option_strings or a.required or id(a) in chosen:
            v = _value(a)
        else:
            continue
        if a.option_strings:
            options += [a.option_strings[0], v]
        else:
            positionals.append(v)
    return [cmd.name, *positionals, *options]


CASES = []
for _cmd in WRITERS:
    for _dest, _spec in _cmd.outputs.items():
        if _spec.extensions:
            CASES.append((_cmd.name, _dest, "extension"))
            if not _spec.stdout:
                CASES.append((_cmd.name, _dest, "dash"))
        if not _spec.makes_dirs:
            CASES.append((_cmd.name, _dest, "folder"))
        if _cmd.inputs and _spec.kind != "prefix":
            CASES.append((_cmd.name, _dest, "input"))


def test_every_writing_command_is_covered():
    names = {c for c, _, _ in CASES}
    assert names == {c.name for c in WRITERS}
    # the commands that write files today; a new one joins CASES through its declaration
    assert names >= {"denoise", "stylize", "layers", "render", "stream", "contacts", "resample",
                     "timewarp", "batch", "primitives", "generate", "demo"}
    assert len(CASES) >= 40


@pytest.mark.parametrize("name,dest,how", CASES)
def test_bad_outputs_are_refused_before_any_work(name, dest, how, tmp_path, monkeypatch,
                                                 capsys):
    cmd = next(c for c in cli.COMMANDS if c.name == name)
    spec = cmd.outputs[dest]
    monkeypatch.chdir(tmp_path)
    ext = spec.extensions[0] if spec.extensions else ""
    input_path = SAMPLE
    if how == "extension":
        value, needle = str(tmp_path / "out.xyz"), "give a path ending in " + ext
    elif how == "dash":
        value, needle = "-", "give a path ending in " + ext
    elif how == "folder":
        value, needle = str(tmp_path / "nodir" / ("out" + ext)), "does not exist"
    else:  # the input itself as the output: a copy of the clip named like an output
        input_path = str(tmp_path / ("same" + ext))
        shutil.copyfile(SAMPLE, input_path)
        value, needle = input_path, "the same file as the input"
    argv = command_line(cmd, tmp_path, dest, value, input_path)
    before = sorted(os.listdir(tmp_path))
    code = cli.main(argv)
    err = capsys.readouterr().err
    assert code == 1, (argv, err)
    assert err.count("\n") == 1 and err.startswith(f"mlayer {name}: error: "), (argv, err)
    assert needle in err, (argv, err)
    assert sorted(os.listdir(tmp_path)) == before, argv  # nothing written, no folder made
    if how == "input":
        with open(input_path, "rb") as a, open(SAMPLE, "rb") as b:
            assert a.read() == b.read()


def test_every_output_option_is_declared():
    """An argument spelled like an output (-o, --plot, --npz, --report ...) is declared as one,
    so the check sees it."""
    for cmd in cli.COMMANDS:
        for a in SUBPARSERS[cmd.name]._actions:
            if OUTPUT_OPTIONS & set(a.option_strings):
                assert a.dest in cmd.outputs, (cmd.name, a.dest)


def test_good_outputs_pass_the_check(tmp_path):
    """The command lines built above pass the check when every output is good (so the
    failures above come from the output under test)."""
    for cmd in WRITERS:
        dest, spec = next(iter(cmd.outputs.items()))
        argv = command_line(cmd, tmp_path, dest, _good(spec, tmp_path, "good"))
        args = cli.build_parser().parse_args(argv)
        check_outputs(cmd, args)


def _check(cmd, **values):
    args = argparse.Namespace(**values)
    check_outputs(cmd, args)


def test_check_outputs_rules(tmp_path):
    from mlayer.errors import InvalidArgumentError, MlayerIOError
    run = lambda args: 0  # noqa: E731
    txt = Output((".txt", ".csv"), "a text file", stdout=True)
    cmd = command("x", "h", reads_clips=False, inputs=("input",),
                  outputs={"out": txt, "bvh": BVH, "pre": Output(kind="prefix")})(run)
    _check(cmd, input="a.bvh", out="-", bvh=None, pre=None)        # '-' is stdout here
    _check(cmd, input="a.bvh", out=str(tmp_path / "R.CSV"), bvh=True, pre="")  # case, flags
    with pytest.raises(InvalidArgumentError, match=r"writes a text file or to -; give a path "
                                                   r"ending in \.txt or \.csv"):
        _check(cmd, input="a.bvh", out="r.json", bvh=None, pre=None)
    with pytest.raises(InvalidArgumentError, match=r"writes a BVH file; give a path ending in "
                                                   r"\.bvh$"):
        _check(cmd, input="a.bvh", out=None, bvh="-", pre=None)    # no stdout for bvh
    with pytest.raises(MlayerIOError, match="does not exist"):
        _check(cmd, input="a.bvh", out=None, bvh=None, pre=str(tmp_path / "no" / "fig"))
    with pytest.raises(MlayerIOError, match="does not exist"):     # PREFIX/ writes into it
        _check(cmd, input="a.bvh", out=None, bvh=None, pre=str(tmp_path / "no") + "/")
    _check(cmd, input="a.bvh", out=None, bvh=None, pre=str(tmp_path) + "/")
    # the same file through another spelling, and through a symbolic link
    clip = tmp_path / "c.bvh"
    clip.write_text("x")
    os.symlink(clip, tmp_path / "link.bvh")
    for other in (str(tmp_path / "." / "c.bvh"), str(tmp_path / "link.bvh")):
        with pytest.raises(InvalidArgumentError, match="the same file as the input"):
            _check(cmd, input=str(clip), out=None, bvh=other, pre=None)
    _check(cmd, input=str(clip), out=None, bvh=str(tmp_path / "d.bvh"), pre=None)
    with pytest.raises(ValueError):
        Output((".BVH",))
    with pytest.raises(ValueError):
        Output((".x",), kind="dir")


def test_a_declared_argument_must_exist():
    bad = command("x", "h", reads_clips=False, outputs={"nope": BVH})(lambda a: 0)
    sub = argparse.ArgumentParser().add_subparsers()
    from mlayer.cli._command import add_parser
    with pytest.raises(ValueError, match="no argument 'nope'"):
        add_parser(sub, bad)


def test_reading_options_follow_the_declaration():
    for cmd in cli.COMMANDS:
        opts = {o for a in SUBPARSERS[cmd.name]._actions for o in a.option_strings}
        has = {"--strict", "--up", "--trim", "--units"} & opts
        assert has == ({"--strict", "--up", "--trim", "--units"} if cmd.reads_clips else set()), \
            cmd.name


def test_a_clip_on_the_standard_input(tmp_path, mocap, monkeypatch, capsys):
    """`-` as an input reads the clip from the standard input (issue 42): `cat a.bvh | mlayer
    denoise - -o out.bvh` writes what `mlayer denoise a.bvh -o ...` writes; a broken clip is
    one line naming <stdin> and its line; `-` twice is refused."""
    import io
    import mlayer
    src = mocap / "cmu_131_01_mj_style_walk.bvh"
    assert cli.main(["denoise", str(src), "-o", str(tmp_path / "a.bvh")]) == 0
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(src.read_bytes())))
    assert cli.main(["denoise", "-", "-o", str(tmp_path / "b.bvh")]) == 0
    a, b = mlayer.read_bvh(tmp_path / "a.bvh"), mlayer.read_bvh(tmp_path / "b.bvh")
    assert (a.rot == b.rot).all() and (a.root_pos == b.root_pos).all()
    capsys.readouterr()
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(b"HIERARCHY\nROOT x {\n")))
    assert cli.main(["denoise", "-", "-o", str(tmp_path / "c.bvh")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("mlayer denoise: error: <stdin>:3: "), err
    assert not (tmp_path / "c.bvh").exists()
    monkeypatch.setattr("sys.stdin", io.TextIOWrapper(io.BytesIO(src.read_bytes())))
    assert cli.main(["info", "-", "-"]) == 1
    assert "only once" in capsys.readouterr().err
