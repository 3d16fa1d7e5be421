"""Probe (not kept): an albedo-dependent grazing term in the per-view lighting: lit*(1 - a w) + b w,
w = (1 - n.v)^P, as an extra (multiplying the albedo) and an additive basis image. Env RIM_ERODE, RIM_P,
RIM_ADD (1: the additive w too)."""
import os, sys
import numpy as np
sys.path.insert(0, "/work/main/bench")
import ycbvss.refine.shading as sh
import ycbvss.refine.bundle as bu
ER = int(os.environ.get("RIM_ERODE", "3")); P = float(os.environ.get("RIM_P", "5")); ADD = os.environ.get("RIM_ADD", "1") == "1"
def grazing(normals, K):
    n = np.asarray(normals, np.float64); H, W = n.shape[:2]; K = np.asarray(K, np.float64)
    u = (np.arange(W) - K[0, 2]) / K[0, 0]; v = (np.arange(H) - K[1, 2]) / K[1, 1]
    d = np.empty((H, W, 3)); d[..., 0], d[..., 1], d[..., 2] = u[None, :], v[:, None], 1.0
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    n = n / np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-9)
    ndv = np.clip(-(n * d).sum(axis=2), 0.0, 1.0)
    return (1.0 - ndv) ** P
def _lit_colour(vr, image, light, rim_px=0, reflection_K=None):
    add = extra = None
    if reflection_K is not None:
        w = grazing(vr.normal, reflection_K)
        extra = w[..., None]
        add = sh.reflection_basis(vr.normal, reflection_K)
        if ADD:
            add = np.concatenate([add, w[..., None]], axis=2)
    if light is None:
        light = sh.view_lighting(vr.color, vr.normal, vr.instance, image, erode_px=ER, extra=extra, additive=add)
    if light is None:
        return np.asarray(vr.color), None
    return sh.lit_template(vr.color, vr.normal, vr.instance, image, coeffs=light, rim_px=rim_px, extra=extra, additive=add), light
bu._lit_colour = _lit_colour
import bench_bias_frames
bench_bias_frames.main()
