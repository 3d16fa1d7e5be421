"""How well the static table measures the cameras' relative rotations (refine.table.table_rotation),
against the exact GT of the validation suite's Blender images.

    python bench/bench_table_rotation.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \\
        --scenes 1-9 --kind medium --step 4 --out bench/results/ycbv21/table_rotation

For each pair of consecutive keyframes (every ``--step``-th frame of the clip) the table's corners
are matched clear of the objects (GT masks), the homography's rotation measured from a start 0.4 deg
off, and compared with the GT relative rotation: error (deg), the covariance's predicted sigma, and
chi-square (3 dof; mean 3 if the covariance is honest). Writes Markdown, CSV and LaTeX.

``--guided``: match as the refiner does with a support plane, warped by the table plane's homography
predicted from an estimate that is off (rotation 0.4 deg as above, translation 2 %, the plane's
distance 3 %). ``--span DEG``: measure the long-range pairs of ``refine.table.span_pairs`` instead
(each keyframe with the earliest keyframe within DEG of it), with the pair's turn in the table.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from ycbvss.eval.tables import Row, Table, write_table
from ycbvss.geometry.so3 import exp_so3, log_so3
from ycbvss.io.bop import load_bop_scene
from ycbvss.io.ycbv import parse_videos
from ycbvss.pipeline.suite import SUITES, clip_scene, clips_of, suite_models
from ycbvss.refine.table import span_pairs, table_matches, table_rotation


def _objects_mask(root: Path, sid: int, f) -> np.ndarray:
    """Union of the frame's GT object masks (BOP ``mask/``)."""
    masks = [cv2.imread(str(root / "test" / f"{sid:06d}" / "mask" / f"{f.im_id:06d}_{j:06d}.png"), 0) > 0
             for j in range(len(f.instances))]
    return np.logical_or.reduce(masks)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--suite-root", type=Path, required=True)
    ap.add_argument("--dataset", type=Path, required=True, help="YCB-V root with the models (../shared/data/ycbv)")
    ap.add_argument("--scenes", default="1-9")
    ap.add_argument("--kind", default="medium", choices=("short", "medium", "long"))
    ap.add_argument("--step", type=int, default=4, help="keyframe step within the clip")
    ap.add_argument("--guided", action="store_true", help="match guided by a predicted homography (the refiner's way)")
    ap.add_argument("--span", type=float, default=0.0, help="measure span pairs up to this turn (deg) instead")
    ap.add_argument("--name", default=None, help="output file stem (default table_rotation_<kind>)")
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    rows, all_err, all_chi = [], [], []
    for sid in parse_videos(a.scenes, "scene list"):
        spec = next(s for s in SUITES["ycbv21"] if s.scene_id == sid)
        clips = clips_of(spec, (a.kind,))
        if not clips:
            continue
        models = suite_models(a.dataset, a.suite_root, list(spec.obj_ids))
        scene = load_bop_scene(a.suite_root / "test", sid, models)
        frames = sorted(clip_scene(scene, clips[0]).frames, key=lambda f: f.im_id)[::a.step]
        err, sd, chi, inl, med, turn = [], [], [], [], [], []
        seq = list(zip(range(len(frames) - 1), range(1, len(frames))))
        if a.span > 0:
            seq = span_pairs(np.stack([f.T_w2c[:3, :3] for f in frames]), seq, a.span)
        for ia, ib in seq:
            fa, fb = frames[ia], frames[ib]
            R_true = fb.T_w2c[:3, :3] @ fa.T_w2c[:3, :3].T
            guess = exp_so3(np.radians([0.25, -0.2, 0.2])) @ R_true
            n_a = fa.T_w2c[:3, :3] @ [0, 0, 1.0]          # the suite's table is the world's z = 0 plane
            H_pred = None
            if a.guided:
                d_a = float(n_a @ fa.T_w2c[:3, 3])
                t_ab = fb.T_w2c[:3, 3] - R_true @ fa.T_w2c[:3, 3]
                Hn = guess + np.outer(1.02 * t_ab, n_a) / (1.03 * d_a)
                H_pred = fb.camera.K @ Hn @ np.linalg.inv(fa.camera.K)
            xs, xd = table_matches(fa.load_rgb(), fb.load_rgb(), _objects_mask(a.suite_root, sid, fa),
                                   _objects_mask(a.suite_root, sid, fb), 1000, H_pred=H_pred)
            m = table_rotation(xs, xd, fa.camera.K, fb.camera.K, guess, n_a)
            if m is None:
                print(f"{a.kind}-{sid} {fa.im_id}->{fb.im_id}: no plane ({len(xs)} matches)")
                continue
            R, cov, n, md = m
            e = log_so3(R @ R_true.T)
            err.append(np.degrees(np.linalg.norm(e)))
            sd.append(np.degrees(np.sqrt(np.trace(cov))))
            chi.append(float(e @ np.linalg.solve(cov, e)))
            inl.append(n)
            med.append(md)
            turn.append(float(np.degrees(np.linalg.norm(log_so3(R_true)))))
        if not err:
            continue
        all_err += err
        all_chi += chi
        rows.append(Row(f"{a.kind}-{sid}", [len(err), float(np.mean(turn)), float(np.mean(inl)), float(np.mean(med)), float(np.mean(err)),
                                            float(np.max(err)), float(np.mean(sd)), float(np.mean(chi))]))
        print(f"{a.kind}-{sid}: pairs {len(err)}, error mean {np.mean(err):.4f} max {np.max(err):.4f} deg, "
              f"sigma {np.mean(sd):.4f}, chi2 {np.mean(chi):.2f}")
    rows.append(Row("all", [len(all_err), None, None, None, float(np.mean(all_err)), float(np.max(all_err)), None,
                            float(np.mean(all_chi))], rule_before=True))
    t = Table(["pairs", "turn mean (deg)", "inliers", "median residual (px)", "error mean (deg)", "error max (deg)",
               "predicted sigma (deg)", "chi2 (3 dof)"], label_header="clip", digits=4,
              caption=f"Relative camera rotation measured from the table's homography ({a.kind} clips, "
                      f"keyframe step {a.step}, {'span pairs within %g deg' % a.span if a.span > 0 else 'consecutive pairs'}, "
                      f"{'guided' if a.guided else 'unguided'} matching) against the exact GT")
    t.rows = rows
    write_table(t, a.out, a.name or f"table_rotation_{a.kind}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
