"""``ycbvss refine``: bundle pose refinement of BOP scenes."""
from __future__ import annotations

import argparse


def register(sub) -> None:
    p = sub.add_parser("refine", help="bundle pose refinement (edge + point + temporal terms) of static scenes",
                       description="Refine the object poses of every scene jointly with the cameras "
                                   "(world = first camera). Writes a BOP19 CSV, BOP scene_gt.json + "
                                   "scene_camera.json (solved cam_R_w2c/cam_t_w2c), world poses, per-pose "
                                   "uncertainty and a convergence log.")
    p.add_argument("--dataset", required=True, help="BOP dataset root (with models/ and the split folder)")
    p.add_argument("--split", required=True, help="split folder name, e.g. test")
    p.add_argument("--init", required=True,
                   help="initial poses: a BOP19 results CSV, or 'scene_gt' to start from each scene's scene_gt.json")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--scenes", type=int, nargs="*", default=None, help="scene ids (default: all)")
    p.add_argument("--models-subdir", default="models")
    p.add_argument("--no-edge", action="store_true", help="drop the edge term")
    p.add_argument("--no-point", action="store_true", help="drop the point (3D-2D flow match) term")
    p.add_argument("--no-temporal", action="store_true", help="drop the temporal (view-to-view) term")
    p.add_argument("--keyframe-step", type=int, default=0,
                   help="optimise every N-th frame jointly, then the others camera-only (0: all jointly)")
    p.add_argument("--alpha", type=float, default=None, help="weight of the point term (default 1)")
    p.add_argument("--beta", type=float, default=None, help="weight of the temporal term (default 1)")
    p.add_argument("--max-iters", type=int, default=None, help="outer (re-render) iterations per level")
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path

    from ycbvss.errors import YcbvssError
    from ycbvss.io.bop import load_dataset
    from ycbvss.io.results import read_bop19_csv, write_bop19_csv
    from ycbvss.progress import progress

    from .bundle import RefineOptions, refine_scene
    from .io import estimates_of, write_scene_outputs

    ds = load_dataset(args.dataset, args.split, models_subdir=args.models_subdir, scene_ids=args.scenes)
    opt = RefineOptions(use_edge=not args.no_edge, use_point=not args.no_point, use_temporal=not args.no_temporal,
                        keyframe_step=args.keyframe_step)
    for k in ("alpha", "beta", "max_iters"):
        if getattr(args, k) is not None:
            setattr(opt, k, getattr(args, k))
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
    ests = []
    for scene in progress(ds.iter_scenes(), desc="refine", total=len(ds.scene_ids), unit="scene"):
        if csv_init is None:
            init = {(f.im_id, i.obj_id): i.T_m2c for f in scene.frames for i in f.instances}
        else:
            init = {(im, o): T for (s, im, o), (_, T) in csv_init.items() if s == scene.scene_id}
        if not init:
            raise YcbvssError(f"no initial poses for scene {scene.scene_id}", args.init)
        t0 = time.perf_counter()
        res = refine_scene(scene, ds.models, init, opt)
        dt = (time.perf_counter() - t0) / max(len(scene.frames), 1)
        ests += estimates_of(scene.scene_id, res, dt)
        write_scene_outputs(out, args.split, scene, res)
        counts = {k: sum(1 for v in res.status.values() if v == k) for k in ("converged", "uncertain", "failed")}
        print(f"scene {scene.scene_id}: {len(res.poses)} poses ({counts['converged']} converged, "
              f"{counts['uncertain']} uncertain, {counts['failed']} failed), {res.stats.get('total_s', 0):.1f} s")
    write_bop19_csv(out / f"refine_{ds.name or 'dataset'}-{args.split}.csv", ests)
    return 0
