"""``ycbvss refine``: bundle pose refinement of BOP scenes."""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from ..errors import YcbvssError
from .options import add_options_arg, add_split_option, read_options_arg


def register(sub) -> None:
    p = sub.add_parser("refine", help="bundle pose refinement (edge + point + temporal terms) of static scenes",
                       description="Refine the object poses of every scene jointly with the cameras "
                                   "(world = first camera). Writes a BOP19 CSV, BOP scene_gt.json + "
                                   "scene_camera.json (solved cam_R_w2c/cam_t_w2c), world poses, per-pose "
                                   "uncertainty and a convergence log.")
    p.add_argument("--dataset", required=True, help="BOP dataset root (with models/ and the split folder)")
    add_split_option(p)
    p.add_argument("--init", required=True,
                   help="initial poses: a BOP19 results CSV, or 'scene_gt' to start from each scene's scene_gt.json")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--scenes", nargs="*", default=None, help="scene ids, e.g. 0,1 or 48-59 (default: all)")
    p.add_argument("--workers", type=int, default=1,
                   help="scenes refined in parallel (local processes, each with cores/workers threads; default 1)")
    p.add_argument("--executor", choices=["local", "ray"], default="local",
                   help="local processes (default) or Ray tasks (--address); finished scenes are skipped on re-run")
    p.add_argument("--address", default=None, help="Ray address (e.g. auto)")
    p.add_argument("--models-subdir", default="models")
    p.add_argument("--no-edge", action="store_true", help="drop the edge term")
    p.add_argument("--no-point", action="store_true", help="drop the point (3D-2D flow match) term")
    p.add_argument("--no-temporal", action="store_true", help="drop the temporal (view-to-view) term")
    p.add_argument("--keyframe-step", type=int, default=0,
                   help="optimise every N-th frame jointly, then the others camera-only (0: all jointly)")
    p.add_argument("--known-cameras", action="store_true",
                   help="keep every frame's camera pose from scene_camera.json (cam_R_w2c, cam_t_w2c) and refine "
                        "the objects only; use it when the cameras are known (e.g. synthetic data): with free "
                        "cameras the scene's scale rests on the objects' apparent size alone "
                        "(bench/results/ycbv21/bias_sources.md)")
    p.add_argument("--alpha", type=float, default=None, help="weight of the point term (default 5)")
    p.add_argument("--beta", type=float, default=None, help="weight of the temporal term (default 1)")
    p.add_argument("--max-iters", type=int, default=None, help="outer (re-render) iterations per level")
    p.add_argument("--edge-contact-mm", type=float, default=None,
                   help="skip the edge term's contour samples at contact lines, where another object's surface lies "
                        "less than this far (mm) behind the silhouette; for objects standing on others, whose "
                        "contact shadow's edge pulls them (default 0: off; 10 with --contact-weight 1 is what "
                        "bench/results/ycbv21/README.md measures)")
    p.add_argument("--edge-junction-px", type=float, default=None,
                   help="skip the edge term's contour samples within this many px (640-px-wide images) of where "
                        "their object's silhouette is cut by a nearer object (T-junctions, whose mixed edges pull "
                        "a partly hidden object; default 3, 0: off)")
    p.add_argument("--contact-weight", type=float, default=None,
                   help="weight of the non-penetration term (per mm^2 of depth inside another object, per point "
                        "and view; default 0: off)")
    p.add_argument("--table-flow", nargs="?", const="all", default=None, metavar="GROUPS",
                   help="hold the cameras' relative rotations at the finest blur level of the keyframe bundle to "
                        "what the static table's homography measures (ycbvss.refine.table): 'all', 'none' or a "
                        "comma-separated list of viewing-baseline groups (narrow, medium, wide); bare: 'all' "
                        "(default: 'medium', RefineOptions.table_flow)")
    p.add_argument("--table-span-deg", type=float, default=None,
                   help="with the table, also pair each keyframe with the earliest keyframe turned at most this "
                        "far (deg) from it, so far pairs fix the camera path's turn (default 30; 0: temporal pairs only)")
    p.add_argument("--no-table-contact", dest="table_contact", action="store_false", default=None,
                   help="with the table, do not hold the objects standing on it at one height above a plane of the "
                        "normal its homographies measure (ycbvss.refine.table_contact; default: held, "
                        "RefineOptions.table_contact)")
    p.add_argument("--table-contact", dest="table_contact", default=None, metavar="GROUPS",
                   help="hold the objects standing on the table at one height on the scenes of these viewing-"
                        "baseline groups (comma-separated: narrow, medium, wide), with or without --table-flow "
                        "(default: where the table's rotation term is on)")
    add_options_arg(p)
    p.set_defaults(func=_run)


