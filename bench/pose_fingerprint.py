"""Behaviour fingerprint: the numbers a refactoring must not change, written to one .npz.

    python bench/pose_fingerprint.py --out before.npz          # record (about 1-3 min on 2 cores)
    python bench/pose_fingerprint.py --compare before.npz after.npz

What is recorded (all float64):

- the bundle refinement of ``bench/bench_refine.py``'s seed-1 scene (procedural, fast renderer,
  8 frames x 5 objects, 640x480 by default, the same initial deviation): every refined object-to-
  camera pose R (3, 3) and t (3,) mm per (frame, object), the solved cameras T_w2c and objects
  T_m2w, the scene-consistent initial poses and the per-pose sigmas and confidences;
- :func:`ycbvss.pipeline.perturb.perturb_poses` of the scene's exact poses (the demo's and
  validate's initial poses);
- :func:`ycbvss.eval.evaluate.evaluate_arrays` of the refined poses, with and without the
  symmetry-aware GT (the two cylinders declared continuously symmetric for this check): every
  error column and the overall scores.

``--compare A B`` prints the largest absolute difference per key group and overall, and exits 1
when the key sets differ or any difference exceeds ``--tol`` (default 1e-9), 0 otherwise.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_refine  # noqa: E402  (bench/ is not a package: the scene and init of its seed)


def _pose_key(prefix: str, key) -> str:
    return prefix + "/" + "_".join(str(int(k)) for k in (key if isinstance(key, tuple) else (key,)))


def _refine_arrays(ps, imgs, init) -> tuple[dict, dict]:
    from ycbvss.refine import RefineOptions, refine_scene

    res = refine_scene(ps.scene, ps.models, init, RefineOptions(), images=imgs)
    out: dict[str, np.ndarray] = {}
    for k, T in res.poses.items():
        out[_pose_key("refined_R", k)] = np.asarray(T, np.float64)[:3, :3]
        out[_pose_key("refined_t", k)] = np.asarray(T, np.float64)[:3, 3]
    for k, T in res.init_poses.items():
        out[_pose_key("init", k)] = np.asarray(T, np.float64)
    for k, T in res.T_w2c.items():
        out[_pose_key("camera_T_w2c", k)] = np.asarray(T, np.float64)
    for k, T in res.T_m2w.items():
        out[_pose_key("object_T_m2w", k)] = np.asarray(T, np.float64)
    for k, s in res.sigma.get("poses", {}).items():
        out[_pose_key("sigma", k)] = np.r_[np.asarray(s["sigma_t_mm"], np.float64), float(s["sigma_r_deg"])]
    for k, c in res.confidence.items():
        out[_pose_key("confidence", k)] = np.float64(c)
    out["converged"] = np.float64(res.converged)
    return out, res.poses


def _perturb_arrays(ps, gt) -> dict:
    from ycbvss.pipeline.perturb import perturb_poses

    Ks = {k: ps.frames[0].camera.K for k in gt}
    pts = {o: np.asarray(m.mesh.vertices, np.float64) for o, m in ps.models.items()}
    p = perturb_poses(gt, Ks, pts, seed=3)
    out = {_pose_key("perturb", k): np.asarray(T, np.float64) for k, T in p.poses.items()}
    out["perturb_means"] = np.array([p.add_mm, p.prj_px, p.depth_scale, p.lateral_scale])
    return out


def _eval_arrays(ps, gt, poses) -> dict:
    from ycbvss.eval.evaluate import EstArrays, EvalOptions, GtArrays, evaluate_arrays

    keys = sorted(gt)
    K = np.asarray(ps.frames[0].camera.K, np.float64)
    G = np.stack([gt[k] for k in keys])
    E = np.stack([np.asarray(poses[k], np.float64) for k in keys])
    ids = np.array([[1, k[0], k[1], 0] for k in keys], np.int64)
    g = GtArrays(ids[:, 0], ids[:, 1], ids[:, 2], ids[:, 3], G[:, :3, :3], G[:, :3, 3], np.stack([K] * len(keys)))
    e = EstArrays(ids[:, 0], ids[:, 1], ids[:, 2], np.ones(len(keys)), E[:, :3, :3], E[:, :3, 3])
    cyl = [{"axis": [0.0, 0.0, 1.0], "offset": [0.0, 0.0, 0.0]}]
    models = {o: (replace(m, symmetries_continuous=cyl) if o in (3, 4) else m) for o, m in ps.models.items()}
    out = {}
    for sym in (False, True):
        r = evaluate_arrays(g, e, models, EvalOptions(symmetric_obj_ids=(3,), use_symmetries=sym))
        for col, v in r.errors.items():
            out[f"eval_sym{int(sym)}/{col}"] = np.asarray(v, np.float64)
        out[f"eval_sym{int(sym)}/overall"] = np.array([r.summary[k] for k in sorted(r.summary)
                                                       if isinstance(r.summary[k], float)])
    return out


def record(out: Path, frames: int, width: int) -> None:
    os.environ.setdefault("YCBVSS_NO_PROGRESS", "1")
    t0 = time.perf_counter()
    ps, imgs, gt, init = bench_refine.make(1, frames, width, 40.0)
    arrays, refined = _refine_arrays(ps, imgs, init)
    arrays.update(_perturb_arrays(ps, gt))
    arrays.update(_eval_arrays(ps, gt, refined))
    np.savez(out, **arrays)
    print(f"{out}: {len(arrays)} arrays, {time.perf_counter() - t0:.1f} s")


def _group(key: str) -> str:
    return key.split("/", 1)[0]


def compare(a_path: Path, b_path: Path, tol: float) -> int:
    a, b = np.load(a_path), np.load(b_path)
    ka, kb = set(a.files), set(b.files)
    if ka != kb:
        print(f"key sets differ: only in A {sorted(ka - kb)[:10]}, only in B {sorted(kb - ka)[:10]}")
        return 1
    worst: dict[str, float] = {}
    for k in sorted(ka):
        x, y = a[k], b[k]
        if x.shape != y.shape:
            print(f"{k}: shapes differ {x.shape} vs {y.shape}")
            return 1
        same_nan = np.isnan(x) == np.isnan(y)
        d = np.where(np.isnan(x) & np.isnan(y), 0.0, np.abs(x - y))
        d = np.where(same_nan, d, np.inf)
        g = _group(k)
        worst[g] = max(worst.get(g, 0.0), float(d.max()) if d.size else 0.0)
    for g, d in sorted(worst.items()):
        print(f"{g:16s} max |A - B| = {d:.3e}")
    overall = max(worst.values())
    print(f"overall max |A - B| = {overall:.3e} over {len(ka)} arrays (tolerance {tol:g})")
    return 0 if overall <= tol else 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", type=Path, help="write the fingerprint here (.npz)")
    ap.add_argument("--compare", type=Path, nargs=2, metavar=("A", "B"))
    ap.add_argument("--tol", type=float, default=1e-9)
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--width", type=int, default=640)
    args = ap.parse_args()
    if args.compare:
        return compare(*args.compare, args.tol)
    if args.out is None:
        ap.error("give --out FILE or --compare A B")
    record(args.out, args.frames, args.width)
    return 0


if __name__ == "__main__":
    sys.exit(main())
