"""One headless moderngl context (EGL; Mesa llvmpipe on CPU-only machines) per process, created lazily."""
from __future__ import annotations

import os
import threading

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
        import moderngl

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
        return ctx


def context_info() -> dict:
    """GL vendor/renderer/version strings of the process context (for bench reports)."""
    ctx = get_context()
    return {k: ctx.info.get(k) for k in ("GL_VENDOR", "GL_RENDERER", "GL_VERSION")}
