"""mlayer._files: one atomic writer. Temporaries are named by the rule of mlr_bvh.h
(``DIR/.NAME.tmp-<16 hex>``, an extension allowed after it), the files honour the umask, and
stale_temporaries lists exactly the temporaries of one output."""
import os
import re
import stat

import pytest

import mlayer
from mlayer._files import atomic_output, stale_temporaries, temporary_name, umask

RULE = re.compile(r"\.(?P<name>.+)\.tmp-[0-9a-f]{16}(\.[^./\\]{1,16})?")


def test_atomic_output_honours_umask(tmp_path):
    old = os.umask(0o027)
    try:
        assert umask() == 0o027
        with atomic_output(tmp_path / "a.json") as tmp:
            with open(tmp, "w") as f:
                f.write("{}")
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(tmp_path / "a.json").st_mode) == 0o640


@pytest.mark.parametrize("mask", [0o022, 0o077])
def test_atomic_output_and_write_bvh_modes(tmp_path, mask):
    """The Python writer and the C writer give a new file, and a replaced one, 0666 less the
    umask."""
    m = mlayer.data.load_sample()[:10]
    old = os.umask(mask)
    try:
        for _ in range(2):  # create, then replace
            with atomic_output(tmp_path / "a.npz", ".npz") as tmp:
                with open(tmp, "wb") as f:
                    f.write(b"x")
            mlayer.write_bvh(m, tmp_path / "a.bvh")
    finally:
        os.umask(old)
    for p in tmp_path.iterdir():
        assert stat.S_IMODE(p.stat().st_mode) == 0o666 & ~mask, p


def test_rewriting_keeps_an_existing_files_mode(tmp_path):
    """Issue 39: an existing 0600 output became 0644 when rewritten (by either writer)."""
    m = mlayer.data.load_sample()[:10]
    old = os.umask(0o022)
    try:
        for name in ("a.bvh", "a.npz"):
            p = tmp_path / name
            p.write_bytes(b"old")
            os.chmod(p, 0o600)
            if name.endswith(".bvh"):
                mlayer.write_bvh(m, p)  # the C writer
            else:
                with atomic_output(p, ".npz") as tmp:
                    with open(tmp, "wb") as f:
                        f.write(b"new")
            assert p.read_bytes() != b"old"
            assert stat.S_IMODE(p.stat().st_mode) == 0o600, name
    finally:
        os.umask(old)


def test_temporaries_follow_the_rule_and_are_listed(tmp_path):
    out = tmp_path / "out.bvh"
    names = {os.path.basename(temporary_name(out)) for _ in range(50)}
    assert len(names) == 50 and all(RULE.fullmatch(n)["name"] == "out.bvh" for n in names)
    assert os.path.dirname(temporary_name(out)) == str(tmp_path)
    npz = os.path.basename(temporary_name(out, ".npz"))
    assert RULE.fullmatch(npz) and npz.endswith(".npz")
    for bad in ("npz", ".a/b", ".a.b", "." + "x" * 17):
        with pytest.raises(ValueError):
            temporary_name(out, bad)
    # temporaries of out: the C writer's (no extension) and atomic_output's (an extension)
    mine = [".out.bvh.tmp-0123456789abcdef", ".out.bvh.tmp-fedcba9876543210.npz"]
    # not temporaries of out: other outputs', the former C rule, wrong digits, a folder
    others = [".out.bvh2.tmp-0123456789abcdef", ".out.tmp-0123456789abcdef",
              "out.bvh.tmp-0123456789abcdef", ".out.bvh.tmp-0123456789ABCDEF",
              ".out.bvh.tmp-0123456789abcde", ".out.bvh.tmp-0123456789abcdef.a.b",
              ".out.bvh.tmp-0123456789abcdefx", "out.bvh"]
    for n in mine + others:
        (tmp_path / n).write_text("partial")
    assert stale_temporaries(out) == sorted(str(tmp_path / n) for n in mine)
    assert stale_temporaries(tmp_path / "out") == [str(tmp_path / ".out.tmp-0123456789abcdef")]
    # a folder whose name holds glob characters
    odd = tmp_path / "a[1]*"
    odd.mkdir()
    (odd / ".x.bvh.tmp-0123456789abcdef").write_text("")
    assert stale_temporaries(odd / "x.bvh") == [str(odd / ".x.bvh.tmp-0123456789abcdef")]


def test_atomic_output_names_and_removes_its_temporary(tmp_path):
    out = tmp_path / "plot.png"
    with atomic_output(out) as tmp:
        assert stale_temporaries(out) == [tmp]  # a running writer's temporary is listed
        assert tmp.endswith(".png") and RULE.fullmatch(os.path.basename(tmp))
        with open(tmp, "wb") as f:
            f.write(b"new")
    assert out.read_bytes() == b"new" and stale_temporaries(out) == []
    with pytest.raises(RuntimeError):
        with atomic_output(out) as tmp:
            with open(tmp, "wb") as f:
                f.write(b"half")
            raise RuntimeError("killed")
    assert out.read_bytes() == b"new" and sorted(os.listdir(tmp_path)) == ["plot.png"]
    with atomic_output(tmp_path / "noext") as tmp:  # no extension: none added
        assert re.fullmatch(r"\.noext\.tmp-[0-9a-f]{16}", os.path.basename(tmp))
