"""How exact are f_t's flow matches? The refiner's own image-to-image matching (local contrast
normalisation, Farneback flow forward and backward, reciprocal check, Shi-Tomasi corners on the
objects) between two Blender-rendered frames of a ``ycbv21`` suite scene, against the exact
correspondence of the same pixel (Blender's depth, the exact cameras).

Per frame separation (1 frame: about 0.3 degrees on the long path; 25 frames: the long clips'
keyframe spacing, about 7.5 degrees) and per start: matches kept, median true motion,
median error, the error along the true motion (mean, median; negative = the flow falls short),
the median ratio of matched to true motion, the share of matches more than 2 px wrong, and the
slope of the error along the motion against how much faster than the median point a point moves
(negative: the flow compresses the motion differences between near and far points, i.e. the
parallax that carries depth). Starts: ``zero`` (Farneback's default), ``predicted`` (Farneback
started from the motion the exact scene predicts), ``residual`` (Farneback between one image and
the other warped by that prediction, the prediction added back: ``refine.matching.residual_flow_pair``).

    python bench/bench_temporal_flow.py --dataset ../shared/data/ycbv --suite-root /tmp/suite \
        --scene 1 --out bench/results/ycbv21

The scene is rendered once into ``--suite-root`` (about 8 minutes for a long scene on 2 cores).
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

SEPARATIONS = (1, 3, 8, 25)
STARTS = ("zero", "predicted", "residual")


def _perturbed(T_w2c: np.ndarray, deg: float, mm: float) -> np.ndarray:
    """T_w2c turned by ``deg`` about the camera's y axis and moved by ``mm`` along its x axis."""
    a = np.radians(deg)
    P = np.eye(4)
    P[:3, :3] = [[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]]
    P[0, 3] = mm
    return P @ T_w2c


