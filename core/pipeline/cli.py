"""CLI: `ycbvss validate` and `ycbvss demo` (registered by ycbvss.cli)."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from ..errors import YcbvssError
from .options import add_options_arg, read_options_arg


def _pos_float(s: str) -> float:
    try:
        v = float(s)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {s!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {s}")
    return v


def _int_min(lo: int):
    def f(s: str) -> int:
        try:
            v = int(s)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {s!r}") from None
        if v < lo:
            raise argparse.ArgumentTypeError(f"must be >= {lo}, got {v}")
        return v
    return f


def parse_scene_list(s: str) -> list[int]:
    """'48,50-52' -> [48, 50, 51, 52]."""
    out = []
    try:
        for part in s.split(","):
            part = part.strip()
            if not part:
                continue
            if "-" in part:
                a, b = part.split("-", 1)
                a, b = int(a), int(b)
                if b < a:
                    raise ValueError
                out += list(range(a, b + 1))
            else:
                out.append(int(part))
    except ValueError:
        raise argparse.ArgumentTypeError(f"bad scene list {s!r} (use e.g. 48,50-52)") from None
    if not out or min(out) < 0:
        raise argparse.ArgumentTypeError(f"bad scene list {s!r} (use e.g. 48,50-52)")
    return out


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--seed", type=_int_min(0), default=0, metavar="N",
                   help="random seed of the perturbation, the refiner's sampling and the rendering (default 0)")
    p.add_argument("--init-add-mm", type=_pos_float, default=22.1, metavar="MM",
                   help="target mean ADD of the initial (perturbed) poses in mm (default 22.1, the paper's)")
    p.add_argument("--no-ablation", dest="ablation", action="store_false",
                   help="skip the three ablation runs (w/o f_edge, w/o f_point, w/o f_t, run on the keyframes): about 2x faster, no Table 5")
    p.add_argument("--keyframe-step", type=_int_min(1), default=None, metavar="N",
                   help="refine every N-th frame jointly, then the others camera-only (default: about 8 "
                        "keyframes per scene; 1 = all frames jointly)")
    p.add_argument("--overlays", type=_int_min(0), default=3, metavar="N",
                   help="number of frames with contour overlays in the report (default 3)")


def register(subparsers) -> None:
    """Add ``ycbvss validate`` and ``ycbvss demo``."""
    _register_validate(subparsers)
    _register_demo(subparsers)


def _register_validate(subparsers) -> None:
    v = subparsers.add_parser(
        "validate", help="synthesise YCBV-SS, perturb GT, refine, evaluate, report (the paper's Tables 4/5)",
        description="Validate bundle pose refinement on data with exact ground truth: (a) synthesise YCBV-SS "
                    "from the given real frames and poses (Blender), (b) perturb the exact GT with random "
                    "per-(view, object) deviations calibrated to a mean ADD / PRJ, (c) run bundle refinement "
                    "(all terms, plus ablations), (d) evaluate. Writes Table 4 / Table 5 layouts as Markdown, "
                    "CSV and LaTeX, poses as BOP19 CSV, overlays, error curves and one HTML report into --out. "
                    "With --real: refine the original annotations of real frames and report the "
                    "original-vs-refined difference instead.",
        epilog="examples:\n"
               "  ycbvss validate --dataset /data/ycbv --scenes 48 --max-frames 60 --out out/val48\n"
               "  ycbvss validate --dataset /data/bop/ycbv --split test --scenes 48-50 --out out/val\n"
               "  ycbvss validate --real --dataset /data/ycbv --scenes 48 --frame-step 10 --out out/real48\n"
               "  ycbvss validate --gt-exact --dataset ycbvss_demo/dataset --out out/again",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    v.add_argument("--dataset", required=True, type=Path, metavar="ROOT",
                   help="a BOP dataset root (models/ + split/NNNNNN/) or an original YCB-Video root (data/, models/)")
    v.add_argument("--out", required=True, type=Path, metavar="DIR", help="output folder (created)")
    v.add_argument("--split", default=None, help="BOP split folder (default: auto, preferring test/val/train_real)")
    v.add_argument("--scenes", type=parse_scene_list, default=None, metavar="LIST",
                   help="scene ids / YCB-Video video numbers to use, e.g. 48,50-52 (default: all)")
    v.add_argument("--init-prj-px", type=_pos_float, default=5.2, metavar="PX",
                   help="target mean PRJ of the initial poses in pixels (default 5.2, the paper's)")
    v.add_argument("--real", action="store_true",
                   help="real frames without exact GT: refine the original annotations and write the "
                        "'original vs refined' difference table (no synthesis, no perturbation)")
    v.add_argument("--gt-exact", action="store_true",
                   help="the dataset's GT is already exact (e.g. a rendered or synthesised BOP dataset): "
                        "skip the YCBV-SS synthesis")
    v.add_argument("--max-frames", type=_int_min(2), default=None, metavar="N",
                   help="use at most N frames per scene (after --frame-step; default: all)")
    v.add_argument("--frame-step", type=_int_min(1), default=1, metavar="N", help="use every N-th frame (default 1)")
    v.add_argument("--workers", type=_int_min(1), default=None, metavar="N",
                   help="Blender worker processes for the synthesis (default: one per core)")
    v.add_argument("--samples", type=_int_min(1), default=8, metavar="N",
                   help="Cycles samples per pixel for the synthesis (default 8)")
    v.add_argument("--suite", default=None, metavar="NAME",
                   help="run the refiner's validation suite instead (ycbv21: 9 Blender scenes of the 21 YCB-V "
                        "models, short/medium/long clips; ycbv21-fresh: 6 sealed test scenes, short and medium "
                        "clips; ycbv21-ci: one short clip); --dataset gives the "
                        "YCB-V models (original or BOP root); scenes are rendered once and cached in --out")
    v.add_argument("--suite-kinds", default="short,medium,long", metavar="LIST",
                   help="clip kinds to run with --suite (default short,medium,long)")
    v.add_argument("--suite-seeds", default="0,5", metavar="LIST",
                   help="initialisation seeds with --suite (default 0,5; seeds >= 5 are held out of tuning)")
    v.add_argument("--capture", default="", metavar="KINDS",
                   help="with --suite: also run the capture-range levels (init ADD 5..60 mm; PRJ 2..20 px at the paper's depth error) on these clip kinds")
    _common(v)
    add_options_arg(v)
    v.set_defaults(func=_validate)


def _register_demo(subparsers) -> None:
    d = subparsers.add_parser(
        "demo", help="no data needed: procedural scene -> Blender -> the whole validate loop -> HTML report",
        description="Build a procedural multi-object table-top scene in code (boxes, cylinders, a mug; textured "
                    "and textureless; a camera arc with a real baseline), render it into a BOP dataset "
                    "(Blender Cycles by default), then run the full validation loop on it (perturb -> bundle "
                    "refinement + ablations -> evaluation -> tables, overlays, curves, HTML report). Prints the "
                    "Table-4-style table and the path of the report.",
        epilog="examples:\n"
               "  ycbvss demo                      # 24 frames 640x480, Blender, ablations (~2 min on 2 idle cores)\n"
               "  ycbvss demo --quick              # 6 frames 320x240 (CI)\n"
               "  ycbvss demo --renderer fast --no-ablation --out /tmp/d",
        formatter_class=argparse.RawDescriptionHelpFormatter)
    d.add_argument("--out", type=Path, default=Path("ycbvss_demo"), metavar="DIR",
                   help="output folder (default ./ycbvss_demo)")
    d.add_argument("--quick", action="store_true",
                   help="tiny run for CI / a first look: 6 frames at 320x240 (unless --frames/--width are given)")
    d.add_argument("--frames", type=_int_min(2), default=None, metavar="N",
                   help="number of frames (default 24; 6 with --quick)")
    d.add_argument("--width", type=_int_min(64), default=None, metavar="PX",
                   help="image width; height = 3/4 width (default 640; 320 with --quick)")
    d.add_argument("--renderer", choices=("blender", "fast"), default="blender",
                   help="blender (default): Cycles path tracing of the objects, composited over the table; "
                        "fast: OpenGL Lambertian shading (seconds, no Blender)")
    d.add_argument("--samples", type=_int_min(1), default=8, metavar="N", help="Cycles samples per pixel (default 8)")
    d.add_argument("--denoise", action="store_true",
                   help="OpenImageDenoise the Blender renders (cleaner, ~2x slower on CPU)")
    d.add_argument("--workers", type=_int_min(1), default=1, metavar="N",
                   help="Blender worker processes (default 1; each uses cores/N threads)")
    d.add_argument("--init-prj-px", type=_pos_float, default=None, metavar="PX",
                   help="target mean PRJ of the initial poses (default: 5.2 px scaled to the image width)")
    _common(d)
    d.set_defaults(func=_demo)


def _print_summary(summary: dict, what: str, stages=None) -> None:
    out = sys.stdout
    print("", file=out)
    print(summary["table4_md"], file=out)
    if summary.get("table5_md"):
        print(summary["table5_md"], file=out)
    if summary.get("mode") in ("validate", "demo"):
        i = summary["initial"]
        r = summary["refined"]
        print(f"initial poses: mean ADD {i['achieved_add_mm']:.2f} mm (target {i['target_add_mm']:g}), "
              f"mean PRJ {i['achieved_prj_px']:.2f} px (target {i['target_prj_px']:g})", file=out)
        print(f"refined (all terms): mean ADD {r['add_mm']:.3f} mm, mean PRJ {r['prj_px']:.3f} px", file=out)
    if summary.get("status"):
        c = summary["status"]
        print(f"status of the refined poses: {c.get('converged', 0)} converged, {c.get('uncertain', 0)} uncertain, "
              f"{c.get('failed', 0)} failed (per object: tables/status.md; the BOP19 score of "
              f"poses/refined_poses.csv is each pose's confidence)", file=out)
    print(f"\n{what}: {summary['scenes'].__len__()} scene(s), {summary['frames']} frames, {summary['pairs']} "
          f"(view, object) pairs", file=out)
    times = dict(stages.times) if stages is not None else dict(summary.get("timings_s", {}))
    for k, t in times.items():
        print(f"  {k:<48s} {t:8.1f} s", file=out)
    if stages is not None:
        print(f"  {'total':<48s} {stages.total_s:8.1f} s", file=out)
    print(f"tables:  {Path(summary['out']) / 'tables'}", file=out)
    print(f"figures: {Path(summary['out']) / 'figures'}", file=out)
    print(f"report:  {summary['report']}", file=out)


def _validate(args) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from .validate import Stages, ValidateOptions, run_validate
    if not args.dataset.exists():
        raise YcbvssError("dataset not found", args.dataset)
    refine_options = read_options_arg(args.options)    # checked before anything runs
    if args.suite:
        return _validate_suite(args, refine_options)
    opts = ValidateOptions(dataset=args.dataset, out=args.out, split=args.split, scenes=args.scenes, seed=args.seed,
                           init_add_mm=args.init_add_mm, init_prj_px=args.init_prj_px, real=args.real,
                           gt_exact=args.gt_exact, ablation=args.ablation, keyframe_step=args.keyframe_step,
                           max_frames=args.max_frames, frame_step=args.frame_step, workers=args.workers,
                           samples=args.samples, overlays=args.overlays, refine_options=refine_options)
    stages = Stages()
    summary = run_validate(opts, stages)
    _print_summary(summary, "ycbvss validate" + (" --real" if args.real else ""), stages)
    return 0


def _validate_suite(args, refine_options: dict | None = None) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from .suite_run import run_suite

    def names(s: str) -> tuple[str, ...]:
        out = tuple(x.strip() for x in s.split(",") if x.strip())
        bad = [x for x in out if x not in ("short", "medium", "long")]
        if bad:
            raise YcbvssError(f"unknown clip kind {bad[0]!r} (short, medium, long)")
        return out

    try:
        seeds = tuple(int(x) for x in args.suite_seeds.split(",") if x.strip())
    except ValueError:
        raise YcbvssError(f"--suite-seeds must be a comma-separated list of integers, got {args.suite_seeds!r}")
    res = run_suite(args.dataset, args.out, args.suite, scene_ids=args.scenes, kinds=names(args.suite_kinds),
                    seeds=seeds, ablation=args.ablation, capture_kinds=names(args.capture) if args.capture else (),
                    refine_options=refine_options)
    for name, p in res["tables"].items():
        if p.suffix == ".md":
            print(p.read_text())
    print(f"ycbvss validate --suite {args.suite}: {res['n_rows']} pose rows -> {args.out / 'report'}")
    return 0


def _demo(args) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from .demo import DemoOptions, run_demo
    from .validate import Stages
    opts = DemoOptions(out=args.out, quick=args.quick, frames=args.frames, width=args.width, seed=args.seed,
                       renderer=args.renderer, samples=args.samples, denoise=args.denoise, workers=args.workers, ablation=args.ablation,
                       keyframe_step=args.keyframe_step, init_add_mm=args.init_add_mm, init_prj_px=args.init_prj_px,
                       overlays=args.overlays)
    stages = Stages()
    summary = run_demo(opts, stages)
    _print_summary(summary, "ycbvss demo", stages)
    return 0
