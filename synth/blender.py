"""Blender in worker processes: a JSON-lines client for ``ycbvss.blender_scripts.worker`` and
:func:`render_job`, the render entry point other stages use (bpy is never imported here).

::

    from ycbvss.synth.blender import render_job
    results = render_job(job, workers=2)
"""
from __future__ import annotations

import hashlib
import json
import os
import queue
import shutil
import subprocess
import sys
import tempfile
import threading
import warnings
from pathlib import Path

from ..errors import YcbvssError


class WorkerDied(YcbvssError):
    pass


class BlenderWorker:
    """One long-lived worker subprocess. ``request(dict) -> result`` (raises on error replies)."""

    def __init__(self, log_path: str | os.PathLike | None = None, env: dict | None = None):
        log = os.environ.get("YCBVSS_BLENDER_LOG") if log_path is None else str(log_path)
        self._log = open(log, "ab") if log else subprocess.DEVNULL
        e = dict(os.environ)
        e.update(env or {})
        # the worker's scratch folder (render EXRs, textures) lives here and is removed at close()
        self._tmp = tempfile.mkdtemp(prefix="ycbvss-blender-")
        e["YCBVSS_BLENDER_TMP"] = self._tmp
        self.proc = subprocess.Popen([sys.executable, "-m", "ycbvss.blender_scripts.worker"],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log,
                                     text=True, bufsize=1, env=e)
        self.lock = threading.Lock()

    def request(self, req: dict):
        with self.lock:
            if self.proc.poll() is not None:
                raise WorkerDied(f"Blender worker exited with code {self.proc.returncode}")
            try:
                self.proc.stdin.write(json.dumps(req) + "\n")
                self.proc.stdin.flush()
                line = self.proc.stdout.readline()
            except (BrokenPipeError, OSError) as e:
                raise WorkerDied(f"Blender worker pipe broken: {e}") from None
            if not line:
                code = self.proc.wait(timeout=30)
                raise WorkerDied(f"Blender worker died (exit code {code}); set YCBVSS_BLENDER_LOG=file "
                                 "to see its log")
            reply = json.loads(line)
        if not reply.get("ok"):
            if reply.get("kind") == "YcbvssError":
                raise YcbvssError(reply.get("detail", reply["error"]), reply.get("path"), reply.get("where"))
            raise RuntimeError(f"Blender worker error: {reply.get('error')}\n{reply.get('traceback', '')}")
        return reply.get("result")

    def configure(self, settings: dict) -> None:
        self.request({"cmd": "configure", "settings": settings})

    def call(self, func: str, **kwargs):
        return self.request({"cmd": "call", "func": func, "kwargs": kwargs})

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self.request({"cmd": "quit"})
                self.proc.wait(timeout=30)
            except Exception:
                self.proc.kill()
                self.proc.wait()
        if self._log not in (None, subprocess.DEVNULL):
            self._log.close()
        shutil.rmtree(self._tmp, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def default_workers() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1))


def frame_seed(*parts) -> int:
    """Order-independent 31-bit seed from (seed, scene_id, im_id, ...) (stable across runs/machines)."""
    h = hashlib.sha256(("/".join(str(p) for p in parts)).encode()).digest()
    return int.from_bytes(h[:4], "little") & 0x7FFFFFFF


_SETTING_KEYS = ("width", "height", "samples", "denoise", "lights", "world_strength", "max_bounces", "material",
                 "filter_width")


def run_parallel(workers: list[BlenderWorker], tasks: list, fn, on_done=None) -> list:
    """Run ``fn(worker, task)`` for all tasks over the workers (one thread each); results in task order.
    The first exception is re-raised after the running tasks finish."""
    results = [None] * len(tasks)
    q: queue.Queue = queue.Queue()
    for i, t in enumerate(tasks):
        q.put((i, t))
    errors: list = []

    def loop(w):
        while not errors:
            try:
                i, t = q.get_nowait()
            except queue.Empty:
                return
            try:
                results[i] = fn(w, t)
                if on_done is not None:
                    on_done(results[i])
            except BaseException as e:   # noqa: BLE001 - re-raised in the caller's thread
                errors.append(e)
                return

    threads = [threading.Thread(target=loop, args=(w,), daemon=True) for w in workers]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    if errors:
        raise errors[0]
    return results


def render_job(job: dict, workers: int = 1, on_done=None) -> list[dict]:
    """Render the frames of ``job`` in Blender worker process(es) (Cycles, CPU).

    ``job``: ``{"width", "height", "samples", "seed", "denoise", "meshes": {key: {"path",
    "unit_scale"?, "scale"?}}, "lights"?, "world_strength"?, "frames": [{"id", "K", "objects":
    [{"mesh", "pass_index", "T_m2c" (4x4, mm)}], "out_dir"}]}``. Writes per frame into ``out_dir``:
    ``<id>_rgba.exr`` (linear, premultiplied RGBA float32), ``<id>_depth.exr`` (float32 z-depth mm,
    0 = background), ``<id>_index.png`` (uint8, uint16 if a pass_index > 255) and returns
    ``[{"id", "rgba", "depth", "index", "render_s"}, ...]`` in frame order. ``on_done(result)``
    (optional) is called as each frame finishes (e.g. to advance a progress bar).
    """
    frames = list(job.get("frames", []))
    if not frames:
        return []
    for key in ("meshes",):
        if key not in job:
            raise YcbvssError(f"render job lacks '{key}'")
    for key, m in job["meshes"].items():
        if not Path(m["path"]).is_file():
            raise YcbvssError(f"mesh '{key}' file missing", m["path"])
    for fr in frames:
        for ob in fr.get("objects", []):
            if ob["mesh"] not in job["meshes"]:
                raise YcbvssError(f"frame {fr.get('id')}: unknown mesh key {ob['mesh']!r}")
    n = max(1, min(int(workers), len(frames)))
    settings = {k: job[k] for k in _SETTING_KEYS if k in job}
    settings.setdefault("width", 640)
    settings.setdefault("height", 480)
    settings["threads"] = max(1, default_workers() // n)
    seed = int(job.get("seed", 0))
    pool = [BlenderWorker() for _ in range(n)]
    try:
        for w in pool:
            w.configure(settings)

        def one(w, fr):
            fseed = int(fr["seed"]) if "seed" in fr else frame_seed(seed, fr["id"])
            r = w.request({"cmd": "render", "frame": fr, "meshes": job["meshes"], "seed": fseed})
            for msg in r.pop("warnings", []):
                warnings.warn(msg, stacklevel=3)
            return r

        return run_parallel(pool, frames, one, on_done)
    finally:
        for w in pool:
            w.close()
