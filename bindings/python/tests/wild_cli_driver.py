"""Runs many `mlayer` command lines, each in a process of its own, for test_wild_corpus.py.

    python wild_cli_driver.py JOBS.json RESULTS.json

JOBS.json: a list of {"id": ..., "argv": [...], "log": PATH}. Each job runs `mlayer ARGV` as
the console script does (mlayer.cli.main, its return value the exit status; an exception that
escapes it is printed as Python prints it, "Traceback ..." on stderr, status 1), with stdout
and stderr going to LOG.out / LOG.err. Where the platform can fork, this process imports
mlayer once and forks a fresh child per job (a separate process per command, without paying
the interpreter and numpy start-up each time); elsewhere every job is a new interpreter
(`python -m mlayer`). RESULTS.json: {id: {"rc": status, "seconds": wall time}}.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time


def _run_forked(argv, log) -> int:
    pid = os.fork()
    if pid == 0:  # the child: stdout/stderr to the log files, then the CLI
        rc = 1
        try:
            out = os.open(log + ".out", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            err = os.open(log + ".err", os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(out, 1)
            os.dup2(err, 2)
            from mlayer import cli
            try:
                rc = cli.main(argv)
            except SystemExit as e:  # argparse usage errors
                rc = e.code if isinstance(e.code, int) else 1
            except BaseException:  # what the interpreter would print for the console script
                import traceback
                traceback.print_exc()
                rc = 1
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(int(rc or 0) & 0xFF)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status)


def _run_interpreter(argv, log) -> int:
    with open(log + ".out", "w") as out, open(log + ".err", "w") as err:
        return subprocess.run([sys.executable, "-m", "mlayer", *argv], stdout=out, stderr=err,
                              timeout=600).returncode


def main(jobs_path, results_path) -> int:
    with open(jobs_path) as f:
        jobs = json.load(f)
    fork = hasattr(os, "fork") and sys.platform.startswith("linux")
    if fork:
        try:  # (the `plot` extra: without it, the commands that draw say so themselves)
            import matplotlib
            matplotlib.use("Agg")
        except ImportError:
            pass
        from mlayer import cli  # noqa: F401  every command module imported once, before the forks
    results = {}
    for job in jobs:
        t0 = time.perf_counter()
        rc = (_run_forked if fork else _run_interpreter)(job["argv"], job["log"])
        results[job["id"]] = {"rc": rc, "seconds": time.perf_counter() - t0}
    with open(results_path, "w") as f:
        json.dump(results, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
