"""Writing a worker's render passes to files (atomic: temporary name + rename)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import OpenEXR

from ycbvss.io.atomic import atomic_path
from ycbvss.io.images import write_exr_depth, write_png


def write_exr_rgba(path, rgba: np.ndarray) -> None:
    """(H, W, 4) float32 linear RGBA -> OpenEXR float32 channels R, G, B, A (ZIP)."""
    a = np.ascontiguousarray(rgba, dtype=np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    chans = {c: np.ascontiguousarray(a[..., i]) for i, c in enumerate("RGBA")}
    with atomic_path(path, ".exr") as tmp:
        with OpenEXR.File(header, chans) as f:
            f.write(str(tmp))


def read_exr_rgba(path) -> np.ndarray:
    """Inverse of :func:`write_exr_rgba`: (H, W, 4) float32."""
    with OpenEXR.File(str(path), separate_channels=True) as f:
        ch = f.channels()
        return np.stack([np.asarray(ch[c].pixels, np.float32) for c in "RGBA"], axis=-1)


def write_render_outputs(out_dir, frame_id, result: dict) -> dict:
    """Write ``<id>_rgba.exr``, ``<id>_depth.exr`` (float32 mm, 0 = background), ``<id>_index.png``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {"rgba": out_dir / f"{frame_id}_rgba.exr", "depth": out_dir / f"{frame_id}_depth.exr",
             "index": out_dir / f"{frame_id}_index.png"}
    write_exr_rgba(paths["rgba"], result["rgba"])
    write_exr_depth(paths["depth"], result["depth_mm"])
    idx = result["index"]
    write_png(paths["index"], idx.astype(np.uint8) if idx.max(initial=0) < 256 else idx.astype(np.uint16),
              rgb=False)
    return {k: str(v) for k, v in paths.items()}
