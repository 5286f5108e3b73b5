"""Running a batch: the plan of outputs, the workers (a local process pool, or a Dask cluster:
the caller's, or an embedded one), the tasks (chunks of clips) and the records gathered into a
:class:`BatchResult`.

The local default is a :class:`concurrent.futures.ProcessPoolExecutor`: one single-threaded
worker process per CPU (the C core runs one thread per call in the workers), so workers times
threads never exceed the cores. The clips are sorted largest first and cut into chunks of
several clips (about four chunks per worker, at most :data:`MAX_CHUNK` clips each), so that
sending a task costs a small fraction of its work and the last tasks are short. Dask is used
only when ``scheduler`` names a cluster (an address, a Client or a Cluster, or ``"dask"`` for
an embedded LocalCluster), with the same chunks.
"""
from __future__ import annotations

import ast
import contextlib
import logging
import math
import multiprocessing
import os
import pathlib
import sys
import time
import types
from collections.abc import Iterable, Iterator
from typing import Any

from .._args import integer
from ..errors import InvalidArgumentError
from .cache import options_key, sidecar_path, sweep, up_to_date
from .inputs import find_inputs
from .registry import Operation, lookup, variant_tag, variants
from .._optional import require
from .._progress import ProgressArg, resolve
from .report import FIELDS, STATUS_FAILED, STATUS_LINK, STATUS_SKIPPED, BatchResult
from .task import process_chunk, read_options

__all__ = ["batch"]

#: ``scheduler=EMBEDDED_DASK``: an embedded Dask LocalCluster (TLS on loopback) instead of the
#: local process pool
EMBEDDED_DASK = "dask"
#: the most clips in one task
MAX_CHUNK = 8
#: tasks per worker aimed at (load balance against the cost of sending a task)
CHUNKS_PER_WORKER = 4

#: (input, [(variant, output, sidecar, options key), ...]): the outputs of one clip still to do
Job = tuple[str, list[tuple[dict[str, Any], str, str, str]]]


def chunks(todo: list[Job], workers: int) -> list[list[Job]]:
    """The tasks: the clips, largest file first, cut into about CHUNKS_PER_WORKER chunks per
    worker of at most MAX_CHUNK clips (one clip per task when there are few)."""
    def size(job: Job) -> int:
        try:
            return os.stat(job[0]).st_size
        except OSError:
            return 0
    order = sorted(todo, key=size, reverse=True)
    n = max(1, min(MAX_CHUNK, math.ceil(len(order) / (CHUNKS_PER_WORKER * max(1, workers)))))
    return [order[i:i + n] for i in range(0, len(order), n)]


def start_method() -> str:
    """The start method of the local pool's processes: this platform's default (fork on Linux
    before Python 3.14, forkserver after, spawn on macOS and Windows)."""
    return multiprocessing.get_start_method(allow_none=True) or \
        multiprocessing.get_all_start_methods()[0]


def _init_worker() -> None:
    """A pool worker: one thread for the numeric libraries too (the workers are the
    parallelism), where threadpoolctl is there to say so."""
    with contextlib.suppress(Exception):
        from threadpoolctl import threadpool_limits  # optional (scikit-learn brings it)
        threadpool_limits(1)


def _default_workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def _client(scheduler: Any, n_workers: int | None) -> Iterator[Any]:
    from distributed import Client, LocalCluster  # checked by batch() (require)
    if scheduler is not None:
        if hasattr(scheduler, "scheduler_address"):  # a Cluster object
            with Client(scheduler) as client:
                yield client
        elif hasattr(scheduler, "submit"):  # a Client
            yield scheduler
        else:
            with Client(str(scheduler), timeout="30s") as client:
                yield client
        return
    import dask
    # no dashboard: the scheduler and each worker still start an HTTP server (this version of
    # distributed starts one even with dashboard_address=None, on 127.0.0.1:8787), so they
    # are given no routes (every request 404: no dashboard, health or metrics page for other
    # users of the machine to read) and a free port instead of 8787
    with dask.config.set({"distributed.scheduler.http.routes": [],
                          "distributed.worker.http.routes": []}), \
            LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True,
                         host="127.0.0.1", protocol="tls://", security=_embedded_security(),
                         dashboard_address="127.0.0.1:0", scheduler_kwargs={"dashboard": False},
                         silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
        yield client


