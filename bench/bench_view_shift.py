"""Per frame of a refined suite clip: the two per-view checks of the status against the true errors.

Refines one suite clip from one initialisation (any ``RefineOptions`` given as JSON) and writes,
per frame, the view's median contour offset (``stats["view_contour_px"]``, the +-3 px check), its
median 2-D template shift (``stats["view_shift_px"]``, :mod:`ycbvss.refine.view_shift`), the
frame's poses' PRJ error (median and max, px) and translation error (max, mm) against the GT, and
the statuses: a Markdown / CSV / LaTeX table of the frames with a pose > 2 mm or a flagged view,
and a PNG of both checks and the median PRJ over the frames.

    python bench/bench_view_shift.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --clip long-1 --init add60 --seed 0 --options '{"coarse_iters": 4}' \
        --save /tmp/long1_add60_ci4.pkl --out bench/results/ycbv21/s74/view_shift_long1_add60_ci4

``--load PKL`` re-reports a result saved with ``--save`` (no refinement).
"""
from __future__ import annotations

import argparse
import json
import os
import pickle
from pathlib import Path

import numpy as np


def refine_clip(dataset: str, root: str, clip_name: str, init_mode: str, seed: int, options: dict) -> dict:
    """Refine a suite clip as ``bench/suite_runs.py`` does (:func:`ycbvss.pipeline.suite_run.refine_run`);
    returns the result's poses, statuses, reasons and stats with the clip's GT and initial poses."""
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import build_suite, clips_of
    from ycbvss.pipeline.suite_run import Run, refine_run

    models, specs = build_suite(dataset, root, "ycbv21", scene_ids=[int(clip_name.rsplit("-", 1)[1])], quiet=True)
    clip = next(c for sp in specs for c in clips_of(sp) if c.name == clip_name)
    scene = load_bop_scene(Path(root) / "test", clip.scene_id, models)
    res, _, gt, init, _, dt = refine_run(Run(clip, init_mode, seed), scene, models, options)
    print(f"refined in {dt:.0f} s")
    return {"poses": res.poses, "status": res.status, "reasons": res.reasons, "stats": res.stats, "gt": gt,
            "init": init}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--clip", default="long-1")
    ap.add_argument("--init", default="add60")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--options", default="{}", help="RefineOptions fields as a JSON object")
    ap.add_argument("--save", help="pickle the result here")
    ap.add_argument("--load", help="re-report a result saved with --save")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    os.environ.setdefault("YCBVSS_NO_PROGRESS", "1")
    from ycbvss.eval.metrics import pose_errors_4x4
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.pipeline.suite import load_clip
    from ycbvss.refine.confidence import OK_PX, VIEW_SHIFT_PX

    if a.load:
        with open(a.load, "rb") as fh:
            d = pickle.load(fh)
    else:
        d = refine_clip(a.dataset, a.suite_root, a.clip, a.init, a.seed, json.loads(a.options))
        if a.save:
            with open(a.save, "wb") as fh:
                pickle.dump(d, fh)
    models, sc = load_clip(a.dataset, a.suite_root, a.clip, quiet=True)
    frames = sorted(f.im_id for f in sc.frames)
    K = {f.im_id: f.camera.K for f in sc.frames}
    gt, poses, st = d["gt"], d["poses"], d["status"]
    vc = np.asarray(d["stats"]["view_contour_px"], float)
    vs = np.asarray(d["stats"].get("view_shift_px", [np.nan] * len(frames)), float)
    per = []
    for n, im in enumerate(frames):
        keys = [k for k in gt if k[0] == im and k in poses]
        prj, t_mm = [], []
        for k in keys:
            prj.append(pose_errors_4x4(poses[k], gt[k], K[im], models[k[1]].vertices_mm[::20])["prj_px"])
            t_mm.append(float(np.linalg.norm(poses[k][:3, 3] - gt[k][:3, 3])))
        sts = [st.get(k, "failed") for k in keys]
        per.append((im, vc[n], vs[n], float(np.median(prj)), float(np.max(prj)), float(np.max(t_mm)),
                    sum(s == "converged" for s in sts), sum(s == "converged" and t > 2.0 for s, t in zip(sts, t_mm)),
                    len(keys)))
    rows = [Row(f"frame {p[0]}", list(p[1:])) for p in per if p[5] > 2.0 or p[1] > OK_PX or p[2] > VIEW_SHIFT_PX]
    allp = np.array([p[1:] for p in per], float)
    rows.append(Row(f"all {len(per)} frames", [float(np.nanmedian(allp[:, 0])), float(np.nanmedian(allp[:, 1])),
                                               float(np.median(allp[:, 2])), float(np.max(allp[:, 3])),
                                               float(np.max(allp[:, 4])), int(allp[:, 5].sum()), int(allp[:, 6].sum()),
                                               int(allp[:, 7].sum())], rule_before=True))
    t = Table(caption=f"{a.clip} from {a.init}, seed {a.seed}, options {a.options}: per frame (frames with a pose > 2 mm "
                      f"or a flagged view; last row: medians / maxima / sums over all frames) the view's median contour "
                      f"offset (> {OK_PX:g} px: uncertain), its median 2-D template shift (> {VIEW_SHIFT_PX:g} px: "
                      f"uncertain), the poses' PRJ (px) and translation error (mm) against the GT, and how many are "
                      f"converged",
              label_header="frame",
              columns=["view contour (px)", "view shift (px)", "PRJ median (px)", "PRJ max (px)", "t max (mm)",
                       "converged", "converged > 2 mm", "poses"], rows=rows, digits=2)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for p in write_table(t, out, "view_shift"):
        print(p)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 3.6))
    x = np.array([p[0] for p in per])
    ax.semilogy(x, np.maximum(allp[:, 2], 1e-2), "k.", ms=3, label="PRJ median of the frame's poses (px)")
    ax.semilogy(x, np.maximum(allp[:, 0], 1e-2), "-", color="tab:blue", lw=1, label="view contour offset (px)")
    ax.semilogy(x, np.maximum(allp[:, 1], 1e-2), "-", color="tab:red", lw=1, label="view 2-D template shift (px)")
    ax.axhline(OK_PX, color="tab:blue", ls=":", lw=1)
    ax.axhline(VIEW_SHIFT_PX, color="tab:red", ls=":", lw=1)
    ax.set_xlabel("frame")
    ax.set_ylim(1e-2, 200)
    ax.set_title(f"{a.clip} from {a.init}, seed {a.seed}: the per-view checks (dotted: their bounds)", fontsize=9)
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(out / "view_shift.png", dpi=120)
    print(out / "view_shift.png")


if __name__ == "__main__":
    main()
