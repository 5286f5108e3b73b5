"""`mlayer info`: the description of a clip, and one-line errors with exit status 1."""
import subprocess
import sys

import pytest

import mlayer
from mlayer.cli import main


def run(capsys, *argv):
    code = main(["info", *map(str, argv)])
    out, err = capsys.readouterr()
    return code, out, err


def test_info_on_the_sample(capsys):
    path = mlayer.data.sample_path()
    code, out, err = run(capsys, path)
    assert code == 0 and err == ""
    lines = out.splitlines()
    field = {ln.split()[0]: ln for ln in lines if ln and not ln.startswith(" ")}
    assert "31 (+7 End Sites), root 'Hips'" in field["joints"]
    assert field["channels"].split()[1] == "96" and "ZYX x 19, ZXY x 12" in field["channels"]
    assert field["frames"].split()[1] == "994"
    assert field["fps"].split()[1] == "120"
    assert field["duration"].split()[1] == "8.283"
    assert "x [" in field["extent"] and "y [" in field["extent"] and "z [" in field["extent"]
    height = float(field["height"].split()[1].lstrip("~"))
    assert 18 < height < 26  # a person in CMU units (~5.6 cm)
    tree = lines[lines.index("skeleton") + 1:]
    assert len(tree) == 31
    assert tree[0].startswith("  Hips ") and "Xpos Ypos Zpos Zrot Yrot Xrot" in tree[0]
    knee = next(t for t in tree if "LeftKnee" in t)
    assert knee.startswith("  " + "  " * 3 + "LeftKnee")
    shoulder = next(t for t in tree if "LeftShoulder" in t)
    assert "Zrot Xrot Yrot" in shoulder and shoulder.rstrip().endswith("ZXY")
    assert sum("End Site" in t for t in tree) == 7


def test_info_on_every_clip(capsys, mocap):
    clips = sorted(mocap.glob("*.bvh"))
    code, out, err = run(capsys, "--no-tree", *clips)
    assert code == 0 and err == ""
    assert out.count("\nframes ") + out.startswith("frames") == len(clips)
    assert "position channels on 21 non-root joint(s)" in out  # Bandai


def test_bad_file_gives_one_line_and_status_1(capsys, tmp_path):
    f = tmp_path / "walk.bvh"
    f.write_text("HIERARCHY\nROOT Hips\n  OFFSET 0 0 0\n")
    code, out, err = run(capsys, f)
    assert code == 1 and out == ""
    assert err.count("\n") == 1
    assert err.startswith(f"mlayer: {f}:3: expected '{{'"), err


def test_missing_file_gives_one_line_and_status_1(capsys, tmp_path):
    code, out, err = run(capsys, tmp_path / "none.bvh")
    assert code == 1 and out == "" and err.count("\n") == 1
    assert err.startswith(f"mlayer: {tmp_path / 'none.bvh'}: ") and "No such file" in err


def test_info_through_the_command_line(tmp_path):
    ok = subprocess.run([sys.executable, "-m", "mlayer", "info", str(mlayer.data.sample_path())],
                        capture_output=True, text=True)
    assert ok.returncode == 0 and "frames    994" in ok.stdout
    bad = tmp_path / "bad.bvh"
    bad.write_bytes(b"\x00\x01\x02garbage")
    r = subprocess.run([sys.executable, "-m", "mlayer", "info", str(bad)],
                       capture_output=True, text=True)
    assert r.returncode == 1 and r.stdout == ""
    assert r.stderr.startswith(f"mlayer: {bad}:1: ") and r.stderr.count("\n") == 1


@pytest.mark.parametrize("argv", [["info"], ["info", "--bogus"]])
def test_usage_errors(argv):
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2


def _commands():
    from mlayer.cli._main import COMMANDS
    return [c.name for c in COMMANDS]


@pytest.mark.parametrize("argv", [[name, "--no-such-option"] for name in _commands()]
                         + [["no-such-command"], ["primitives", "a.bvh", "-o", "m.npz",
                                                  "--ks", "9..3"],
                            ["stylize", "a.bvh", "-o", "b.bvh", "--alpha", "big"],
                            ["batch", "blur", "a", "-o", "b"]])
def test_usage_errors_are_one_line_with_a_pointer_to_help(argv, capsys):
    """argparse prints its usage block and the error; every parser of the command line (the
    top level and each command's) gives one line naming the error and where --help is."""
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    out, err = capsys.readouterr()
    prog = "mlayer" if argv[0] == "no-such-command" else f"mlayer {argv[0]}"
    assert out == "" and err.count("\n") == 1, err
    assert err.startswith(f"{prog}: error: ") and "usage:" not in err
    assert err.rstrip("\n").endswith(f"(see {prog} --help)")
    assert argv[-1] in err or "required" in err or "unrecognized" in err