def _failed(chunk: list[Job], error: str) -> list[list[dict[str, Any]]]:
    return [[{"input": src, "output": out, "variant": v, "status": STATUS_FAILED, "error": error}
             for v, out, _, _ in need] for src, need in chunk]


def _run_pool(op: Operation, tasks: list[list[Job]], args: tuple[Any, ...], workers: int,
              done: Any) -> None:
    """Run the tasks on a local process pool, calling ``done(chunk, records)`` as each one
    ends. A worker process that dies (killed, or crashed in C) breaks the pool: the clips of
    the tasks it took down are run again one at a time, each in a pool of one process, so that
    the clip that kills its process is reported failed and the others are done."""
    from concurrent.futures import ProcessPoolExecutor, as_completed
    from concurrent.futures.process import BrokenProcessPool
    ctx = multiprocessing.get_context(start_method())
    again: list[Job] = []
    with ProcessPoolExecutor(workers, mp_context=ctx, initializer=_init_worker) as ex:
        futures = {ex.submit(process_chunk, op, chunk, *args): chunk for chunk in tasks}
        try:
            for fut in as_completed(futures):
                chunk = futures[fut]
                try:
                    recs = fut.result()
                except BrokenProcessPool:
                    again.extend(chunk)
                    continue
                except Exception as e:  # noqa: BLE001  (e.g. a result that does not pickle)
                    recs = _failed(chunk, f"{type(e).__name__}: {e}")
                done(chunk, recs)
        except BaseException:  # (KeyboardInterrupt): stop the workers now, not after
            _terminate(ex)     # their tasks; the sweep removes what they were writing
            raise
    while again:  # one clip at a time: the first one not done is the one that killed
        with ProcessPoolExecutor(1, mp_context=ctx, initializer=_init_worker) as ex:
            futs = [ex.submit(process_chunk, op, [job], *args) for job in again]
            for k, fut in enumerate(futs):
                try:
                    recs = fut.result()
                except BrokenProcessPool:
                    done([again[k]], _failed([again[k]], "the worker process died on this clip "
                                             "(killed, or crashed in native code)"))
                    again = again[k + 1:]
                    break
                except Exception as e:  # noqa: BLE001
                    recs = _failed([again[k]], f"{type(e).__name__}: {e}")
                done([again[k]], recs)
            else:
                again = []


def _terminate(ex: Any) -> None:
    """Stop a process pool's workers at once and cancel what is queued."""
    if hasattr(ex, "terminate_workers"):  # Python 3.14
        ex.terminate_workers()
        return
    for proc in list((getattr(ex, "_processes", None) or {}).values()):
        with contextlib.suppress(Exception):
            proc.terminate()
    ex.shutdown(wait=False, cancel_futures=True)


def _run_dask(client: Any, op: Operation, tasks: list[list[Job]], args: tuple[Any, ...],
              done: Any) -> None:
    """Run the tasks on a Dask cluster (a task whose worker died is re-run by Dask)."""
    from distributed import as_completed
    futures = {client.submit(process_chunk, op, chunk, *args, pure=False): i
               for i, chunk in enumerate(tasks)}
    try:
        for fut in as_completed(futures):
            chunk = tasks[futures[fut]]
            try:
                recs = fut.result()
            except Exception as e:  # noqa: BLE001  (e.g. KilledWorker)
                recs = _failed(chunk, f"{type(e).__name__}: {e}")
            done(chunk, recs)
    except BaseException:
        client.cancel(list(futures))
        raise


