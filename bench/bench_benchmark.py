"""Speed of benchmark scoring at the size of the paper's BCOT part (about 150k frame poses).

Synthetic BCOT-like data: 404 single-object sequences (about 370 frames each) of 20 bodies, the
bcot protocol (lengths 25/50/100/200, steps 1-4, coverage 1) -> about 150k scored (frame, object)
pairs; one tracker with tracker-level errors (t ~ N(0, 10 mm) per axis, tz x2, R ~ 3 deg; 5 % of
the frames lost = missing). Models: the full-resolution YCB-V meshes of ../shared/data (8k
vertices each) when present, else 8k-point synthetic surfaces.

Measured:
1. ``score_benchmark`` (GT index + ADD/PRJ/R/t + scores + per-length scores), in memory;
2. the whole ``ycbvss benchmark score`` path: read 1466-ish results CSVs, score, write the ranking
   tables, scores.json, curves.png and the per-frame errors CSV;
3. ADD-S for every object (``--adds-all``) on a subset, extrapolated (what the protocol avoids);
4. identity with the brute-force reference (``ycbvss.eval.reference.errors_loop``, one KD-tree per
   pose as bop_toolkit) on a random subset: max relative difference of ADD, ADD-S, PRJ and R.

    python bench/bench_benchmark.py [--pairs-per-seq 370] [--ref-n 300] [--symmetric 13] [--no-grid]
"""
from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from ycbvss.eval.benchmark import ProtocolOptions, make_protocol, score_benchmark, write_report, write_results
from ycbvss.eval.benchmark.results import read_result_dir
from ycbvss.eval.benchmark.score import PointCache, gt_index, score_tracker
from ycbvss.eval.benchmark.sources import Sequence
from ycbvss.eval.reference import errors_loop
from ycbvss.geometry.so3 import exp_so3

K = np.array([[1046.0, 0.0, 643.0], [0.0, 1045.0, 363.0], [0.0, 0.0, 1.0]])
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "ycbv"


def models_20(rng) -> dict:
    if SHARED.is_dir():
        from ycbvss.io.ycbv import load_ycbv_models
        m = load_ycbv_models(SHARED)
        pts = {i + 1: m[o].vertices_mm for i, o in enumerate(sorted(m)[:20])}
        src = "YCB-V textured.obj meshes (full resolution)"
    else:
        pts = {}
        for o in range(1, 21):
            v = rng.normal(size=(8000, 3))
            pts[o] = v / np.linalg.norm(v, axis=1, keepdims=True) * rng.uniform(30, 110, 3)
        src = "synthetic ellipsoids (8000 points)"
    return {o: SimpleNamespace(vertices_mm=p, label=f"body{o}", obj_id=o) for o, p in pts.items()}, src


def sequences(rng, n_seq: int, n_frames: int) -> list[Sequence]:
    out = []
    for s in range(n_seq):
        o = 1 + s % 20
        w = rng.normal(size=3)
        w *= np.radians(2.0) / np.linalg.norm(w)
        R0 = exp_so3(rng.normal(size=3))
        gt, Ks = {}, {}
        for k in range(n_frames):
            T = np.eye(4)
            T[:3, :3] = exp_so3(w * k) @ R0
            T[:3, 3] = [60 * np.sin(0.05 * k), 40 * np.sin(0.03 * k), 700 + 150 * np.sin(0.02 * k)]
            gt[k] = {o: T}
            Ks[k] = K
        out.append(Sequence(s, f"scene{s // 20}/body{o}", list(range(n_frames)), Ks, gt))
    return out


