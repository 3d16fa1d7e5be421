"""Image I/O (OpenCV): RGB, 16-bit depth PNG, label/mask PNG, float32 OpenEXR depth."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import OpenEXR

from ..errors import YcbvssError
from .atomic import atomic_path


def _imread(path, flags, where: str | None):
    if path is None:
        raise YcbvssError("image path not set", None, where)
    path = Path(path)
    if not path.is_file():
        raise YcbvssError("missing image file", path, where)
    im = cv2.imread(str(path), flags)
    if im is None:
        raise YcbvssError("corrupt or unreadable image", path, where)
    return im


def read_rgb(path, where: str | None = None) -> np.ndarray:
    """(H, W, 3) uint8 RGB."""
    im = _imread(path, cv2.IMREAD_COLOR, where)
    return cv2.cvtColor(im, cv2.COLOR_BGR2RGB)


def read_depth_mm(path, depth_scale: float = 1.0, where: str | None = None) -> np.ndarray:
    """16-bit PNG depth * depth_scale -> (H, W) float32 mm (0 = invalid). EXR is read as float."""
    path = Path(path) if path is not None else None
    if path is not None and path.suffix.lower() == ".exr":
        return read_exr_depth(path, where) * np.float32(depth_scale)
    im = _imread(path, cv2.IMREAD_ANYDEPTH, where)
    if im.ndim != 2:
        raise YcbvssError("depth image must be single-channel", path, where)
    return im.astype(np.float32) * np.float32(depth_scale)


def read_label(path, where: str | None = None) -> np.ndarray:
    im = _imread(path, cv2.IMREAD_UNCHANGED, where)
    if im.ndim == 3:
        im = im[..., 0]
    return im


def read_mask(path, where: str | None = None) -> np.ndarray:
    """Binary mask (H, W) bool."""
    return read_label(path, where) > 0


def write_png(path, image: np.ndarray, rgb: bool = True) -> None:
    """Write PNG atomically. 3-channel input is RGB (converted for OpenCV); uint16 allowed."""
    im = image
    if im.ndim == 3 and rgb:
        im = cv2.cvtColor(im, cv2.COLOR_RGB2BGR if im.shape[2] == 3 else cv2.COLOR_RGBA2BGRA)
    with atomic_path(path, ".png") as tmp:
        if not cv2.imwrite(str(tmp), im, [cv2.IMWRITE_PNG_COMPRESSION, 3]):
            raise YcbvssError("PNG encoder failed", path)


def write_jpg(path, image_rgb: np.ndarray, quality: int = 95) -> None:
    with atomic_path(path, ".jpg") as tmp:
        if not cv2.imwrite(str(tmp), cv2.cvtColor(image_rgb, cv2.COLOR_RGB2BGR),
                           [cv2.IMWRITE_JPEG_QUALITY, quality]):
            raise YcbvssError("JPEG encoder failed", path)


def write_depth_png(path, depth_mm: np.ndarray, depth_scale: float = 1.0) -> None:
    """Depth in mm -> uint16 PNG with value = round(depth_mm / depth_scale) (BOP convention)."""
    d = np.round(np.nan_to_num(depth_mm, nan=0.0, posinf=0.0) / depth_scale)
    if d.max(initial=0) > 65535:
        raise YcbvssError(f"depth exceeds uint16 range with depth_scale {depth_scale}", path)
    write_png(path, d.astype(np.uint16), rgb=False)


def read_exr_depth(path, where: str | None = None) -> np.ndarray:
    """Single-channel float32 OpenEXR (channel 'Z', 'Y', 'R' or 'V') -> (H, W) float32."""
    path = Path(path)
    if not path.is_file():
        raise YcbvssError("missing EXR file", path, where)
    try:
        with OpenEXR.File(str(path)) as f:
            ch = f.channels()
            for name in ("Z", "Y", "R", "V", "Depth.V"):
                if name in ch:
                    return np.asarray(ch[name].pixels, dtype=np.float32)
            first = next(iter(ch.values()))
            px = np.asarray(first.pixels, dtype=np.float32)
            return px if px.ndim == 2 else px[..., 0]
    except YcbvssError:
        raise
    except Exception as e:  # OpenEXR raises generic errors on corrupt files
        raise YcbvssError(f"corrupt EXR: {e}", path, where) from None


def write_exr_depth(path, depth: np.ndarray, channel: str = "Z") -> None:
    """(H, W) float32 -> single-channel float32 OpenEXR (ZIP compression), atomically."""
    d = np.ascontiguousarray(depth, dtype=np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with atomic_path(path, ".exr") as tmp:
        with OpenEXR.File(header, {channel: d}) as f:
            f.write(str(tmp))
