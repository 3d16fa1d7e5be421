"""``ycbvss export`` (refined BOP dataset) and ``ycbvss gt`` (a split's GT as a BOP19 CSV)."""
from __future__ import annotations

import argparse

from .options import add_split_option


def register(sub) -> None:
    p = sub.add_parser(
        "export", help="write a BOP dataset with the refined poses and cameras of a `ycbvss refine` output",
        description="Complete BOP dataset with the refined annotations: scene_gt.json replaced, scene_gt_info.json, "
                    "mask/, mask_visib/ recomputed (bop_toolkit rules), scene_camera.json with the solved "
                    "cam_R_w2c/cam_t_w2c, scene_gt_refine.json (per-pose status and confidence), rgb/depth/models "
                    "linked (or --copy), models_eval/, camera files, targets file and dataset_info.md.")
    p.add_argument("--dataset", required=True, help="source BOP dataset root (what refine was run on)")
    add_split_option(p)
    p.add_argument("--refined", required=True, help="`ycbvss refine --out` folder")
    p.add_argument("--out", required=True, help="new BOP dataset root")
    p.add_argument("--scenes", default=None, help="scene ids, e.g. 0,1 or 48-59 (default: all)")
    p.add_argument("--copy", action="store_true", help="copy rgb/depth/models instead of symbolic links")
    p.set_defaults(func=_run_export)

    g = sub.add_parser("gt", help="write a split's GT poses as a BOP19 results CSV",
                       description="One row per GT instance (score 1, time -1): a perfect 'estimate' to test "
                                   "eval and to initialise refine.")
    g.add_argument("--dataset", required=True, help="BOP dataset root")
    add_split_option(g)
    g.add_argument("--out", required=True, help="CSV file to write")
    g.add_argument("--scenes", default=None, help="scene ids, e.g. 0,1 or 48-59 (default: all)")
    g.set_defaults(func=_run_gt)


def _scenes(text):
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..io.ycbv import parse_videos
    return parse_videos(text, "scene list")


def _run_export(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..io.bop_dataset import resolve_split
    from .export import export_refined
    args.split = resolve_split(args.dataset, args.split)
    r = export_refined(args.dataset, args.split, args.refined, args.out, copy=args.copy, scenes=_scenes(args.scenes))
    print(f"exported {len(r['scenes'])} scenes, {r['frames']} frames: {r['refined']} refined poses, {r['kept']} "
          f"kept from the source, {r['cams_refined']} refined cameras -> {r['out']} ({r['seconds']:.1f} s)")
    print(f"next: ycbvss eval --dataset {r['out']} --split {r['split']} --results CSV --out DIR")
    return 0


def _run_gt(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..io.bop_dataset import resolve_split
    from .export import write_gt_csv
    args.split = resolve_split(args.dataset, args.split)
    n = write_gt_csv(args.dataset, args.split, args.out, scenes=_scenes(args.scenes))
    print(f"wrote {n} GT poses of split {args.split} to {args.out}")
    return 0
