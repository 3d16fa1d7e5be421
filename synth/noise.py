"""Sensor noise and blur for rendered pixels (all parameters explicit, randomness from a passed Generator)."""
from __future__ import annotations

from dataclasses import asdict, dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class NoiseParams:
    """Signal-dependent noise in linear RGB [0, 1]: ``var = shot * x + read**2`` per channel
    (Poisson-Gaussian model; ``shot`` = 1 / full-well electrons at value 1), optional Gaussian blur
    of the render (``blur_sigma_px``, 0 = off) before compositing."""

    shot: float = 2.0e-3
    read: float = 4.0e-3
    blur_sigma_px: float = 0.0

    def to_dict(self) -> dict:
        return asdict(self)


def add_sensor_noise(lin: np.ndarray, weight: np.ndarray, params: NoiseParams,
                     rng: np.random.Generator) -> np.ndarray:
    """Add shot + read noise to linear RGB (H, W, 3) where ``weight`` (H, W) in [0, 1] > 0 (render alpha),
    scaled by the weight so anti-aliased edges blend into the untouched real background."""
    x = np.clip(lin, 0.0, None).astype(np.float32)
    sigma = np.sqrt(params.shot * x + params.read ** 2).astype(np.float32)
    n = rng.standard_normal(x.shape, dtype=np.float32) * sigma
    return (lin + n * weight[..., None].astype(np.float32)).astype(np.float32)


def blur_premultiplied(rgba: np.ndarray, sigma_px: float) -> np.ndarray:
    """Gaussian blur of a premultiplied RGBA render (colour and alpha together: no dark halos)."""
    if sigma_px <= 0:
        return rgba
    return cv2.GaussianBlur(np.ascontiguousarray(rgba, np.float32), (0, 0), float(sigma_px),
                            borderType=cv2.BORDER_REPLICATE)
