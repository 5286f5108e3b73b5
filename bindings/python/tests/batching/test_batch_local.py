"""mlayer.batch's default: a local process pool (no Dask), tasks of several clips.

Every output equals the single-clip function's; the tasks are chunks of clips, largest first;
a worker process that dies takes only its clip down; a script without a main guard works where
the pool forks and fails in one line where its processes import the script again.
"""
import json
import math
import os
import pathlib
import shutil
import subprocess
import sys

import pytest

import mlayer
from mlayer.batching import Operation, batch as run_batch
from mlayer.batching.run import CHUNKS_PER_WORKER, MAX_CHUNK, chunks, start_method

SHORT = ("bandai1_walk_happy_001.bvh", "cmu_02_03_run_jog_25fps.bvh",
         "cmu_131_01_mj_style_walk.bvh")
forks = pytest.mark.skipif(start_method() != "fork",
                           reason="the pool's processes are not forked here: the test's own "
                                  "operations cannot be imported by them")


@pytest.fixture
def clips(mocap, tmp_path):
    d = tmp_path / "in"
    d.mkdir()
    for name in SHORT:
        shutil.copy2(mocap / name, d / name)
    return d


def expected_bvh(src) -> str:
    return mlayer.write_bvh_string(mlayer.denoise(mlayer.read_bvh(src)))


def test_whole_corpus_on_the_local_pool(mocap, tmp_path, monkeypatch):
    """Without Dask at all: two worker processes, every output as mlayer.denoise writes it."""
    monkeypatch.setitem(sys.modules, "distributed", None)  # (the forked workers inherit it)
    out = tmp_path / "out"
    res = run_batch("denoise", mocap, out, n_workers=2, report=tmp_path / "r.json",
                    progress=False)
    names = sorted(p.name for p in mocap.glob("*.bvh"))
    assert res.exit_code == 0 and res.ok == len(names) and res.n_workers == 2, res.table()
    assert res.scheduler == ""
    for name in names:
        assert (out / name).read_text() == expected_bvh(mocap / name), name
    doc = json.loads((tmp_path / "r.json").read_text())
    workers = {r["worker"] for r in doc["records"]}
    assert all(w.startswith("pid ") for w in workers) and f"pid {os.getpid()}" not in workers
    assert 1 <= len(workers) <= 2
    for r in doc["records"]:
        assert r["jitter_before"] > 0 and r["jitter_after"] > 0 and r["seconds"] > 0
    again = run_batch("denoise", mocap, out, n_workers=2, progress=False)
    assert again.count("skipped") == len(names)


def test_chunks_are_sized_and_ordered(tmp_path):
    sizes = [5, 300, 40, 7, 1000, 2] * 20
    todo = []
    for k, n in enumerate(sizes):
        f = tmp_path / f"c{k}.bvh"
        f.write_bytes(b"x" * n)
        todo.append((str(f), [({}, f"o{k}", f"s{k}", "key")]))
    for workers in (1, 2, 8, 64):
        tasks = chunks(todo, workers)
        flat = [job for task in tasks for job in task]
        assert sorted(flat) == sorted(todo)  # every clip once
        # about CHUNKS_PER_WORKER tasks per worker, of at most MAX_CHUNK clips, all of one
        # size but the last
        size = min(MAX_CHUNK, math.ceil(len(todo) / (CHUNKS_PER_WORKER * workers)))
        assert [len(t) for t in tasks[:-1]] == [size] * (len(tasks) - 1)
        assert 1 <= len(tasks[-1]) <= size
        got = [os.path.getsize(job[0]) for job in flat]
        assert got == sorted(got, reverse=True)  # largest first
    assert [len(t) for t in chunks(todo[:3], 2)] == [1, 1, 1]


def _denoise_or_die(motion, variants, marker="", **options):
    """Kills its worker process on the clip of 213 frames (every time) and, once, on the first
    other clip it meets; denoise otherwise."""
    if motion.n_frames == 213:
        os._exit(3)
    if not os.path.exists(marker):
        pathlib.Path(marker).write_text(str(os.getpid()))
        os._exit(1)
    return [mlayer.denoise(motion, **options) for _ in variants]


@forks
def test_a_dying_worker_takes_only_its_clip_down(clips, tmp_path):
    op = Operation("denoise-or-die", _denoise_or_die, ".bvh", frozenset({"marker"}))
    marker = tmp_path / "died-once"
    out = tmp_path / "out"
    res = run_batch(op, clips, out, marker=str(marker), n_workers=2, progress=False)
    assert marker.exists()
    by_name = {pathlib.Path(r["input"]).name: r for r in res.records}
    killer = by_name.pop(SHORT[0])  # bandai1_walk_happy_001: 213 frames
    assert killer["status"] == "failed" and "worker process died" in killer["error"]
    assert res.exit_code == 1 and res.failed == 1 and res.ok == 2, res.table()
    for name in by_name:
        assert (out / name).read_text() == expected_bvh(clips / name)
    assert not (out / SHORT[0]).exists()


def _script(tmp_path, guarded: bool) -> pathlib.Path:
    wild = pathlib.Path(__file__).resolve().parents[4] / "tests" / "data" / "wild"
    call = (f"r = mlayer.batch('denoise', [{str(wild / 'pybvh_test1.bvh')!r}], "
            f"{str(tmp_path / 'out')!r}, n_workers=2)\nprint('records', len(r.records))\n")
    if guarded:
        call = "if __name__ == '__main__':\n" + "".join(f"    {x}\n" for x in call.splitlines())
    script = tmp_path / ("guarded.py" if guarded else "unguarded.py")
    script.write_text("import mlayer\n" + call)
    return script


def test_a_script_without_a_main_guard(tmp_path):
    """Works where the pool forks (Linux before Python 3.14); elsewhere fails before anything
    starts, in one line saying what to add. Under the guard it runs everywhere."""
    script = _script(tmp_path, guarded=False)
    p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path)
    if start_method() == "fork":
        assert p.returncode == 0 and "records 1" in p.stdout, p.stderr
    else:
        assert p.returncode != 0
        last = p.stderr.strip().splitlines()[-1]
        assert 'if __name__ == "__main__":' in last and f"{script}:2" in last, p.stderr
        assert not (tmp_path / "out").exists()
    p = subprocess.run([sys.executable, str(_script(tmp_path, guarded=True))],
                       capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert p.returncode == 0 and "records 1" in p.stdout, p.stderr


def test_spawned_pool_refuses_an_unguarded_script(tmp_path):
    """Where processes are spawned (macOS, Windows), an unguarded call is the one-line error;
    here forced by choosing spawn in the script."""
    script = _script(tmp_path, guarded=False)
    text = script.read_text().replace(
        "import mlayer\n", "import multiprocessing\nmultiprocessing.set_start_method('spawn')\n"
                           "import mlayer\n")
    script.write_text(text)
    p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                       timeout=300, cwd=tmp_path)
    assert p.returncode != 0
    lines = p.stderr.strip().splitlines()
    assert 'if __name__ == "__main__":' in lines[-1] and f"{script}:4" in lines[-1], p.stderr
    assert "InvalidArgumentError" in lines[-1]
    assert not (tmp_path / "out").exists()
