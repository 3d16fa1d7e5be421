"""The one exception type the CLI turns into a single clear error line (no traceback)."""
from __future__ import annotations

from pathlib import Path


class YcbvssError(Exception):
    """A user-facing error: bad input data, a missing file, an impossible request.

    The message names the file and, where known, the scene/frame/object, e.g.
    ``scene_gt.json: scene 48 frame 1 object 5: R is not orthonormal (|R^T R - I| = 0.3)``.
    """

    def __init__(self, message: str, path: str | Path | None = None, where: str | None = None):
        self.path = None if path is None else str(path)
        self.where = where
        self.detail = message
        parts = [p for p in (self.path, where) if p]
        super().__init__(": ".join(parts + [message]))


def where(scene_id: int | None = None, im_id: int | None = None, obj_id: int | None = None) -> str:
    """Format a location string ``scene S frame F object O`` (parts that are None are dropped)."""
    out = []
    if scene_id is not None:
        out.append(f"scene {scene_id}")
    if im_id is not None:
        out.append(f"frame {im_id}")
    if obj_id is not None:
        out.append(f"object {obj_id}")
    return " ".join(out)
