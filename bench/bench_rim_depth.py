"""How far in front of the rim the exterior-contour samples are lifted, with and without the
chord-midpoint rim depth (``ycbvss.refine.edge.rim_depth``).

For each object: 3 random poses at 0.8-1.1 m (YCB-V camera, 640x480), up to 150 contour samples per
pose; the reference rim depth along each sample's ray is where the ray passes closest to the
surface (the surface densely sampled, 800k points, KD-tree; the ray marched in 0.25 mm steps).

    python bench/bench_rim_depth.py --models /tmp/suite/full/models --objs 10 18 2 5 1 13 19 14
"""
from __future__ import annotations

import argparse

import numpy as np


def main() -> None:
    import trimesh
    from scipy.spatial import cKDTree
    from scipy.spatial.transform import Rotation

    from ycbvss.io.bop import load_models
    from ycbvss.refine.edge import all_contour_points
    from ycbvss.refine.jacobians import backproject_px
    from ycbvss.refine.templates import ensure_meshes, get_renderer, render_view

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", required=True, help="BOP models folder (mm)")
    ap.add_argument("--objs", type=int, nargs="+", default=[10, 18, 2, 5, 1, 13, 19, 14])
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    K = np.array([[1066.778, 0, 312.987], [0, 1067.487, 241.311], [0, 0, 1]])
    models = load_models(a.models)
    r = get_renderer()
    ensure_meshes(r, {o: models[o] for o in a.objs})
    rng = np.random.default_rng(a.seed)
    s = np.arange(-25.0, 25.01, 0.25)
    print("| obj | front depth: rim - lifted (mm) mean / median / p90 | chord midpoint - rim (mm) median / MAD |")
    print("|---|---|---|")
    for oid in a.objs:
        mesh = models[oid].mesh
        tree = cKDTree(trimesh.sample.sample_surface(mesh, 800000, seed=1)[0])
        gaps, mids = [], []
        for _ in range(3):
            T = np.eye(4)
            T[:3, :3] = Rotation.random(random_state=int(rng.integers(1 << 31))).as_matrix()
            T[:3, 3] = [rng.uniform(-80, 80), rng.uniform(-60, 60), rng.uniform(800, 1100)]
            T[:3, 3] -= T[:3, :3] @ mesh.bounding_box.centroid
            vr = render_view(r, models, [oid], K, 640, 480, {0: T}, back=True)
            uv, z_front, _ = all_contour_points(vr.instance, vr.depth_mm)
            _, z_rim_est, _ = all_contour_points(vr.instance, vr.depth_mm, vr.back_depth_mm, vr.back_instance)
            sel = rng.choice(len(uv), min(150, len(uv)), replace=False)
            uv, z_front, z_rim_est = uv[sel], z_front[sel], z_rim_est[sel]
            P = backproject_px(K, uv, z_front)
            ray = P / np.linalg.norm(P, axis=1, keepdims=True)
            pts = P[:, None, :] + s[None, :, None] * ray[:, None, :]
            Ti = np.linalg.inv(T)
            dist = tree.query(pts.reshape(-1, 3) @ Ti[:3, :3].T + Ti[:3, 3])[0].reshape(len(uv), len(s))
            for k in range(len(uv)):
                idx = np.flatnonzero(dist[k] <= dist[k].min() + 0.02)
                z_rim = z_front[k] + 0.5 * (s[idx[0]] + s[idx[-1]]) * ray[k, 2]
                gaps.append(z_rim - z_front[k])
                mids.append(z_rim_est[k] - z_rim)
        g, m = np.array(gaps), np.array(mids)
        print(f"| {oid} {models[oid].name} | {g.mean():.2f} / {np.median(g):.2f} / {np.percentile(g, 90):.2f} "
              f"| {np.median(m):.2f} / {np.median(np.abs(m - np.median(m))):.2f} |", flush=True)


if __name__ == "__main__":
    main()
