"""Probe (not kept): the lighting fit nearer the rim / a Schlick-Fresnel reflection basis. Env RIM_ERODE, RIM_FRESNEL."""
import os, sys
import numpy as np
sys.path.insert(0, "/work/main/bench")
import ycbvss.refine.shading as sh
import ycbvss.refine.bundle as bu
ER = int(os.environ.get("RIM_ERODE", "3"))
FR = os.environ.get("RIM_FRESNEL", "0") == "1"
_vl = sh.view_lighting
def vl(color, normals, instance, image, erode_px=3, max_px=40000, extra=None, additive=None):
    return _vl(color, normals, instance, image, ER, max_px, extra, additive)
sh.view_lighting = vl
bu.view_lighting = vl
if FR:
    _rb = sh.reflection_basis
    def rb(normals, K):
        b = _rb(normals, K)
        n = np.asarray(normals, np.float64)
        H, W = n.shape[:2]
        K = np.asarray(K, np.float64)
        u = (np.arange(W) - K[0, 2]) / K[0, 0]; v = (np.arange(H) - K[1, 2]) / K[1, 1]
        d = np.empty((H, W, 3)); d[..., 0], d[..., 1], d[..., 2] = u[None, :], v[:, None], 1.0
        d /= np.linalg.norm(d, axis=2, keepdims=True)
        n = n / np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-9)
        ndv = np.clip(-(n * d).sum(axis=2, keepdims=True), 0.0, 1.0)
        f = (1.0 - ndv) ** 5
        return np.concatenate([b, f * b], axis=2)
    sh.reflection_basis = rb
    bu.reflection_basis = rb
import bench_bias_frames
bench_bias_frames.main()
