"""mlayer.batch / `mlayer batch` on Dask: a LocalCluster of two worker processes on loopback
(the default local process pool: test_batch_local.py).

Every output is compared byte for byte with the single-clip function written by write_bvh
(or array for array with decompose for features); a worker killed mid-run, an interrupted run
resumed, bad files, and no partial or temporary file left behind.
"""
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from conftest import need  # noqa: E402

need("batch")
import distributed  # noqa: E402

import mlayer  # noqa: E402
from mlayer.batching import SIDECAR_DIR, Operation, operations, process_clip  # noqa: E402
from mlayer.batching import batch as run_batch  # noqa: E402

SHORT = ("bandai1_walk_happy_001.bvh", "cmu_02_03_run_jog_25fps.bvh",
         "cmu_131_01_mj_style_walk.bvh")


@pytest.fixture(scope="module")
def cluster():
    import logging
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None,
                                  silence_logs=logging.ERROR) as c:
        yield c


@pytest.fixture
def clips(mocap, tmp_path):
    """A folder with a few short real clips (copies: tests touch and break them)."""
    d = tmp_path / "in"
    d.mkdir()
    for name in SHORT:
        shutil.copy2(mocap / name, d / name)
    return d


def expected_bvh(src, fn=mlayer.denoise, **kw) -> str:
    return mlayer.write_bvh_string(fn(mlayer.read_bvh(src), **kw))


def assert_clean(out_dir, outputs):
    """Exactly the expected outputs (plus sidecars): no partial or temporary file anywhere."""
    out_dir = pathlib.Path(out_dir)
    files = {p.relative_to(out_dir).as_posix() for p in out_dir.rglob("*") if p.is_file()}
    visible = {f for f in files if not f.startswith(SIDECAR_DIR + "/")}
    assert visible == set(outputs)
    side = {f for f in files if f.startswith(SIDECAR_DIR + "/")}
    assert side == {f"{SIDECAR_DIR}/{o}.json" for o in outputs}


def read_text(p) -> str:
    return pathlib.Path(p).read_text()


# ---- no cluster needed ----------------------------------------------------------------------

def test_bad_arguments_fail_before_running(clips, tmp_path):
    out = tmp_path / "out"
    with pytest.raises(mlayer.InvalidArgumentError, match="unknown batch operation"):
        run_batch("blur", clips, out)
    with pytest.raises(mlayer.InvalidArgumentError, match="unknown option"):
        run_batch("denoise", clips, out, fps=30)
    with pytest.raises(mlayer.InvalidArgumentError, match="stylize only"):
        run_batch("denoise", clips, out, alphas=[1, 2])
    with pytest.raises(mlayer.InvalidArgumentError, match="overwrite an input"):
        run_batch("denoise", clips, clips)
    out.mkdir()
    with pytest.raises(mlayer.InvalidArgumentError, match="no .bvh"):
        run_batch("denoise", out, tmp_path / "out2")
    assert not any(out.iterdir())


def test_process_clip_without_dask(clips, tmp_path):
    """The task function itself, called in this process: one record per variant."""
    src = str(clips / SHORT[0])
    jobs = [({"alpha": a}, str(tmp_path / f"o{a}.bvh"), str(tmp_path / f"s{a}.json"), "k")
            for a in (0.5, 2.0)]
    op = operations()["stylize"]
    recs = process_clip(op, src, jobs, {})
    assert [r["status"] for r in recs] == ["ok", "ok"]
    for (v, out, side, _), r in zip(jobs, recs):
        assert read_text(out) == expected_bvh(src, mlayer.stylize, alpha=v["alpha"])
        assert r["frames"] == r["frames_out"] == 213 and r["seconds"] > 0
        assert r["jitter_before"] > 0 and r["jitter_after"] > 0
        assert json.loads(read_text(side))["options"] == "k"


# ---- on a LocalCluster of two processes -----------------------------------------------------

