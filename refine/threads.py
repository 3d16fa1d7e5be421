"""The refiner's view thread pool, and one thread per numerical kernel while it runs.

The refiner parallelises over views (:func:`view_pool`, two threads beside the OpenGL thread, plus a flow
thread, see :mod:`ycbvss.refine.bundle` and :mod:`ycbvss.refine.matching`). OpenBLAS and OpenCV
each start their own worker threads per call on top of that: on 2 cores, BLAS products of a few
thousand rows and small OpenCV filters then pay for thread start-up and for OpenBLAS's spinning
workers without gaining any core. :func:`single_threaded_kernels` limits both to one thread for
the duration of a ``with`` block and restores the previous settings after it. Measured in
session 40: bench_refine's poses bit-identical, suite short-4's poses and statuses identical and
its sigmas within 2e-13 (the covariance's BLAS products sum in another order on one thread).
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from typing import Iterator


@contextmanager
def single_threaded_kernels() -> Iterator[None]:
    """BLAS (threadpoolctl) and OpenCV (``cv2.setNumThreads``) on one thread inside the block;
    both restored on exit. Process-wide while it lasts: other threads' BLAS / OpenCV calls run
    single-threaded too."""
    import cv2
    from threadpoolctl import threadpool_limits

    n_cv = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            yield
    finally:
        cv2.setNumThreads(n_cv)


_VIEW_POOL: tuple[int, ThreadPoolExecutor] | None = None   # (owning pid, executor)


def view_pool() -> ThreadPoolExecutor:
    """Two worker threads per process for per-view image work (re-created in a forked child)."""
    global _VIEW_POOL
    if _VIEW_POOL is None or _VIEW_POOL[0] != os.getpid():
        _VIEW_POOL = (os.getpid(), ThreadPoolExecutor(max_workers=2, thread_name_prefix="ycbvss-view"))
    return _VIEW_POOL[1]