def tracker_results(rng, cfg, seqs) -> dict:
    by = {s.scene_id: s for s in seqs}
    res = {}
    for s in cfg["subsequences"]:
        rows = {}
        for im in s["frames"][1:]:
            if rng.random() < 0.05:
                continue
            for o in s["objects"]:
                T = by[s["scene_id"]].gt[im][o]
                R = exp_so3(rng.normal(size=3) * np.radians(3.0)) @ T[:3, :3]
                t = T[:3, 3] + rng.normal(size=3) * [10, 10, 20]
                rows[(im, o)] = (R, t, 0.01)
        res[int(s["id"])] = rows
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sequences", type=int, default=404)
    ap.add_argument("--pairs-per-seq", type=int, default=370)
    ap.add_argument("--ref-n", type=int, default=300)
    ap.add_argument("--adds-n", type=int, default=3000)
    ap.add_argument("--no-grid", action="store_true", help="ADD-S without the exact voxel grid (KD-tree kernel only)")
    ap.add_argument("--symmetric", type=int, nargs="*", default=[],
                    help="obj_ids scored with ADD-S (13 = the bowl's mesh: 1/20 of the poses, as YCB-V's bowl)")
    args = ap.parse_args()
    os.environ.setdefault("YCBVSS_NO_PROGRESS", "1")
    if args.no_grid:
        from ycbvss.eval import model_points
        model_points.GRID_MIN_QUERIES = 1 << 62
    rng = np.random.default_rng(0)
    models, src = models_20(rng)
    seqs = sequences(rng, args.sequences, args.pairs_per_seq)
    cfg = make_protocol(seqs, {"name": "bcot-like", "layout": "bcot", "root": ""}, ProtocolOptions("bcot", seed=0),
                        models)
    res = tracker_results(rng, cfg, seqs)
    print(f"models: {src}; {len(cfg['subsequences'])} subsequences")
    # warm-up (numba kernels from the on-disk cache)
    gti0 = gt_index({**cfg, "subsequences": cfg["subsequences"][:3]}, seqs)
    score_tracker("w", gti0, res, PointCache(models))

    t0, c0 = time.perf_counter(), time.process_time()
    sym = tuple(args.symmetric)
    gti, scores = score_benchmark(cfg, seqs, models, {"tracker": res}, symmetric_obj_ids=sym)
    t1, c1 = time.perf_counter(), time.process_time()
    n = len(gti)
    print(f"1. score_benchmark (ADD-S for {list(sym) or 'no object'}): {n} frame poses in {t1 - t0:.2f} s wall / {c1 - c0:.2f} s CPU "
          f"({1e6 * (t1 - t0) / n:.1f} us per pose); ADD-PRJ-AUC {scores[0].overall['add_prj_auc']:.2f}")

    with tempfile.TemporaryDirectory() as td:
        d = Path(td) / "res"
        for sid, rows in res.items():
            write_results(d, sid, [(im, o, np.r_[np.c_[R, t], [[0, 0, 0, 1]]], dt) for (im, o), (R, t, dt) in rows.items()])
        t0 = time.perf_counter()
        loaded, _ = read_result_dir(d, cfg)
        t_read = time.perf_counter() - t0
        gti2, sc2 = score_benchmark(cfg, seqs, models, {"tracker": loaded}, symmetric_obj_ids=sym)
        t_score = time.perf_counter() - t0 - t_read
        write_report(sc2, gti2, cfg, Path(td) / "out", {o: m.label for o, m in models.items()}, {})
        t_all = time.perf_counter() - t0
        same = all(np.allclose(sc2[0].errors[k], scores[0].errors[k], rtol=1e-9, atol=0, equal_nan=True)
                   for k in ("add_mm", "prj_px"))
        print(f"2. benchmark score from files: read {len(loaded)} CSVs {t_read:.2f} s + score {t_score:.2f} s + "
              f"report {t_all - t_read - t_score:.2f} s = {t_all:.2f} s wall (errors equal to the in-memory "
              f"run within 1e-9 relative: {same})")

    have = np.flatnonzero(np.isfinite(scores[0].errors["add_mm"]))
    sub = rng.choice(have, size=min(args.adds_n, len(have)), replace=False)
    from ycbvss.eval.metrics import pose_errors
    from ycbvss.eval.model_points import ModelPoints
    from ycbvss.eval.benchmark.score import estimate_arrays
    _, Re, te = estimate_arrays(gti, res)
    mp = {o: ModelPoints(m.vertices_mm) for o, m in models.items()}
    t0 = time.perf_counter()
    for o in np.unique(gti.obj_id[sub]):
        i = sub[gti.obj_id[sub] == o]
        pose_errors(Re[i], te[i], gti.R[i], gti.t[i], gti.K[i], mp[o], with_adds=True)
    t_adds = time.perf_counter() - t0
    print(f"3. ADD-S for every object (--adds-all): {1e3 * t_adds / len(sub):.2f} ms per pose -> "
          f"{t_adds / len(sub) * n:.0f} s for {n} (the protocol computes ADD-S for the symmetric set only)")

    ref = rng.choice(have, size=min(args.ref_n, len(have)), replace=False)
    worst = 0.0
    t0 = time.perf_counter()
    for i in ref:
        o = int(gti.obj_id[i])
        e = errors_loop(Re[i:i + 1], te[i:i + 1], gti.R[i:i + 1], gti.t[i:i + 1], gti.K[i:i + 1], models[o].vertices_mm)
        ours = pose_errors(Re[i:i + 1], te[i:i + 1], gti.R[i:i + 1], gti.t[i:i + 1], gti.K[i:i + 1], mp[o],
                           with_adds=True)
        for k in ("add_mm", "prj_px", "r_deg"):
            a, b = float(np.ravel(e[k])[0]), float(scores[0].errors[k][i])
            worst = max(worst, abs(a - b) / max(abs(a), 1e-12))
        if o in sym:
            a, b = float(np.ravel(e["adds_mm"])[0]), float(scores[0].errors["add_s_mm"][i])
            worst = max(worst, abs(a - b) / max(abs(a), 1e-12))
        a, b = float(np.ravel(e["adds_mm"])[0]), float(ours["adds_mm"][0])
        worst = max(worst, abs(a - b) / max(abs(a), 1e-12))
    t_ref = time.perf_counter() - t0
    print(f"4. brute-force reference on {len(ref)} poses: max relative difference {worst:.2e} (limit 1e-9); "
          f"reference {1e3 * t_ref / len(ref):.1f} ms per pose -> {t_ref / len(ref) * n:.0f} s for {n}")
    print(f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6:.2f} GB; load average "
          f"{os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