def _refine_job(job: dict) -> dict:
    """Refine one scene and write its outputs (runs in a worker process for --workers > 1). The scene's
    estimates file ``refine/<scene>_estimates.csv`` is written last: it marks the scene done (resume)."""
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..io.bop import load_dataset
    from ..io.results import write_bop19_csv
    from ..refine.bundle import refine_scene
    from ..refine.io import estimates_of, write_scene_outputs

    sid = job["scene_id"]
    ds = load_dataset(job["dataset"], job["split"], models_subdir=job["models_subdir"], scene_ids=[sid])
    scene = ds.load_scene(sid)
    init = job["init"]
    if init is None:
        init = {(f.im_id, i.obj_id): i.T_m2c for f in scene.frames for i in f.instances}
    t0 = time.perf_counter()
    res = refine_scene(scene, ds.models, init, job["opt"])
    dt = (time.perf_counter() - t0) / max(len(scene.frames), 1)
    write_scene_outputs(job["out"], job["split"], scene, res)
    write_bop19_csv(_part_path(job["out"], sid), estimates_of(sid, res, dt))
    counts = {k: sum(1 for v in res.status.values() if v == k) for k in ("converged", "uncertain", "failed")}
    return {"scene_id": sid, "n_poses": len(res.poses), "counts": counts, "total_s": res.stats.get("total_s", 0)}


def _part_path(out, sid: int):
    return Path(out) / "refine" / f"{sid:06d}_estimates.csv"


def _run(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..io.bop import load_dataset
    from ..io.bop_dataset import resolve_split
    from ..io.results import read_bop19_csv, write_bop19_csv
    from ..io.ycbv import parse_videos
    from ..parallel import run_jobs
    from ..refine.bundle import RefineOptions
    from .datasets import enlarged_model_scales
    args.split = resolve_split(args.dataset, args.split)
    scenes = None if args.scenes is None else parse_videos(",".join(args.scenes), "scene list")
    ds = load_dataset(args.dataset, args.split, models_subdir=args.models_subdir, scene_ids=scenes)
    opt = RefineOptions(use_edge=not args.no_edge, use_point=not args.no_point, use_temporal=not args.no_temporal,
                        keyframe_step=args.keyframe_step, fix_cameras=args.known_cameras)
    for k in ("alpha", "beta", "max_iters", "edge_contact_mm", "edge_junction_px", "contact_weight", "table_span_deg"):
        if getattr(args, k) is not None:
            setattr(opt, k, getattr(args, k))
    if args.table_flow is not None:
        opt.table_flow = {"all": True, "none": False}.get(args.table_flow, args.table_flow)
    if args.table_contact is not None:
        opt.table_contact = args.table_contact
    elif enlarged_model_scales(args.dataset):
        opt.table_contact = False
        opt.support_check = False
        print("ycbvss: the dataset's models are enlarged (YCBV-SS, synth_report.json), so its objects do not "
              "stand on the table with their models' surfaces: table contact and the support check off", file=sys.stderr)
    for k, v in read_options_arg(args.options).items():
        setattr(opt, k, v)
    if not (opt.use_edge or opt.use_point):
        raise YcbvssError("at least one of the edge and point terms is needed (both disabled)")
    csv_init = None
    if args.init != "scene_gt":
        csv_init = {}
        for e in read_bop19_csv(args.init, known_obj_ids=ds.models.keys()):
            key = (e.scene_id, e.im_id, e.obj_id)
            if key not in csv_init or e.score > csv_init[key][0]:
                csv_init[key] = (e.score, e.T_m2c)
    out = Path(args.out)
    try:                                     # an unwritable --out is found before any work
        (out / "refine").mkdir(parents=True, exist_ok=True)
        probe = out / "refine" / f".write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as e:
        raise YcbvssError(f"output folder not writable: {e.strerror}", out) from None
    jobs, resumed = [], []
    for sid in ds.scene_ids:
        init = None
        if csv_init is not None:
            init = {(im, o): T for (s, im, o), (_, T) in csv_init.items() if s == sid}
            if not init:
                raise YcbvssError(f"no initial poses for scene {sid}", args.init)
        if _part_path(out, sid).is_file():
            resumed.append(sid)
            continue
        jobs.append({"dataset": str(args.dataset), "split": args.split, "models_subdir": args.models_subdir,
                     "scene_id": sid, "init": init, "opt": opt, "out": str(out)})
    if resumed:
        print(f"{len(resumed)} scene(s) already refined in {out} (resumed): {', '.join(map(str, resumed))}")

    def report(job, r):
        c = r["counts"]
        print(f"scene {r['scene_id']}: {r['n_poses']} poses ({c['converged']} converged, "
              f"{c['uncertain']} uncertain, {c['failed']} failed), {r['total_s']:.1f} s")

    run_jobs(_refine_job, jobs, workers=args.workers, executor=args.executor, address=args.address,
             desc="refine", on_result=report)
    ests = [e for sid in ds.scene_ids for e in read_bop19_csv(_part_path(out, sid))]
    write_bop19_csv(out / f"refine_{ds.name or 'dataset'}-{args.split}.csv", ests)
    return 0