def pair_stats(fk, fi, models: dict, renderer, start: str, prior_deg: float = 0.3, prior_mm: float = 3.0) -> dict:
    """Match frame fk into frame fi as f_t does; compare with the exact correspondences. The
    predicted motion comes from the exact depth and a destination camera off by ``prior_deg`` /
    ``prior_mm`` (an estimate not yet converged: 5-8 px off at 640 px)."""
    from ycbvss.refine.flow_prior import predicted_flow, relative_motion
    from ycbvss.refine.matching import (FlowOptions, dense_flow_pair, flow_matches, min_eig_map, normalize_for_flow,
                                        residual_flow_pair)
    from ycbvss.refine.match_mask import match_mask
    from ycbvss.refine.templates import render_view

    opt = FlowOptions()
    ik, ii = fk.load_rgb(), fi.load_rgb()
    H, W = ik.shape[:2]

    def render(f):
        return render_view(renderer, models, [x.obj_id for x in f.instances], f.camera.K, W, H,
                           {j: x.T_m2c for j, x in enumerate(f.instances)})

    vk = render(fk)
    mask = np.zeros((H, W), bool)
    for j in vk.obj_index:
        mask |= match_mask(vk.mask(j), 6, 0)     # the fixed 6 px erosion this bench measured
    init_ab = init_ba = None
    if start in ("predicted", "residual"):
        vi = render(fi)
        Ti = _perturbed(fi.T_w2c, prior_deg, prior_mm)
        init_ab = predicted_flow(vk.depth_mm, fk.camera.K, fi.camera.K, relative_motion(fk.T_w2c, Ti))
        init_ba = predicted_flow(vi.depth_mm, fi.camera.K, fk.camera.K, relative_motion(Ti, fk.T_w2c))
    a, b = normalize_for_flow(ik), normalize_for_flow(ii)
    flows = (residual_flow_pair(a, b, opt, init_ab, init_ba) if start == "residual"
             else dense_flow_pair(a, b, opt, init_ab, init_ba))
    (xs, xd), = flow_matches(None, None, [mask], opt, flows=flows, corner_image=ik,
                             corner_me=min_eig_map(ik), dst_me=min_eig_map(ii))
    depth = fk.load_depth_mm()
    d = depth[xs[:, 1].round().astype(int), xs[:, 0].round().astype(int)] if len(xs) else np.zeros(0)
    ok = d > 0
    xs, xd, d = xs[ok], xd[ok], d[ok]
    if len(xs) == 0:
        return {"n": 0}
    X = np.linalg.inv(fk.camera.K) @ np.c_[xs, np.ones(len(xs))].T * d
    T = relative_motion(fk.T_w2c, fi.T_w2c)
    q = fi.camera.K @ (T[:3, :3] @ X + T[:3, 3:4])
    true = (q[:2] / q[2]).T - xs
    err = (xd - xs) - true
    tn = np.linalg.norm(true, axis=1)
    along = (err * true).sum(axis=1) / np.maximum(tn, 1e-9)
    dev = tn - np.median(tn)         # how much faster than the typical point this one moves (px)
    slope = float(np.linalg.lstsq(np.c_[dev, np.ones(len(dev))], along, rcond=None)[0][0]) if len(dev) > 2 else float("nan")
    return {"n": len(xs), "motion_px": float(np.median(tn)), "err_px": float(np.median(np.linalg.norm(err, axis=1))),
            "along_mean_px": float(along.mean()), "along_median_px": float(np.median(along)),
            "ratio": float(np.median(np.linalg.norm(xd - xs, axis=1)[tn > 1] / tn[tn > 1])) if np.any(tn > 1) else float("nan"),
            "wrong_2px": float(np.mean(np.linalg.norm(err, axis=1) > 2.0)), "compression": slope}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", required=True, type=Path, help="YCB-Video root (for the models)")
    ap.add_argument("--suite-root", required=True, type=Path, help="where the suite scene is (or will be) rendered")
    ap.add_argument("--scene", type=int, default=1, help="a long suite scene (1-3)")
    ap.add_argument("--starts", default="0,50,100,150", help="first frames of the pairs")
    ap.add_argument("--prior-deg", type=float, default=0.3, help="error of the predicting camera: turn (deg)")
    ap.add_argument("--prior-mm", type=float, default=3.0, help="... and shift (mm)")
    ap.add_argument("--out", type=Path, default=None, help="write temporal_flow.{md,csv,tex} here")
    a = ap.parse_args()

    from ycbvss.eval.tables import Row, Table, to_markdown, write_table
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import build_suite
    from ycbvss.progress import progress
    from ycbvss.refine.templates import ensure_meshes, get_renderer

    models, _ = build_suite(a.dataset, a.suite_root, scene_ids=[a.scene])
    scene = load_bop_scene(a.suite_root / "test", a.scene, models)
    frames = {f.im_id: f for f in scene.frames}
    renderer = get_renderer()
    ensure_meshes(renderer, models)
    firsts = [int(x) for x in a.starts.split(",")]
    t = Table(columns=["matches", "motion px", "error px", "along mean px", "along median px", "ratio", "> 2 px",
                       "slope px/px"],
              label_header="separation, start", digits=3,
              caption=f"f_t flow matches against the exact correspondences, suite scene {a.scene}, "
                      f"pairs from frames {a.starts} (per pair, then the mean); predictions from a camera "
                      f"{a.prior_deg:g} deg / {a.prior_mm:g} mm off")
    jobs = [(s, st) for s in SEPARATIONS for st in STARTS]
    bar = progress(total=len(jobs) * len(firsts), desc="flow pairs", unit="pair")
    for sep, start in jobs:
        res = []
        for k in firsts:
            if k in frames and k + sep in frames:
                res.append(pair_stats(frames[k], frames[k + sep], models, renderer, start, a.prior_deg, a.prior_mm))
            bar.update(1)
        res = [r for r in res if r["n"]]
        if not res:
            continue
        keys = ["n", "motion_px", "err_px", "along_mean_px", "along_median_px", "ratio", "wrong_2px", "compression"]
        t.rows.append(Row(f"{sep} frames, {start}", [float(np.mean([r[k] for r in res])) for k in keys]))
    bar.close()
    print(to_markdown(t))
    if a.out is not None:
        print(write_table(t, a.out, "temporal_flow"))


if __name__ == "__main__":
    main()
