"""One headless moderngl context (EGL; Mesa llvmpipe on CPU-only machines) per process, created lazily."""
from __future__ import annotations

import ctypes
import os
import threading

import moderngl
import numpy as np

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


class _GilFreeGL:
    """The few OpenGL calls of a draw and its read-back, made through ctypes, which releases
    Python's GIL around each foreign call.

    moderngl's ``VertexArray.render`` (llvmpipe transforms and bins the triangles in the calling
    thread) and ``Framebuffer.read_into`` (``glReadPixels`` waits for the rasteriser, then converts
    the pixels) hold the GIL while they work, so the refiner's view-pool threads cannot run Python
    for as long as a frame takes. These functions issue the same GL calls as those two methods
    (``glUseProgram``, ``glBindVertexArray``, ``glDrawElementsInstanced``; ``glBindFramebuffer``,
    ``glReadBuffer``, ``glPixelStorei``, ``glClampColor``, ``glReadPixels``), so the pixels are the
    same. Loaded from GLVND's ``libOpenGL.so.0`` (the EGL context's dispatch) and used only when its
    ``glGetString(GL_RENDERER)`` names the moderngl context's renderer; otherwise, or with
    ``YCBVSS_RENDER_GIL_FREE=0``, ``ok`` is False and the renderer uses moderngl's methods. Call them
    on the context's thread only.
    """

    GL_TRIANGLES, GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0 = 0x0004, 0x8D40, 0x8CE0
    GL_PACK_ALIGNMENT, GL_UNPACK_ALIGNMENT, GL_CLAMP_READ_COLOR = 0x0D05, 0x0CF5, 0x891C
    INDEX_TYPE = {1: 0x1401, 2: 0x1403, 4: 0x1405}           # GL_UNSIGNED_BYTE / SHORT / INT
    FORMAT = {1: 0x1903, 2: 0x8227, 3: 0x1907, 4: 0x1908}     # GL_RED, GL_RG, GL_RGB, GL_RGBA
    TYPE = {"f1": 0x1401, "f4": 0x1406}                       # GL_UNSIGNED_BYTE, GL_FLOAT

    def __init__(self) -> None:
        self.ok = False
        if os.environ.get("YCBVSS_RENDER_GIL_FREE", "1") == "0":
            return
        try:
            lib = ctypes.CDLL("libOpenGL.so.0")
            u, i, p = ctypes.c_uint, ctypes.c_int, ctypes.c_void_p
            sig = {"glUseProgram": [u], "glBindVertexArray": [u], "glDrawElementsInstanced": [u, i, u, p, i],
                   "glBindFramebuffer": [u, u], "glReadBuffer": [u], "glPixelStorei": [u, i],
                   "glClampColor": [u, u], "glReadPixels": [i, i, i, i, u, u, p]}
            for name, args in sig.items():
                fn = getattr(lib, name)
                fn.restype, fn.argtypes = None, args
                setattr(self, name[2:], fn)
            get_string = lib.glGetString
            get_string.restype, get_string.argtypes = ctypes.c_char_p, [u]
            theirs = get_context().info.get("GL_RENDERER")
            mine = get_string(0x1F01)       # GL_RENDERER, through this library's dispatch
        except (OSError, AttributeError):
            return
        # the calls reach the moderngl context only when both go through the same dispatch (GLVND):
        # otherwise this library has no current context and would draw and read nothing
        self.ok = bool(mine) and mine.decode(errors="replace") == theirs

    def draw_indexed(self, program_glo: int, vao_glo: int, n_indices: int, index_size: int) -> None:
        """``VertexArray.render(TRIANGLES)`` of an indexed vertex array (all its indices, one instance)."""
        self.UseProgram(program_glo)
        self.BindVertexArray(vao_glo)
        self.DrawElementsInstanced(self.GL_TRIANGLES, n_indices, self.INDEX_TYPE[index_size], None, 1)

    def read_into(self, fbo_glo: int, out: np.ndarray, attachment: int, components: int, dtype: str) -> None:
        """``Framebuffer.read_into(out, components=..., attachment=..., dtype=..., alignment=1)`` of
        the whole (H, W) framebuffer into the C-contiguous array ``out``; leaves ``fbo_glo`` bound."""
        if not out.flags.c_contiguous:
            raise ValueError("read_into needs a C-contiguous array")
        H, W = out.shape[:2]
        self.BindFramebuffer(self.GL_FRAMEBUFFER, fbo_glo)
        self.ReadBuffer(self.GL_COLOR_ATTACHMENT0 + attachment)
        self.PixelStorei(self.GL_PACK_ALIGNMENT, 1)
        self.PixelStorei(self.GL_UNPACK_ALIGNMENT, 1)
        self.ClampColor(self.GL_CLAMP_READ_COLOR, 0)
        self.ReadPixels(0, 0, W, H, self.FORMAT[components], self.TYPE[dtype], out.ctypes.data)


_GL: tuple[int, _GilFreeGL] | None = None    # (owning pid, the calls)


def gil_free_gl() -> _GilFreeGL:
    """The process's :class:`_GilFreeGL` (loaded on first use; again after a fork)."""
    global _GL
    if _GL is None or _GL[0] != os.getpid():
        _GL = (os.getpid(), _GilFreeGL())
    return _GL[1]


def context_info() -> dict:
    """GL vendor/renderer/version strings of the process context (for bench reports)."""
    ctx = get_context()
    return {k: ctx.info.get(k) for k in ("GL_VENDOR", "GL_RENDERER", "GL_VERSION")}
