"""Blender worker process: ``python -m ycbvss.blender_scripts.worker``.

Protocol: one JSON object per line on stdin, one JSON reply per line on the ORIGINAL stdout
(Blender's own prints are diverted to stderr so they cannot corrupt the protocol).

Requests::

    {"cmd": "configure", "settings": {width, height, samples, denoise, threads, lights, world_strength}}
    {"cmd": "render", "frame": {...}, "meshes": {...}, "seed": int}   # writes <id>_rgba/_depth/_index
    {"cmd": "call", "func": "package.module:function", "kwargs": {...}}  # func(worker, **kwargs)
    {"cmd": "quit"}

Replies: ``{"ok": true, "result": ...}`` or ``{"ok": false, "error": str, "kind": "YcbvssError"|...}``.
bpy is imported lazily on the first request that needs Blender.
"""
from __future__ import annotations

import importlib
import json
import os
import sys
import traceback

from .outputs import write_render_outputs
from .session import BlenderSession


class Worker:
    """State of one worker process: the Blender session (lazy) and a per-call-site cache."""

    def __init__(self):
        self._session = None
        self.settings: dict = {}
        self.cache: dict = {}

    @property
    def session(self):
        if self._session is None:
            self._session = BlenderSession()
            self._session.configure(**self.settings)
        return self._session

    def configure(self, settings: dict) -> None:
        self.settings = dict(settings)
        if self._session is not None:
            self._session.configure(**self.settings)

    def render(self, frame: dict, meshes: dict, seed: int) -> dict:
        """Render one frame (the render_job frame format) and return the pass arrays."""
        s = self.session
        s.set_meshes(meshes)
        return s.render(frame, meshes, seed)

    def handle(self, req: dict):
        cmd = req.get("cmd")
        if cmd == "configure":
            self.configure(req.get("settings", {}))
            return None
        if cmd == "render":
            frame = req["frame"]
            res = self.render(frame, req.get("meshes", {}), int(req.get("seed", 0)))
            paths = write_render_outputs(frame["out_dir"], frame["id"], res)
            warns, self.session.warnings[:] = list(self.session.warnings), []
            return {"id": frame["id"], **paths, "render_s": res["render_s"], "warnings": warns}
        if cmd == "call":
            mod_name, fn_name = req["func"].split(":")
            fn = getattr(importlib.import_module(mod_name), fn_name)
            return fn(self, **req.get("kwargs", {}))
        if cmd == "ping":
            return {"pid": os.getpid()}
        raise ValueError(f"unknown worker command {cmd!r}")


def main() -> int:
    proto = os.fdopen(os.dup(1), "w", buffering=1)
    os.dup2(2, 1)                      # anything printed by Blender goes to stderr
    sys.stdout = sys.stderr
    worker = Worker()
    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        try:
            req = json.loads(line)
        except json.JSONDecodeError as e:
            proto.write(json.dumps({"ok": False, "error": f"bad request: {e}", "kind": "protocol"}) + "\n")
            continue
        if req.get("cmd") == "quit":
            proto.write(json.dumps({"ok": True, "result": None}) + "\n")
            break
        try:
            result = worker.handle(req)
            reply = {"ok": True, "result": result}
        except Exception as e:  # report every failure to the parent, keep serving
            err = {"ok": False, "error": str(e), "kind": type(e).__name__,
                   "traceback": traceback.format_exc()}
            if type(e).__name__ == "YcbvssError":
                err.update(path=getattr(e, "path", None), where=getattr(e, "where", None),
                           detail=getattr(e, "detail", str(e)))
            reply = err
        proto.write(json.dumps(reply) + "\n")
    proto.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