def test_whole_corpus_embedded_cluster(mocap, tmp_path):
    """scheduler="dask": an embedded LocalCluster (two worker processes on loopback) over the
    whole shared folder; every output equals mlayer.denoise written by write_bvh. (The default,
    a local process pool: test_batch_local.py.)"""
    out = tmp_path / "out"
    report = tmp_path / "report.json"
    res = run_batch("denoise", mocap, out, n_workers=2, report=report, progress=False,
                    scheduler="dask")
    names = sorted(p.name for p in mocap.glob("*.bvh"))
    assert res.exit_code == 0 and res.ok == len(names) == 8 and res.n_workers == 2
    assert res.scheduler.startswith("tls://127.0.0.1:")  # the embedded cluster: TLS
    assert_clean(out, names)
    for name in names:
        got = read_text(out / name)
        assert got == expected_bvh(mocap / name), name
        m = mlayer.read_bvh(out / name)
        assert m.n_frames == mlayer.read_bvh(mocap / name).n_frames
    doc = json.loads(read_text(report))
    assert doc["summary"] == {"outputs": 8, "ok": 8, "skipped": 0, "failed": 0, "links": 0}
    workers = {r["worker"] for r in doc["records"]}
    assert all(w.startswith("tls://127.0.0.1:") for w in workers)
    for r in doc["records"]:
        assert r["frames"] == r["frames_out"] > 0
        assert r["jitter_before"] > 0 and r["jitter_after"] > 0
        # the contact cleanup plants the feet about as well as the capture: a contact whose
        # denoised foot follows the input's path within 2% of the leg is left as it is (issue
        # 38: clean captures untouched), so the path lengths, mostly capture noise at 120 fps,
        # may exceed the input's a little (CMU 01_01: 1.074x, moved by 0.00% of body height)
        assert r["sliding_after"] <= r["sliding_before"] * 1.08, r["input"]
    table = res.table()
    assert "8 done, 0 up to date (skipped), 0 failed" in table


def test_stylize_alphas_match_single_clip(clips, tmp_path, cluster):
    out = tmp_path / "out"
    res = run_batch("stylize", clips, out, alphas="0.5:2:1.5", scheduler=cluster.scheduler_address,
                    progress=False)
    assert res.ok == 2 * len(SHORT) and res.exit_code == 0
    outs = []
    for name in SHORT:
        stem = name[:-4]
        for a in (0.5, 2.0):
            o = f"{stem}_alpha{a:g}.bvh"
            outs.append(o)
            assert read_text(out / o) == expected_bvh(clips / name, mlayer.stylize, alpha=a), o
    assert_clean(out, outs)
    # stylize with per-joint alphas and without the contact cleanup
    res = run_batch("stylize", [clips / SHORT[2]], tmp_path / "o2", alphas=[3],
                    joints={"Left*": 0.0}, keep_contacts=False,
                    scheduler=cluster.scheduler_address, progress=False)
    assert res.ok == 1, res.table()
    want = expected_bvh(clips / SHORT[2], mlayer.stylize, alpha=3, joints={"Left*": 0.0},
                        keep_contacts=False)
    assert read_text(tmp_path / "o2" / (SHORT[2][:-4] + "_alpha3.bvh")) == want


def test_features_npz(clips, tmp_path, cluster):
    out = tmp_path / "out"
    res = run_batch("features", clips, out, scheduler=cluster.scheduler_address,
                    progress=False)
    assert res.ok == len(SHORT)
    assert_clean(out, [n[:-4] + ".npz" for n in SHORT])
    for name in SHORT:
        m = mlayer.read_bvh(clips / name)
        lay = mlayer.decompose(m)
        cn, c = mlayer.detect_contacts(m)
        with np.load(out / (name[:-4] + ".npz")) as z:
            np.testing.assert_array_equal(z["control"], lay.control)
            np.testing.assert_array_equal(z["residual"], lay.residual)
            np.testing.assert_array_equal(z["base_rot"], lay.base.rot)
            np.testing.assert_array_equal(z["base_root_pos"], lay.base.root_pos)
            np.testing.assert_array_equal(z["lam_c"], lay.lam_c)
            np.testing.assert_array_equal(z["positions"], m.positions())
            np.testing.assert_array_equal(z["rot"], m.rot)
            np.testing.assert_array_equal(z["contacts"], c)
            assert list(z["contact_names"]) == cn
            assert list(z["joint_names"]) == m.joint_names
            assert float(z["fps"]) == m.fps
            np.testing.assert_array_equal(z["pose_features"], mlayer.pose_features(m))


def test_resample_and_timewarp(clips, tmp_path, cluster):
    addr = cluster.scheduler_address
    res = run_batch("resample", clips, tmp_path / "r", fps=24, scheduler=addr, progress=False)
    assert res.ok == len(SHORT)
    for name in SHORT:
        want = mlayer.write_bvh_string(mlayer.resample(mlayer.read_bvh(clips / name), fps=24))
        assert read_text(tmp_path / "r" / name) == want
        rec = next(r for r in res.records if r["input"].endswith(name))
        assert rec["frames_out"] == mlayer.read_bvh(tmp_path / "r" / name).n_frames
    res = run_batch("timewarp", clips, tmp_path / "t", strength=1.5, scheduler=addr,
                    progress=False)
    assert res.ok == len(SHORT)
    for name in SHORT:
        want = mlayer.write_bvh_string(mlayer.timewarp(mlayer.read_bvh(clips / name),
                                                       strength=1.5))
        assert read_text(tmp_path / "t" / name) == want


