"""mlayer.batch on a shared machine: the embedded scheduler refuses foreign clients, output
files honour the umask, an output folder inside the input folder resumes, and symbolic links
that are not read as clips are recorded in the report."""
from __future__ import annotations

import json
import os
import pathlib
import stat
import subprocess
import sys

import numpy as np
import pytest

from conftest import need  # noqa: E402

need("batch")

import mlayer  # noqa: E402
import mlayer.batching as B  # noqa: E402  (the subpackage; mlayer.batch is the function)
from mlayer.batching.run import _client  # noqa: E402

CLIPS = ["cmu_01_01_playground_jumps.bvh", "lafan1_clip_a.bvh", "cmu_10_01_soccer_kick.bvh"]

# the attacker: another process on the same machine that knows the scheduler's port. It tries
# the address as given, plain TCP on the same port, and TLS with its own temporary certificate
ATTACK = r"""
import sys
from distributed import Client
from distributed.security import Security
addr = sys.argv[1]
tries = [("as given", addr, None), ("tcp", addr.replace("tls://", "tcp://"), None),
         ("own certificate", addr, Security.temporary())]
for name, a, sec in tries:
    try:
        kw = {"security": sec} if sec is not None else {}
        with Client(a, timeout="5s", **kw) as c:
            print("CONNECTED", name, c.submit(sum, [20, 22]).result(), flush=True)
    except Exception as e:
        print("REFUSED", name, type(e).__name__, flush=True)
"""


def test_embedded_scheduler_refuses_foreign_clients():
    with _client(None, 1) as client:
        addr = client.scheduler.address
        assert addr.startswith("tls://127.0.0.1:"), addr
        assert client.submit(sum, [1, 2]).result(timeout=60) == 3  # the batch's own client works
        p = subprocess.run([sys.executable, "-c", ATTACK, addr], capture_output=True, text=True,
                           timeout=180)
        lines = p.stdout.splitlines()
        assert not [ln for ln in lines if ln.startswith("CONNECTED")], p.stdout
        assert len([ln for ln in lines if ln.startswith("REFUSED")]) == 3, (p.stdout, p.stderr)
        assert client.submit(sum, [2, 2]).result(timeout=60) == 4  # and still works


@pytest.fixture
def corpus(tmp_path, mocap):
    """captures/ with three short clips (one in a sub-folder), a link to a folder outside it
    (with a clip), a dangling link; the output folder is captures/out."""
    root = tmp_path / "captures"
    (root / "sub").mkdir(parents=True)
    (tmp_path / "elsewhere").mkdir()
    for k, name in enumerate(CLIPS):
        m = mlayer.read_bvh(mocap / name)[:40]
        folder = root / "sub" if k == 2 else root
        mlayer.write_bvh(m, folder / name)
    mlayer.write_bvh(mlayer.read_bvh(mocap / CLIPS[0])[:40], tmp_path / "elsewhere" / "x.bvh")
    os.symlink(tmp_path / "elsewhere", root / "linked")
    os.symlink(tmp_path / "missing.bvh", root / "ghost.bvh")
    return root


