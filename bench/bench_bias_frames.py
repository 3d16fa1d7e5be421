"""What a refinement started from the exact GT leaves, on a few frames of a suite scene, per option set:
with the cameras held at the GT (each object's depth then triangulated across the views) and with free
cameras (the scene's scale then set by the objects' apparent sizes alone).

A quick probe of a cost change (about 15-30 s per run on 2 cores for 8 frames of a 7-object scene)
before the suite's long runs: per object the rotation R (deg; for objects scored with ADD-S and a
continuous symmetry, the bowl, the angle of its axis only, as the suite scores it) and the signed
depth error tz (mm), both means over the frames; per run their means over objects, mean abs(tz) and
the signed mean tz (a scene scale shows as every object off the same way).

    python bench/bench_bias_frames.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \\
        --scene 3 --options '{}' --options '{"edge_appearance_model": "synthetic"}' --out /tmp/bias_frames
"""
from __future__ import annotations

import argparse
import copy
import json
import warnings
from pathlib import Path

import numpy as np


def refine_from_gt(scene, models: dict, opts: dict, fixed: bool) -> dict:
    """{(im_id, obj_id): refined pose (4, 4)} of ``scene`` refined from its GT (seed 0 unless set)."""
    from ycbvss.refine.bundle import RefineOptions, refine_scene

    gt = {(f.im_id, i.obj_id): i.T_m2c for f in scene.frames for i in f.instances}
    res = refine_scene(scene, models, dict(gt), RefineOptions(**{"seed": 0, "fix_cameras": fixed, **opts}))
    return res.poses


def object_errors(scene, models: dict, poses: dict) -> dict:
    """{obj_id: (mean R deg, mean signed tz mm)} of ``poses`` against the scene's GT."""
    from ycbvss.eval.metrics import re_deg
    from ycbvss.pipeline.suite_run import _bowl_free_rotation_deg

    gt = {(f.im_id, i.obj_id): i.T_m2c for f in scene.frames for i in f.instances}
    out = {}
    for oid in sorted({k[1] for k in gt}):
        ks = [k for k in gt if k[1] == oid and k in poses]
        if not ks:
            continue
        m = models[oid]
        axis = (np.asarray(m.symmetries_continuous[0]["axis"], float)
                if m.symmetric and m.symmetries_continuous else None)
        r = [_bowl_free_rotation_deg(poses[k][:3, :3], gt[k][:3, :3], axis) if axis is not None else
             float(re_deg(poses[k][:3, :3], gt[k][:3, :3])) for k in ks]
        out[oid] = (float(np.mean(r)), float(np.mean([poses[k][2, 3] - gt[k][2, 3] for k in ks])))
    return out


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import SUITES, suite_models
    from ycbvss.progress import progress

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", required=True, help="YCB-Video root (or BOP root) with the 21 models")
    ap.add_argument("--suite-root", required=True, type=Path, help="a rendered suite (BOP: models/, test/)")
    ap.add_argument("--suite", default="ycbv21")
    ap.add_argument("--scene", type=int, required=True)
    ap.add_argument("--frames", default="0,25,50,75,100,125,150,175", help="frame ids of the scene")
    ap.add_argument("--cameras", default="fixed,free",
                    help="comma-separated: fixed (held at the GT), free, or both as the default")
    ap.add_argument("--options", action="append", default=None,
                    help="RefineOptions overrides, a JSON object; repeat for more runs (default: one run, {})")
    ap.add_argument("--out", required=True, type=Path)
    a = ap.parse_args()
    modes = a.cameras.split(",")
    if any(c not in ("fixed", "free") for c in modes):
        ap.error(f"--cameras takes fixed, free or fixed,free; got {a.cameras!r}")
    warnings.simplefilter("ignore")
    spec = next(s for s in SUITES[a.suite] if s.scene_id == a.scene)
    models = suite_models(a.dataset, a.out / "models_src", spec.obj_ids)
    full = load_bop_scene(a.suite_root / "test", a.scene, models)
    keep = {int(x) for x in a.frames.split(",")}
    scene = copy.copy(full)
    scene.frames = [f for f in full.frames if f.im_id in keep]
    opt_sets = [json.loads(o) for o in (a.options or ["{}"])]
    oids = list(spec.obj_ids)
    names = [getattr(models[o], "name", None) or str(o) for o in oids]
    cols = ["R (deg)", "abs tz (mm)", "mean tz (mm)"] + [f"{n} {c}" for n in names for c in ("R", "tz")]
    t = Table(cols, label_header="cameras / options", digits=3,
              caption=f"From the exact GT, {a.suite} scene {a.scene}, frames {a.frames}: mean over objects of R "
                      f"(deg; the bowl's axis only) and of abs(tz) and tz (mm); per object R (deg) and tz (mm)")
    runs = [(c, o) for c in modes for o in opt_sets]
    for cams, opts in progress(runs, desc="runs", unit="run"):
        err = object_errors(scene, models, refine_from_gt(scene, models, opts, cams == "fixed"))
        r = [err[o][0] for o in oids if o in err]
        tz = [err[o][1] for o in oids if o in err]
        per = [err[o][c] if o in err else None for o in oids for c in (0, 1)]
        label = f"{cams}: {json.dumps(opts)}"
        t.rows.append(Row(label, [float(np.mean(r)), float(np.mean(np.abs(tz))), float(np.mean(tz))] + per))
        print(f"{label}: R {np.mean(r):.3f} abs tz {np.mean(np.abs(tz)):.3f} mean tz {np.mean(tz):+.3f} | "
              + " ".join(f"{o}:{err[o][0]:.3f}/{err[o][1]:+.2f}" for o in oids if o in err), flush=True)
    for p in write_table(t, a.out, f"bias_frames_scene{a.scene}"):
        print(p)


if __name__ == "__main__":
    main()