def _denoise_but_kill_worker_once(motion, variants, marker="", **options):
    """Kills its worker process the first time it runs (while the other clips are in flight),
    then behaves as denoise."""
    if not os.path.exists(marker):
        with open(marker, "w") as f:
            f.write(str(os.getpid()))
        os._exit(1)
    return [mlayer.denoise(motion, **options) for _ in variants]


def test_worker_killed_mid_run(clips, tmp_path, cluster):
    import cloudpickle
    cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers cannot import us
    try:
        marker = tmp_path / "killed-once"
        op = Operation("denoise-kill", _denoise_but_kill_worker_once, ".bvh",
                       frozenset({"marker"}))
        out = tmp_path / "out"
        with distributed.Client(cluster) as client:
            before = set(client.scheduler_info()["workers"])
            res = run_batch(op, clips, out, marker=str(marker), scheduler=client,
                            progress=False)
            client.wait_for_workers(2, timeout=60)
            after = set(client.scheduler_info()["workers"])
    finally:
        cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
    assert marker.exists()  # a worker did die ...
    assert before != after  # ... and the nanny replaced it
    assert res.exit_code == 0 and res.ok == len(SHORT), res.table()
    for name in SHORT:  # ... and every output is still right
        assert read_text(out / name) == expected_bvh(clips / name)
    assert_clean(out, list(SHORT))


def test_interrupted_run_resumes(mocap, tmp_path, cluster):
    """`mlayer batch` interrupted by SIGINT after its first output: the re-run skips what was
    done (untouched files), does the rest, and every output is right."""
    src = tmp_path / "in"
    src.mkdir()
    names = []
    for k in range(12):  # twelve clips on one worker: the run lasts a second or more
        n = f"walk{k}.bvh"
        shutil.copy2(mocap / "cmu_131_01_mj_style_walk.bvh", src / n)
        names.append(n)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "mlayer", "batch", "denoise", str(src),
                             "-o", str(out), "--workers", "1", "--no-progress"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        t_end = time.monotonic() + 120
        side = out / SIDECAR_DIR  # an output is done once its sidecar is written after it
        while time.monotonic() < t_end and proc.poll() is None:
            if side.is_dir() and any(side.glob("*.bvh.json")):
                break
            time.sleep(0.05)
        assert proc.poll() is None, proc.communicate()
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    written = {p.name: p.stat().st_mtime_ns for p in out.glob("*.bvh")}
    for name in written:  # what the interrupted run left is complete
        assert read_text(out / name) == expected_bvh(src / name)
    # done: written with its sidecar (the signal may fall between an output and its sidecar:
    # such an output is redone, as it must be without its record)
    done = {n: t for n, t in written.items() if (side / f"{n}.json").is_file()}
    assert 1 <= len(done) < len(names)

    res = run_batch("denoise", src, out, scheduler=cluster.scheduler_address, progress=False)
    status = {os.path.basename(r["output"]): r["status"] for r in res.records}
    assert status == {n: ("skipped" if n in done else "ok") for n in names}
    assert res.exit_code == 0
    for name in names:
        assert read_text(out / name) == expected_bvh(src / name)
    for name, mtime in done.items():
        assert (out / name).stat().st_mtime_ns == mtime  # not rewritten
    assert_clean(out, names)
    skipped = next(r for r in res.records if r["status"] == "skipped")
    assert skipped["frames"] == 994 and skipped["jitter_before"] > 0  # from the sidecar

    # an input changed, or other options: redone; everything else still up to date
    os.utime(src / names[0], ns=(time.time_ns(), time.time_ns()))
    res = run_batch("denoise", src, out, scheduler=cluster.scheduler_address, progress=False)
    assert [r["status"] for r in res.records] == ["ok"] + ["skipped"] * (len(names) - 1)
    res = run_batch("denoise", src, out, gamma=2.0, scheduler=cluster.scheduler_address,
                    progress=False)
    assert res.ok == len(names)
    (out / names[1]).write_text("truncated")  # an output touched by someone else: redone
    res = run_batch("denoise", src, out, gamma=2.0, scheduler=cluster.scheduler_address,
                    progress=False)
    assert [r["status"] for r in res.records] == ["skipped", "ok"] + ["skipped"] * (len(names) - 2)
    assert read_text(out / names[1]) == expected_bvh(src / names[1], gamma=2.0)


