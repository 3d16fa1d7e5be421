"""`ycbvss eval`: score a BOP19 results CSV against a BOP dataset split.

Reads only scene_gt.json, scene_camera.json and the models (no images). Writes into --out:
errors.csv, summary.json, table.{md,csv,tex}, scores.{md,csv,tex}, curves.png, and prints the
tables. Bad input (missing files, malformed CSV, unknown obj_id) -> one error line, exit 2.
"""
from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import YcbvssError
from .options import add_split_option


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "eval", help="evaluate pose estimates (BOP19 CSV) on a BOP split: tx ty tz R PRJ ADD(-S), AUC, SR",
        description="Per GT instance: tx, ty, tz (mm), R (deg), PRJ (px), ADD and ADD-S (mm); per object "
                    "AUC of ADD(-S) (bound 100 mm) and PRJ (10 px), ADD-PRJ-AUC, SR at 5 cm / 5 deg; overall "
                    "= mean over objects. GT instances without an estimate count as failed.")
    p.add_argument("--dataset", required=True, help="BOP dataset root (contains models/ and the split folder)")
    add_split_option(p)
    p.add_argument("--results", required=True, help="BOP19 results CSV")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--symmetric", nargs="*", default=None, metavar="SET|OBJ_ID",
                   help="objects scored with ADD-S: paper (default: 13 = 024_bowl, Li et al.), bop (BOP ycbv: "
                        "1,13,14,16,18,19,20,21), posecnn (PoseCNN/PVN3D: 13,16,19,20,21), none, or obj_ids "
                        "(e.g. 13 16); the set is named in every table header")
    p.add_argument("--use-symmetries", action="store_true",
                   help="compare with the GT pose modulo the models_info symmetries (closest equivalent)")
    p.add_argument("--adds-for", choices=("all", "symmetric"), default="all",
                   help="compute the ADD-S column for all objects (default) or only the symmetric ones")
    p.add_argument("--models-subdir", default="models", help="models folder under --dataset (default models)")
    p.add_argument("--scenes", nargs="*", default=None, help="only these scene ids, e.g. 0,1 or 48-59")
    p.add_argument("--add-bound-mm", type=float, default=100.0, help="ADD(-S) AUC bound (default 100 mm)")
    p.add_argument("--prj-bound-px", type=float, default=10.0, help="PRJ AUC bound (default 10 px)")
    p.add_argument("--sr-t-mm", type=float, default=50.0, help="SR translation threshold (default 50 mm)")
    p.add_argument("--sr-r-deg", type=float, default=5.0, help="SR rotation threshold (default 5 deg)")
    p.add_argument("--no-curves", action="store_true", help="skip curves.png")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..eval.evaluate import EstArrays, EvalOptions, GtArrays, evaluate_arrays
    from ..eval.outputs import summary_text, write_outputs
    from ..io.bop import load_models
    from ..io.bop_dataset import resolve_split
    from ..io.results import read_bop19_csv
    from ..io.ycbv import parse_videos
    root = Path(args.dataset)
    if not root.is_dir():
        raise YcbvssError("dataset root not found", root)
    args.split = resolve_split(root, args.split)
    if args.scenes is not None:
        args.scenes = parse_videos(",".join(args.scenes), "scene list")
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..eval.symmetric_sets import parse_symmetric
    sym, sym_label = parse_symmetric(args.symmetric)
    options = EvalOptions(symmetric_obj_ids=sym, symmetric_set=sym_label, use_symmetries=args.use_symmetries,
                          adds_for=args.adds_for, add_bound_mm=args.add_bound_mm,
                          prj_bound_px=args.prj_bound_px, sr_t_mm=args.sr_t_mm, sr_r_deg=args.sr_r_deg)
    models = load_models(root / args.models_subdir, symmetric_obj_ids=sym)
    gt = GtArrays.from_bop(root, args.split, models, args.scenes)
    if len(gt) == 0:
        raise YcbvssError(f"no GT instances in split {args.split!r}", root / args.split)
    estimates = read_bop19_csv(args.results, known_obj_ids=models.keys())
    result = evaluate_arrays(gt, EstArrays.from_estimates(estimates), models, options)
    paths = write_outputs(result, args.out, curves=not args.no_curves)
    print(summary_text(result))
    print(f"wrote {', '.join(sorted(p.name for p in paths.values()))} to {args.out}")
    return 0
