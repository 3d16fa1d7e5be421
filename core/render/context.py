"""One headless moderngl context (EGL; Mesa llvmpipe on CPU-only machines) per process, created lazily."""
from __future__ import annotations

import ctypes
import os
import threading

import moderngl

from ..errors import YcbvssError

_LOCK = threading.Lock()
_CTX = None
_CTX_PID = None


def get_context():
    """The process-wide standalone moderngl context (created on first use; re-created after a fork).

    The context is not thread-safe: use one renderer per process (Ray workers are processes).
    """
    global _CTX, _CTX_PID
    with _LOCK:
        if _CTX is not None and _CTX_PID == os.getpid():
            return _CTX

        errors = []
        for kwargs in ({"backend": "egl"}, {}):
            try:
                ctx = moderngl.create_standalone_context(require=330, **kwargs)
                break
            except Exception as e:  # noqa: BLE001 - report every backend's failure below
                errors.append(f"{kwargs or 'default'}: {e}")
        else:
            raise YcbvssError("cannot create a headless OpenGL context (need EGL + Mesa llvmpipe or a GPU): "
                              + "; ".join(errors), where="ycbvss.render")
        _CTX, _CTX_PID = ctx, os.getpid()
        _tune_malloc()
        return ctx


def _tune_malloc() -> None:
    """Keep freed image-sized buffers in the heap (glibc) instead of returning them to the OS.

    Each render returns fresh (H, W) arrays; with glibc's default mmap threshold every one of them is a new
    mmap whose page faults cost ~1 ms per 640x480 frame -- a tenth of the frame budget on llvmpipe.
    Raising M_MMAP_THRESHOLD / M_TRIM_THRESHOLD makes repeated renders reuse heap memory.  Disable with
    ``YCBVSS_RENDER_NO_MALLOPT=1``.  No-op without glibc.
    """
    if os.environ.get("YCBVSS_RENDER_NO_MALLOPT"):
        return
    try:
        libc = ctypes.CDLL("libc.so.6")
        m_trim_threshold, m_mmap_threshold = -1, -3
        libc.mallopt(m_mmap_threshold, 32 * 1024 * 1024)
        libc.mallopt(m_trim_threshold, 256 * 1024 * 1024)
    except (OSError, AttributeError):
        pass


def context_info() -> dict:
    """GL vendor/renderer/version strings of the process context (for bench reports)."""
    ctx = get_context()
    return {k: ctx.info.get(k) for k in ("GL_VENDOR", "GL_RENDERER", "GL_VERSION")}
