"""Is the suite's GT the pose Blender rendered? Per (view, object) at the exact GT: the rigid
motion (point-to-plane, linearised, one trimmed refit) that takes the fast renderer's surface to
the Cycles depth pass over the object's interior (its silhouette eroded by 3 px, depth within
5 mm). Zero means the rendered pose is the GT; a rotation here would be a GT error that every
image term of the refiner would share.

    python bench/bench_gt_depth.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \
        --scenes 1 --frames 0,30,60,90,120,150,180 --out bench/results/ycbv21/template_shading
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def rigid_fit(pc: np.ndarray, pf: np.ndarray, n: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Small motion (omega rad (3,), v mm (3,)) about ``centre`` minimising
    sum (n . (pc - (pf + omega x (pf - centre) + v)))^2, refitted once without residuals above
    3 x their median absolute value. pc, pf, n: (N, 3) camera-frame points and unit normals."""
    r = np.sum(n * (pc - pf), axis=1)
    A = np.concatenate([np.cross(pf - centre, n), n], axis=1)
    sol = np.linalg.lstsq(A, r, rcond=None)[0]
    res = r - A @ sol
    keep = np.abs(res) <= 3.0 * np.median(np.abs(res)) + 0.05
    return np.linalg.lstsq(A[keep], r[keep], rcond=None)[0]


def main() -> None:
    import cv2
    from bench_contour_offsets import add_view_args, gt_views   # this folder (run as a script)

    from ycbvss.eval.tables import Row, Table, write_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_args(ap)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    per: dict = {}
    models: dict = {}
    for models, _, fr, _, vr, oids in gt_views(a):
        D = fr.load_depth_mm().astype(np.float64)
        K = fr.camera.K
        vv, uu = np.mgrid[0:D.shape[0], 0:D.shape[1]]
        for j, oid in enumerate(oids):
            m = cv2.erode(vr.mask(j).astype(np.uint8), np.ones((7, 7), np.uint8)).astype(bool)
            df = vr.depth_mm.astype(np.float64)
            ok = m & (D > 0) & (np.abs(D - df) < 5.0)
            if ok.sum() < 100:
                continue
            x = np.stack([(uu[ok] - K[0, 2]) / K[0, 0], (vv[ok] - K[1, 2]) / K[1, 1], np.ones(int(ok.sum()))], axis=1)
            n = vr.normal[ok].astype(np.float64)
            n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-12
            sol = rigid_fit(x * D[ok][:, None], x * df[ok][:, None], n, fr.instances[j].T_m2c[:3, 3])
            per.setdefault(oid, []).append((float(np.degrees(np.linalg.norm(sol[:3]))), float(np.linalg.norm(sol[3:]))))
    t = Table(["(view)s", "rotation mean (deg)", "rotation max (deg)", "translation mean (mm)", "translation max (mm)"],
              label_header="object", digits=4,
              caption=f"Rigid motion from the fast renderer's surface at the GT to the Cycles depth pass, per (view, object); "
                      f"scenes {a.scenes}, frame positions {a.frames}")
    for o, v in sorted(per.items()):
        x = np.array(v)
        t.rows.append(Row(getattr(models[o], "name", None) or str(o),
                          [float(len(x)), float(x[:, 0].mean()), float(x[:, 0].max()), float(x[:, 1].mean()), float(x[:, 1].max())]))
        print(f"{o:3d} n {len(x)} rot {x[:, 0].mean():.4f} (max {x[:, 0].max():.4f}) deg, t {x[:, 1].mean():.4f} (max {x[:, 1].max():.4f}) mm")
    for p in write_table(t, Path(a.out), "gt_depth"):
        print(p)


if __name__ == "__main__":
    main()