def _is_main_test(test: ast.expr) -> bool:
    """``__name__ == "__main__"`` (either way round)."""
    if not (isinstance(test, ast.Compare) and len(test.ops) == 1 and
            isinstance(test.ops[0], ast.Eq)):
        return False
    sides = [test.left, test.comparators[0]]
    return (any(isinstance(x, ast.Name) and x.id == "__name__" for x in sides) and
            any(isinstance(x, ast.Constant) and x.value == "__main__" for x in sides))


def unguarded_call() -> str | None:
    """Where the main script calls into this outside ``if __name__ == "__main__":`` (the
    script's path and line), else None. The embedded cluster's worker processes start by
    importing the main script again (multiprocessing's spawn), so such a call would start a
    cluster in every worker: Dask then fails with pages of "Nanny failed to start". Only a
    script run by path counts (a package's ``__main__``, as ``python -m mlayer``, is not
    imported again)."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    spec = getattr(main, "__spec__", None)
    if not path or (spec is not None and spec.name.endswith("__main__")):
        return None
    frame: types.FrameType | None = sys._getframe(1)
    while frame is not None and not (frame.f_code.co_name == "<module>" and
                                     frame.f_globals.get("__name__") == "__main__"):
        frame = frame.f_back
    if frame is None:
        return None
    line = frame.f_lineno
    try:
        tree = ast.parse(pathlib.Path(path).read_text(encoding="utf-8"))
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return None
    for node in ast.walk(tree):
        if (isinstance(node, ast.If) and _is_main_test(node.test) and
                node.lineno <= line <= (node.end_lineno or node.lineno)):
            return None
    return f"{path}:{line}"


def _embedded_security() -> Any:
    """Mutual TLS with credentials made for this run only (``Security.temporary()``: a new
    self-signed CA, certificate and key, held by this process and handed to the workers it
    starts). The embedded scheduler runs
    arbitrary tasks for whoever connects to it, and loopback is open to every user of the
    machine: with TLS, only this process and the workers it starts hold a certificate the
    scheduler accepts (a client without one, or with its own, is disconnected in the TLS
    handshake)."""
    from distributed.security import Security  # cryptography: checked by batch() (require)
    return Security.temporary()

def batch(operation: str | Operation,
          inputs: str | os.PathLike[str] | Iterable[str | os.PathLike[str]],
          out_dir: str | os.PathLike[str], *, alphas: str | float | Iterable[Any] | None = None,
          scheduler: Any = None, n_workers: int | None = None,
          report: str | os.PathLike[str] | None = None, progress: ProgressArg = None,
          force: bool = False, metrics: bool = True, read: dict[str, Any] | None = None,
          **options: Any) -> BatchResult:
    """Run an operation over every clip of ``inputs`` in parallel, writing into ``out_dir``.

    By default on a local pool of worker processes (one per CPU, one thread each); on Dask
    when ``scheduler`` is given. Each task is a chunk of clips (largest first), so that the
    cost of sending a task is a small part of its work.

    Parameters
    ----------
    operation : str or Operation
        ``"denoise"``, ``"stylize"``, ``"features"``, ``"resample"``, ``"timewarp"``, another
        name registered with :func:`register_operation` (see :func:`operations`), or an
        :class:`Operation`.
    inputs : str, os.PathLike or a list of them
        A folder (every .bvh below it), a glob (``"captures/**/*.bvh"``), a file, or a list
        of these; outputs keep the paths relative to the folder (the glob's fixed part).
    out_dir : str or os.PathLike
        Created if needed. Outputs: ``<rel>.bvh``, ``<rel>_alpha<A>.bvh`` per alpha for
        stylize, ``<rel>.npz`` for features.
    alphas : float, sequence or str, optional
        Stylize only: one alpha or several (a list, a range such as np.arange, or a string
        ``"0.5:2.5:0.5"`` or ``"1,1.5,2"``); default 2.
    scheduler : None, str, or a dask Client or Cluster, optional
        None (default): a local :class:`concurrent.futures.ProcessPoolExecutor` (no Dask
        needed); where processes are started by spawn or forkserver (macOS, Windows, Python
        3.14 on Linux) they import the main script again, so a script must call this under
        ``if __name__ == "__main__":`` (an unguarded call fails at once, saying so).
        ``"tls://host:8786"`` or ``"tcp://host:8786"``: an existing Dask cluster (a dask
        Client or LocalCluster object also works). ``"dask"``: an embedded Dask LocalCluster
        on loopback, secured by mutual TLS with credentials made for this run (other users of
        the machine cannot connect); slower than the local pool on one machine, it is there to
        try Dask. Securing a cluster of your own is its owner's business: a tcp:// scheduler
        runs the tasks of anyone who can reach its port. Start it with TLS (``dask scheduler
        --tls-ca-file ca.pem --tls-cert sched.pem --tls-key sched.key``, the workers
        likewise) and give this process its credentials in the Dask configuration
        (``distributed.comm.tls.ca-file`` and ``distributed.comm.tls.client.cert`` /
        ``.key``, e.g. the environment variables DASK_DISTRIBUTED__COMM__TLS__CA_FILE,
        ..._CLIENT__CERT, ..._CLIENT__KEY), or pass
        ``Client(address, security=Security(...))`` as ``scheduler``.
    n_workers : int, optional
        Worker processes of the local pool or the embedded Dask cluster (default: one per
        CPU, at most one per clip).
    report : str or os.PathLike, optional
        Write the records there: .json, or CSV for any other extension.
    progress : None, bool, stream or callable, optional
        A progress bar over clips (tqdm): None (default) on stderr when it is a terminal,
        True, False, a stream, or a callable ``f(done, total)``.
    force : bool, optional
        Redo outputs that are up to date.
    metrics : bool, optional
        Compute jitter and foot sliding before/after (costs a few forward kinematics).
    read : dict, optional
        How the workers read each clip: read_bvh's strict, up, trim and units (for example
        ``{"trim": "auto", "up": "z"}``); part of the outputs' up-to-date key.
    **options
        The operation's keyword arguments: keep_contacts=False, gamma, lam_c, sigma_c, joints
        and root_alpha (stylize), fps / n_frames / lam (resample), strength ...

    Returns
    -------
    BatchResult
        The records; ``result.exit_code`` is 1 when any clip failed.

    Raises
    ------
    mlayer.InvalidArgumentError
        Before anything runs, for an unknown operation or option, no inputs, outputs that
        would collide or overwrite an input, or a call at the top level of a script, outside
        ``if __name__ == "__main__":``, which the worker processes would run again (the
        embedded Dask cluster; the local pool where it does not fork).
    mlayer.MissingDependencyError
        (the ``batch`` extra) Before anything runs, with a ``scheduler`` but without Dask, or
        without cryptography for the embedded Dask cluster.
    """
    t0 = time.perf_counter()
    embedded = isinstance(scheduler, str) and scheduler == EMBEDDED_DASK
    if scheduler is not None:
        require("distributed", feature="mlayer.batch(scheduler=...) on Dask")
    if embedded:  # the embedded cluster's TLS: Security.temporary needs cryptography
        require("cryptography", feature="mlayer.batch's embedded Dask cluster (TLS)")
    # the processes that import the main script again: Dask's (spawned) and the local pool's
    # but where it forks
    if embedded or (scheduler is None and start_method() != "fork"):
        where = unguarded_call()
        if where is not None:
            raise InvalidArgumentError(
                f"mlayer.batch: called at the top level of the script ({where}): its worker "
                f"processes import the script again; put the call under "
                f"`if __name__ == \"__main__\":`")
    make_bar = resolve(progress, "mlayer.batch")
    read = read_options(read)
    op = lookup(operation)
    bad = sorted(set(options) - set(op.options))
    if bad:
        raise InvalidArgumentError(f"batch {op.name}: unknown option(s) {', '.join(bad)}; "
                                   f"accepted: {', '.join(sorted(op.options)) or 'none'}")
    runs = variants(op, alphas)
    if n_workers is not None:
        if scheduler is not None and not embedded:
            raise InvalidArgumentError("n_workers sizes the local pool (or the embedded "
                                       "cluster); the cluster at `scheduler` has its own "
                                       "workers")
        integer(n_workers, "n_workers", 1)
    out_root = pathlib.Path(out_dir).resolve()
    links: list[tuple[str | pathlib.Path, str]] = []
    clips = find_inputs(inputs, exclude=out_root, links=links)
    if not clips:
        raise InvalidArgumentError(f"no .bvh files in {inputs!r}")
    inputs_set = {str(src) for src, _ in clips} | {os.path.realpath(src) for src, _ in clips}
    plan: list[tuple[str, list[tuple[dict[str, Any], str, str, str]]]] = []
    seen: dict[str, pathlib.Path] = {}
    for src_path, rel in clips:
        jobs: list[tuple[dict[str, Any], str, str, str]] = []
        for v in runs:
            out = out_root / rel.parent / (rel.name + variant_tag(v) + op.extension)
            if str(out) in inputs_set or os.path.realpath(out) in inputs_set:
                raise InvalidArgumentError(f"batch: output {out} would overwrite an input; "
                                           "choose another output folder")
            if str(out) in seen:
                raise InvalidArgumentError(f"batch: {src_path} and {seen[str(out)]} both map "
                                           f"to {out}")
            seen[str(out)] = src_path
            jobs.append((v, str(out), str(sidecar_path(out_root, out)),
                         options_key(op, options, v, read)))
        plan.append((str(src_path), jobs))

    all_outs = [pathlib.Path(o) for _, jobs in plan for _, o, _, _ in jobs]
    # the outputs and their sidecars: what a killed writer may have left temporaries of
    written = all_outs + [pathlib.Path(s) for _, jobs in plan for _, _, s, _ in jobs]
    records_by_out: dict[str, dict[str, Any]] = {}
    todo: list[tuple[str, list[tuple[dict[str, Any], str, str, str]]]] = []
    for src, jobs in plan:
        need = []
        for job in jobs:
            v, out_s, side, key = job
            prev = None if force else up_to_date(src, pathlib.Path(out_s), pathlib.Path(side),
                                                 key)
            if prev is None:
                need.append(job)
            else:
                rec = {k: prev.get(k) for k in FIELDS}
                rec.update(input=src, output=out_s, variant=v, status=STATUS_SKIPPED, error="")
                records_by_out[out_s] = rec
        if need:
            todo.append((src, need))
    for d in {p.parent for p in all_outs}:
        d.mkdir(parents=True, exist_ok=True)
    sweep(written)

    n_used, address = 0, ""
    if todo:
        workers = n_workers or min(_default_workers(), len(todo))
        args = (options, metrics, read)
        bar = make_bar(len(todo), op.name, "clip")
        failed = 0

        def done(chunk: list[Job], recs: list[list[dict[str, Any]]]) -> None:
            nonlocal failed
            for clip_recs in recs:
                for r in clip_recs:
                    records_by_out[r["output"]] = r
                if any(r["status"] == STATUS_FAILED for r in clip_recs):
                    failed += 1
                    bar.set_postfix_str(f"{failed} failed")
            bar.update(len(chunk))

        try:
            if scheduler is None:
                n_used = workers
                _run_pool(op, chunks(todo, workers), args, workers, done)
            else:
                with _client(None if embedded else scheduler,
                             workers if embedded else None) as client:
                    address = client.scheduler.address if client.scheduler else ""
                    n_used = len(client.scheduler_info().get("workers", {})) or workers
                    _run_dask(client, op, chunks(todo, n_used), args, done)
        finally:
            bar.close()
            sweep(written)
    records = []
    for o in all_outs:
        r = records_by_out[str(o)]
        records.append({k: r.get(k) for k in FIELDS})
    for path, note in links:  # links to folders and dangling links: said, not silently lost
        rec = dict.fromkeys(FIELDS)
        rec.update(input=os.path.abspath(path), output="", variant={}, status=STATUS_LINK,
                   error=note)
        records.append(rec)
    result = BatchResult(op.name, records, time.perf_counter() - t0, n_used, address)
    if report is not None:
        result.write_report(report)
    return result