def test_batch_outputs_inside_inputs_modes_links(corpus):
    out = corpus / "out"
    report = corpus / "out" / "report.json"
    old = os.umask(0o022)
    try:
        r1 = mlayer.batch("features", corpus, out, n_workers=1, progress=False, metrics=False,
                          report=report)
        assert r1.exit_code == 0 and r1.ok == 3, r1.table()
        # symbolic links: the folder link is not followed, the dangling one skipped, both said
        links = {os.path.basename(r["input"]): r["error"] for r in r1.records
                 if r["status"] == B.STATUS_LINK}
        assert set(links) == {"linked", "ghost.bvh"}, r1.records
        assert "not followed" in links["linked"] and "dangling" in links["ghost.bvh"]
        doc = json.loads(report.read_text())
        assert doc["summary"]["links"] == 2 and doc["summary"]["outputs"] == 3
        assert "LINK" in r1.table()
        # every file batch wrote: 0644 under umask 022, as the BVH outputs
        written = [p for p in out.rglob("*") if p.is_file()]
        assert {p.suffix for p in written} == {".npz", ".json"}
        assert len([p for p in written if B.SIDECAR_DIR in p.parts]) == 3
        for p in written:
            assert stat.S_IMODE(p.stat().st_mode) == 0o644, p
        # the second run resumes: the outputs inside captures/ are not inputs
        r2 = mlayer.batch("features", corpus, out, n_workers=1, progress=False, metrics=False)
        assert r2.exit_code == 0 and r2.skipped == 3 and r2.ok == 0, r2.table()
        assert sorted(os.path.basename(r["input"]) for r in r2.outputs) == sorted(CLIPS)
        # a glob follows the folder link (Python's glob does) and says so
        r3 = mlayer.batch("features", str(corpus / "**" / "*.bvh"), out, n_workers=1,
                          progress=False, metrics=False)
        notes = [r["error"] for r in r3.records if r["status"] == B.STATUS_LINK]
        assert any("followed" in n and "not followed" not in n for n in notes), r3.records
        assert r3.ok == 1 and r3.skipped == 3, r3.table()  # linked/x.bvh is new
        np.load(out / "linked" / "x.npz")
    finally:
        os.umask(old)


@pytest.mark.parametrize("mask", [0o022, 0o077])
def test_every_file_batch_writes_honours_the_umask(tmp_path, mocap, mask):
    """The task's writers in this process: BVH (the C writer), .npz, the .json sidecars, and
    the CSV and JSON reports; 0644 under umask 022, 0600 under 077."""
    src = tmp_path / "in.bvh"
    mlayer.write_bvh(mlayer.read_bvh(mocap / CLIPS[1])[:40], src)
    out = tmp_path / "out"
    out.mkdir()  # (batch makes the output folders before the tasks run)
    old = os.umask(mask)
    try:
        recs = []
        for name, ext in (("denoise", ".bvh"), ("features", ".npz")):
            jobs = [({}, str(out / f"{name}{ext}"), str(out / B.SIDECAR_DIR / f"{name}.json"),
                     "k")]
            recs += B.process_clip(B.operations()[name], str(src), jobs, {}, metrics=False)
        assert [r["status"] for r in recs] == ["ok", "ok"], recs
        result = B.BatchResult("denoise", recs, 1.0)
        result.write_report(out / "report.csv")
        result.write_report(out / "report.json")
    finally:
        os.umask(old)
    written = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    assert written == [f"{B.SIDECAR_DIR}/denoise.json", f"{B.SIDECAR_DIR}/features.json",
                       "denoise.bvh", "features.npz", "report.csv", "report.json"]
    for p in written:
        assert stat.S_IMODE((out / p).stat().st_mode) == 0o666 & ~mask, (p, oct(mask))


def test_batch_on_workers_honours_umask_077(tmp_path, mocap):
    """The embedded cluster's workers inherit the umask: BVH outputs, sidecars and the CSV
    report are 0600 under umask 077."""
    src = tmp_path / "in"
    src.mkdir()
    mlayer.write_bvh(mlayer.read_bvh(mocap / CLIPS[1])[:40], src / "a.bvh")
    out = tmp_path / "out"
    old = os.umask(0o077)
    try:
        res = mlayer.batch("denoise", src, out, n_workers=1, progress=False, metrics=False,
                           report=tmp_path / "report.csv")
    finally:
        os.umask(old)
    assert res.ok == 1, res.table()
    written = [p for p in out.rglob("*") if p.is_file()] + [tmp_path / "report.csv"]
    assert sorted(p.suffix for p in written) == [".bvh", ".csv", ".json"]
    for p in written:
        assert stat.S_IMODE(p.stat().st_mode) == 0o600, p


