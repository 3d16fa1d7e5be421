"""Probe (not kept): the synthetic image's object colour mixed towards the background it sits on by
a * (1 - n.v)^P (a rim that mirrors what lies behind it at grazing view). Env RIM_A, RIM_P, RIM_K (json root)."""
import os, sys, json
import numpy as np
sys.path.insert(0, "/work/main/bench")
import ycbvss.refine.templates as tp
import ycbvss.refine.bundle as bu
import ycbvss.refine.contour_match as cm
from ycbvss.refine.edge import srgb_to_linear
from ycbvss.refine.srgb import encode_u8
A = float(os.environ.get("RIM_A", "0.5")); P = float(os.environ.get("RIM_P", "5"))
cams = json.load(open(os.environ["RIM_K"]))
K = np.array(next(iter(cams.values()))["cam_K"], np.float64).reshape(3, 3)
CUR = {}
_vec = tp.view_edge_candidates
def vec(vr, *a, **k):
    CUR["vr"] = vr
    return _vec(vr, *a, **k)
tp.view_edge_candidates = vec
bu.view_edge_candidates = vec
def grazing(normals):
    n = np.asarray(normals, np.float64); H, W = n.shape[:2]
    assert (H, W) == (480, 640), (H, W)
    u = (np.arange(W) - K[0, 2]) / K[0, 0]; v = (np.arange(H) - K[1, 2]) / K[1, 1]
    d = np.empty((H, W, 3)); d[..., 0], d[..., 1], d[..., 2] = u[None, :], v[:, None], 1.0
    d /= np.linalg.norm(d, axis=2, keepdims=True)
    nn = np.linalg.norm(n, axis=2, keepdims=True)
    n = n / np.maximum(nn, 1e-9)
    ndv = np.where(nn[..., 0] > 0.5, np.clip(-(n * d).sum(axis=2), 0.0, 1.0), 0.0)
    return (1.0 - ndv) ** P
def synthetic_image(instance, coverage, colour, image, ring_px=2.5, psf_sigma_px=0.0):
    from scipy.ndimage import distance_transform_edt
    inside = np.asarray(instance) > 0
    cov = inside.astype(np.float32) if coverage is None else np.clip(np.asarray(coverage, np.float32), 0.0, 1.0)
    far = distance_transform_edt(~inside) > ring_px
    lin_img = srgb_to_linear(image)
    _, (iy, ix) = distance_transform_edt(~far, return_indices=True)
    bg = lin_img[iy, ix]
    w = A * grazing(CUR["vr"].normal)[..., None]
    obj = (1.0 - w) * srgb_to_linear(colour) + w * bg
    lin = cov[..., None] * obj + (1.0 - cov[..., None]) * bg
    return encode_u8(lin)
tp.synthetic_image = synthetic_image
import bench_bias_frames
bench_bias_frames.main()