def test_bad_files_reported_cli_exit_code(clips, tmp_path, cluster, capsys):
    (clips / "broken.bvh").write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0\n")
    (clips / "empty.bvh").write_bytes(b"")
    (clips / "short.bvh").write_text(
        "HIERARCHY\nROOT Hips\n{\n OFFSET 0 0 0\n CHANNELS 3 Zrotation Xrotation Yrotation\n"
        " End Site\n {\n  OFFSET 0 1 0\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.1\n0 0 0\n"
        "1 1 1\n")
    # leftover temporary files of killed writers of our outputs and sidecars (named by the
    # rule of mlr_bvh.h, the C writer's and atomic_output's): swept
    out = tmp_path / "out"
    (out / SIDECAR_DIR).mkdir(parents=True)
    (out / ".broken.bvh.tmp-0123456789abcdef").write_text("partial")
    (out / f".{SHORT[0]}.tmp-fedcba9876543210.bvh").write_text("partial")
    (out / SIDECAR_DIR / f".{SHORT[1]}.json.tmp-00112233445566ff.json").write_text("{")
    report = tmp_path / "report.csv"
    from mlayer.cli import main
    code = main(["batch", "denoise", str(clips), "-o", str(out), "--scheduler",
                 cluster.scheduler_address, "--report", str(report), "--no-progress"])
    captured = capsys.readouterr()
    assert code == 1
    assert "3 of 6 outputs failed" in captured.err
    assert "FAILED" in captured.out and "broken.bvh" in captured.out
    import csv
    with open(report, newline="") as f:
        rows = {os.path.basename(r["input"]): r for r in csv.DictReader(f)}
    assert rows["broken.bvh"]["status"] == "failed"
    assert "ParseError" in rows["broken.bvh"]["error"] and "broken.bvh:" in \
        rows["broken.bvh"]["error"]
    assert rows["empty.bvh"]["status"] == "failed"
    assert rows["short.bvh"]["status"] == "failed" and "3 frames" in rows["short.bvh"]["error"]
    for name in SHORT:
        assert rows[name]["status"] == "ok"
        assert read_text(out / name) == expected_bvh(clips / name)
    assert_clean(out, list(SHORT))  # no output, partial or temporary file for the bad ones
    # fixing nothing and re-running: the good ones are skipped, the bad ones fail again
    code = main(["batch", "denoise", str(clips), "-o", str(out), "--scheduler",
                 cluster.scheduler_address, "--no-progress"])
    assert code == 1
    assert "3 done" not in capsys.readouterr().out


def test_cli_usage_errors(clips, tmp_path, capsys):
    from mlayer.cli import main
    assert main(["batch", "denoise", str(tmp_path / "nope"), "-o", str(tmp_path / "o")]) == 1
    assert "no such file" in capsys.readouterr().err
    assert main(["batch", "stylize", str(clips), "-o", str(tmp_path / "o"),
                 "--alphas", "2:1:0.5"]) == 1
    with pytest.raises(SystemExit) as e:
        main(["batch", "blur", str(clips), "-o", str(tmp_path / "o")])
    assert e.value.code == 2


def test_read_options_reach_the_workers_and_the_up_to_date_key(clips, tmp_path, cluster):
    addr = cluster.scheduler_address
    name = "cmu_02_03_run_jog_25fps.bvh"  # a CMU conversion with a lead-in at its start
    lead = mlayer.lead_in(mlayer.read_bvh(clips / name)).n_frames
    assert lead > 0
    out = tmp_path / "t"
    res = run_batch("denoise", clips, out, read={"trim": "auto"}, scheduler=addr,
                    progress=False)
    assert res.ok == len(SHORT)
    n = mlayer.read_bvh(clips / name).n_frames
    assert mlayer.read_bvh(out / name).n_frames == n - lead
    # the same run again is up to date; other read options make the outputs stale
    again = run_batch("denoise", clips, out, read={"trim": "auto"}, scheduler=addr,
                      progress=False)
    assert again.skipped == len(SHORT)
    redo = run_batch("denoise", clips, out, read={"trim": 2}, scheduler=addr, progress=False)
    assert redo.ok == len(SHORT) and mlayer.read_bvh(out / name).n_frames == n - 2
    for bad, msg in (({"trim": -1}, "read trim"), ({"up": "w"}, "read up"),
                     ({"units": "furlong"}, "read units"), ({"depth": 1}, "unknown read option"),
                     ("auto", "read must be a dict")):
        with pytest.raises(mlayer.InvalidArgumentError, match=msg):
            run_batch("denoise", clips, tmp_path / "bad", read=bad, scheduler=addr,
                      progress=False)