def test_links_leading_out_of_the_input_folder_are_refused(corpus, tmp_path):
    """Issue 39: a *.bvh link to /etc/passwd was read and its first line quoted in the report.
    A link to a file outside the input folder is refused and listed, never read; one to a
    file inside it is still a clip of its own."""
    secret = tmp_path / "secret.txt"
    secret.write_text("root:x:0:0:SECRET-LINE\n")
    os.symlink(secret, corpus / "passwd.bvh")
    os.symlink(corpus / CLIPS[0], corpus / "again.bvh")
    out = tmp_path / "out"
    r = mlayer.batch("features", corpus, out, n_workers=1, progress=False, metrics=False,
                     report=out / "report.json")
    links = {os.path.basename(r_["input"]): r_["error"] for r_ in r.records
             if r_["status"] == B.STATUS_LINK}
    assert "passwd.bvh" in links and "leading out of the input folder" in links["passwd.bvh"]
    assert "SECRET" not in r.table() and "SECRET" not in (out / "report.json").read_text()
    assert r.ok == 4, r.table()  # the three clips and the link to one of them
    # a glob: the same for a file link leading out of its folder
    found: list = []
    pairs = B.find_inputs(str(corpus / "*.bvh"), links=found)
    assert all(os.path.basename(p) != "passwd.bvh" for p, _ in pairs)
    assert any(os.path.basename(str(p)) == "passwd.bvh" for p, _ in found)


def test_embedded_cluster_serves_no_dashboard():
    """Issue 39: the embedded cluster served Dask's dashboard on 127.0.0.1:8787 (and a port per
    worker) without authentication, for any Host header. Its HTTP servers now have no routes
    and no fixed port."""
    import urllib.error
    import urllib.request
    from mlayer.batching.run import _client
    with _client(None, 1) as client:
        info = client.scheduler_info()
        ports = [info["services"]["dashboard"]] + [
            w["services"]["dashboard"] for w in info["workers"].values()
            if "dashboard" in w.get("services", {})]
        assert info["services"]["dashboard"] != 8787
        for port in ports:
            for path in ("/status", "/health", "/metrics", "/info/main/workers.html"):
                with pytest.raises(urllib.error.HTTPError) as e:
                    urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=10)
                assert e.value.code == 404, (port, path)


def test_a_script_without_a_main_guard_fails_in_one_line(tmp_path):
    """The README's batch snippet saved as a script without `if __name__ == "__main__":` died
    in 483 lines of Dask tracebacks ("Nanny failed to start"): the embedded cluster's worker
    processes import the script again and start a cluster each. On the embedded Dask cluster
    it now fails before anything starts, saying what to add; under the guard the same call
    runs (issue 42). (The default local pool: test_batch_local.py.)"""
    wild = pathlib.Path(__file__).resolve().parents[4] / "tests" / "data" / "wild"
    body = (f"import mlayer\n"
            f"r = mlayer.batch('denoise', [{str(wild / 'pybvh_test1.bvh')!r}], "
            f"{str(tmp_path / 'out')!r}, n_workers=1, scheduler='dask')\n"
            f"print('records', len(r.records))\n")
    script = tmp_path / "unguarded.py"
    script.write_text(body)
    p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                       timeout=120, cwd=tmp_path)
    assert p.returncode != 0
    last = p.stderr.strip().splitlines()[-1]
    assert "InvalidArgumentError" in last and 'if __name__ == "__main__":' in last, p.stderr
    assert f"{script}:2" in last and "Nanny" not in p.stderr
    assert not (tmp_path / "out").exists()
    guarded = tmp_path / "guarded.py"
    lines = body.splitlines()
    guarded.write_text(lines[0] + "\nif __name__ == '__main__':\n" +
                       "".join(f"    {x}\n" for x in lines[1:]))
    p = subprocess.run([sys.executable, str(guarded)], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path)
    assert p.returncode == 0 and "records 1" in p.stdout, p.stderr
