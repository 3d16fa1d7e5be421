"""refine.threads: BLAS and OpenCV run single-threaded inside the block and get their settings back after it."""
from __future__ import annotations

import cv2
import pytest
from threadpoolctl import threadpool_info

from ycbvss.refine.threads import single_threaded_kernels


def _blas_threads() -> list[int]:
    return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]


def test_limits_inside_and_restores_after():
    import numpy  # noqa: F401  (loads the BLAS threadpoolctl inspects)

    before_cv, before_blas = cv2.getNumThreads(), _blas_threads()
    with single_threaded_kernels():
        assert cv2.getNumThreads() == 1
        assert all(n == 1 for n in _blas_threads())
    assert cv2.getNumThreads() == before_cv and _blas_threads() == before_blas


def test_restores_after_an_error():
    before_cv = cv2.getNumThreads()
    with pytest.raises(RuntimeError):
        with single_threaded_kernels():
            raise RuntimeError("inside")
    assert cv2.getNumThreads() == before_cv
