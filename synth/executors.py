"""Where frames are synthesised: local Blender worker processes or Ray actors (each owning one worker).

Both run ``ycbvss.synth.frame:process_frame`` inside ``ycbvss.blender_scripts.worker`` processes, so
results are identical whichever executor and however many workers are used (per-frame seeds).
"""
from __future__ import annotations

from typing import Callable

from ..errors import YcbvssError
from .blender import BlenderWorker, default_workers, run_parallel

FRAME_FUNC = "ycbvss.synth.frame:process_frame"
COVERAGE_FUNC = "ycbvss.synth.coverage:coverage_frame"


class LocalExecutor:
    """``workers`` long-lived Blender worker processes on this machine, each rendering with
    cores // workers threads (default: cores // 2 workers x 2 threads = all cores; on 2 cores one worker with
    2 Cycles threads measured faster than two single-threaded workers, and each worker holds all textures)."""

    def __init__(self, workers: int | None = None):
        cores = default_workers()
        self.n = max(1, int(workers or cores // 2))
        self.threads = max(1, cores // self.n)
        self.pool: list[BlenderWorker] = []

    def _ensure(self):
        if not self.pool:
            self.pool = [BlenderWorker() for _ in range(self.n)]

    def map(self, config: dict, tasks: list[dict], on_result: Callable[[dict], None],
            func: str = FRAME_FUNC) -> list[dict]:
        if not tasks:
            return []
        self._ensure()
        cfg = {**config, "threads": self.threads}
        return run_parallel(self.pool, tasks, lambda w, t: w.call(func, config=cfg, task=t), on_result)

    def close(self):
        for w in self.pool:
            w.close()
        self.pool = []


def _chunks(items: list, n: int) -> list[list]:
    return [items[i:i + n] for i in range(0, len(items), n)]


class _RayFrameActor:
    """A Ray actor owning one Blender worker subprocess (kept warm across chunks)."""

    def __init__(self, threads: int):
        self.worker = BlenderWorker()
        self.threads = threads

    def run_chunk(self, config: dict, tasks: list[dict], func: str = FRAME_FUNC) -> list[dict]:
        cfg = {**config, "threads": self.threads}
        return [self.worker.call(func, config=cfg, task=t) for t in tasks]

    def close(self):
        self.worker.close()
        return True


class RayExecutor:
    """Distributes chunks of frames over a Ray cluster (``address='auto'``) or a local Ray instance
    (``address=None``: ``ray.init(num_cpus=...)``). One actor per ``cpus_per_worker`` CPUs."""

    def __init__(self, address: str | None = None, workers: int | None = None, chunk: int = 8,
                 cpus_per_worker: int = 2, num_cpus: int | None = None):
        try:
            # lazy: optional and heavy (Ray extra)
            import ray
        except ImportError:
            raise YcbvssError("the Ray executor needs Ray: pip install 'ycbvss[ray]'") from None
        self.ray = ray
        if not ray.is_initialized():
            if address:
                ray.init(address=address, include_dashboard=False, log_to_driver=False)
            else:
                ray.init(num_cpus=num_cpus or default_workers(), include_dashboard=False, log_to_driver=False)
        total = int(ray.cluster_resources().get("CPU", 1))
        cpus_per_worker = max(1, min(int(cpus_per_worker), total))
        self.n = max(1, int(workers or max(1, total // cpus_per_worker)))
        self.chunk = max(1, int(chunk))
        Actor = ray.remote(num_cpus=cpus_per_worker)(_RayFrameActor)
        self.actors = [Actor.remote(cpus_per_worker) for _ in range(self.n)]

    def map(self, config: dict, tasks: list[dict], on_result: Callable[[dict], None],
            func: str = FRAME_FUNC) -> list[dict]:
        # lazy: optional and heavy (Ray extra)
        from ray.util import ActorPool
        if not tasks:
            return []
        chunks = _chunks(tasks, self.chunk)
        pool = ActorPool(self.actors)
        out = []
        for res in pool.map_unordered(lambda a, c: a.run_chunk.remote(config, c, func), chunks):
            for r in res:
                on_result(r)
                out.append(r)
        key = {(t["scene_id"], t["im_id"]): i for i, t in enumerate(tasks)}
        return sorted(out, key=lambda r: key[(r["scene_id"], r["im_id"])])

    def close(self):
        try:
            self.ray.get([a.close.remote() for a in self.actors])
        except Exception:
            pass
        for a in self.actors:
            self.ray.kill(a)
        self.actors = []


def make_executor(kind: str = "local", workers: int | None = None, address: str | None = None,
                  chunk: int = 8):
    if kind == "local":
        return LocalExecutor(workers)
    if kind == "ray":
        return RayExecutor(address=address, workers=workers, chunk=chunk)
    raise YcbvssError(f"unknown executor {kind!r} (local or ray)")
