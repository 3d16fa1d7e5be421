"""Does a grazing-angle specular basis in the per-view lighting fit predict the contour better?

The lit templates (``refine/shading.py``) model the image as albedo x a quadratic in the normal
(Lambert, SH order 2). A glossy surface also reflects its surroundings, most at grazing angles
(Schlick: (1 - n.v)^p): dark glossy objects (clamps, mug, marker) get a brighter rim in a Cycles
image, which the model lacks. This bench adds one additive basis image per channel, (1 - n.v)^p x
255 in linear light, to the per-view least-squares fit, and measures at the exact GT of suite
frames, per object, the mean over views of the median image-edge offset (px, outward +) from the
lit contour prediction (as ``bench_contour_offsets.py --objects``) with and without it.

    python bench/bench_fresnel_rim.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \
        --scenes 4,5,6,7 --frames 0,10,20 --out bench/results/ycbv21/s70
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

MODES = ("lit", "lit + grazing specular")


def view_dirs(K: np.ndarray, H: int, W: int) -> np.ndarray:
    """(H, W, 3) unit directions from each pixel centre's surface point towards the camera (camera frame)."""
    u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
    d = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1)
    return -d / np.linalg.norm(d, axis=-1, keepdims=True)


def grazing_basis(normals: np.ndarray, to_cam: np.ndarray, power: float = 5.0) -> np.ndarray:
    """(H, W) Schlick's grazing factor (1 - n.v)^power of camera-frame normals (H, W, 3)."""
    n = normals / np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-9)
    return (1.0 - np.clip(np.sum(n * to_cam, -1), 0.0, 1.0)) ** power


def shade_with_grazing(albedo: np.ndarray, normals: np.ndarray, mask: np.ndarray, C: np.ndarray, F: np.ndarray) -> np.ndarray:
    """The template lit by ``C`` (3, 10) of ``refine.shading.fit_shading(..., additive=F)`` where ``mask``: (H, W, 3) uint8 sRGB."""
    from ycbvss.refine.edge import srgb_to_linear
    from ycbvss.refine.shading import _linear_to_srgb_u8, sh9_basis

    out = albedo.copy()
    px = np.flatnonzero(mask)
    n = normals.reshape(-1, 3)[px].astype(np.float64)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-9)
    s = np.clip(sh9_basis(n) @ C[:, :9].T, 0.0, None)
    add = F.reshape(-1)[px][:, None] * 255.0 * C[:, 9][None]
    flat = out.reshape(-1, 3)
    flat[px] = _linear_to_srgb_u8(np.clip(srgb_to_linear(flat[px]) * s + add, 0.0, 255.0))
    return out


def main() -> None:
    import cv2

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench_contour_offsets import add_view_args, gt_views
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.refine.contour_match import _minimum_along
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.shading import fit_shading, lit_template
    from ycbvss.refine.templates import view_edge_candidates

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_args(ap)
    ap.add_argument("--erode", type=int, default=3, help="fit this many px inside the silhouettes (view_lighting's 3)")
    ap.add_argument("--power", type=float, default=5.0, help="p of (1 - n.v)^p")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    acc: dict = {}
    names: dict = {}
    ks = []
    for models, _, fr, img, vr, oids in gt_views(a):
        F = grazing_basis(vr.normal, view_dirs(fr.camera.K, *img.shape[:2]), a.power)
        obj = vr.instance > 0
        inner = cv2.erode(obj.astype(np.uint8), np.ones((2 * a.erode + 1,) * 2, np.uint8)).astype(bool)
        C = fit_shading(img, vr.color, vr.normal, inner, additive=F)
        ks.append(C[:, 9])
        fld = edge_field(img, 1.0, colour=True)
        for mode, col in zip(MODES, (lit_template(vr.color, vr.normal, vr.instance, img),
                                     shade_with_grazing(vr.color, vr.normal, obj, C, F))):
            c = view_edge_candidates(vr, blur_sigma_px=1.0, normals=True, image=img, appearance_color=col)
            for lab0, oid in enumerate(oids):
                names[oid] = models[oid].name or str(oid)
                sel = np.flatnonzero((c.l_c == lab0 + 1) & np.any(c.n_c != 0.0, axis=1))
                if len(sel) < 40:
                    continue
                t = _minimum_along(fld, c.uv_c[sel], c.n_c[sel], 1.5, 0.25)
                ok = np.abs(t) < 1.5 - 0.25               # a minimum at the window's end: no edge found
                if ok.sum() >= 10:
                    acc.setdefault((oid, mode), []).append(float(np.median(t[ok])))
    k = np.array(ks)
    tab = Table(columns=[f"{m} (px)" for m in MODES], label_header="object", digits=3,
                caption=f"Image edge minus the lit contour prediction at the exact GT (px, outward +), mean over views of "
                        f"the per-view median; second column with an additive (1 - n.v)^{a.power:g} basis in the lighting "
                        f"fit ({a.erode} px inside the silhouettes; its weight per channel, mean over views "
                        f"{np.round(k.mean(0), 3).tolist()} x 255 linear); scenes {a.scenes}, frame positions {a.frames}")
    per: dict = {m: [] for m in MODES}
    for o in sorted(names):
        if (o, MODES[0]) not in acc or (o, MODES[1]) not in acc:
            continue
        v = [float(np.mean(acc[(o, m)])) for m in MODES]
        for m, x in zip(MODES, v):
            per[m].append(x)
        tab.rows.append(Row(names[o], v))
    tab.rows.append(Row("mean over objects", [float(np.mean(per[m])) for m in MODES], rule_before=True))
    tab.rows.append(Row("rms over objects", [float(np.sqrt(np.mean(np.square(per[m])))) for m in MODES]))
    for p in write_table(tab, Path(a.out), f"fresnel_rim_p{a.power:g}_erode{a.erode}"):
        print(p)


if __name__ == "__main__":
    main()
