"""Run independent per-scene jobs in parallel: in this process, local processes, or Ray tasks.

``run_jobs(fn, jobs, workers, executor, address, desc, on_result)``: ``fn`` is a module-level function
(importable by name in a fresh process) taking one picklable job and returning a picklable result;
``on_result(job, result)`` runs in the calling process as each job finishes (write outputs, markers).
One tqdm bar over all jobs shows the overall progress and the ETA. The first error stops the run
(running jobs finish, queued ones are cancelled) and is re-raised; a :class:`YcbvssError` keeps its
one-line message.

- ``executor="local"``, ``workers=1``: the jobs run here, one after the other (no process start-up);
- ``executor="local"``, ``workers=N``: N spawned processes (spawn, not fork: OpenGL contexts do not
  survive a fork); each process is told to use cores // N threads (OMP/BLAS/numba);
- ``executor="ray"``: one Ray task per job on the cluster at ``address`` (ray is imported lazily: it
  is an optional dependency, ``pip install ycbvss[ray]``).
"""
from __future__ import annotations

import multiprocessing as mp
import os
from concurrent.futures import FIRST_EXCEPTION, ProcessPoolExecutor, wait
from typing import Callable, Iterable

from .errors import YcbvssError
from .progress import progress

_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")


def _cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def _init_worker(threads: int) -> None:
    for v in _THREAD_VARS:
        os.environ[v] = str(threads)
    os.environ["YCBVSS_NO_PROGRESS"] = "1"          # one overall bar, in the parent


def run_jobs(fn: Callable, jobs: Iterable, workers: int = 1, executor: str = "local", address: str | None = None,
             desc: str = "scenes", on_result: Callable | None = None, unit: str = "scene") -> list:
    """Results in job order (see module docstring)."""
    jobs = list(jobs)
    if executor not in ("local", "ray"):
        raise YcbvssError(f"unknown executor {executor!r} (local or ray)")
    workers = max(1, int(workers or 1))
    results = [None] * len(jobs)
    bar = progress(total=len(jobs), desc=desc, unit=unit)
    try:
        if executor == "ray":
            _run_ray(fn, jobs, address, results, bar, on_result)
        elif workers == 1 or len(jobs) <= 1:
            for i, job in enumerate(jobs):
                results[i] = fn(job)
                if on_result is not None:
                    on_result(job, results[i])
                bar.update(1)
        else:
            _run_local(fn, jobs, workers, results, bar, on_result)
    finally:
        bar.close()
    return results


def _run_local(fn, jobs, workers, results, bar, on_result) -> None:
    threads = max(1, _cores() // workers)
    with ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=mp.get_context("spawn"),
                             initializer=_init_worker, initargs=(threads,)) as pool:
        futs = {pool.submit(fn, job): i for i, job in enumerate(jobs)}
        pending = set(futs)
        while pending:
            done, pending = wait(pending, return_when=FIRST_EXCEPTION)
            for f in done:
                err = f.exception()
                if err is not None:
                    for p in pending:
                        p.cancel()
                    raise err
                i = futs[f]
                results[i] = f.result()
                if on_result is not None:
                    on_result(jobs[i], results[i])
                bar.update(1)


def _run_ray(fn, jobs, address, results, bar, on_result) -> None:
    try:
        # lazy: optional dependency
        import ray
    except ImportError:
        raise YcbvssError("--executor ray needs Ray: pip install 'ycbvss[ray]'") from None
    if not ray.is_initialized():
        ray.init(address=address, ignore_reinit_error=True, log_to_driver=False)
    remote = ray.remote(fn)
    refs = {remote.remote(job): i for i, job in enumerate(jobs)}
    pending = list(refs)
    while pending:
        done, pending = ray.wait(pending, num_returns=1)
        for r in done:
            i = refs[r]
            try:
                results[i] = ray.get(r)
            except ray.exceptions.RayTaskError as e:
                for p in pending:
                    ray.cancel(p)
                cause = e.cause if hasattr(e, "cause") else None
                raise (cause if isinstance(cause, YcbvssError) else YcbvssError(f"ray task failed: {e}")) from None
            if on_result is not None:
                on_result(jobs[i], results[i])
            bar.update(1)
