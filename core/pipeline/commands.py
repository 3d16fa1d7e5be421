"""Data-layer subcommands: ``ycbvss convert ycbv`` and ``ycbvss assets verify``.

Heavy imports (scipy, trimesh, moderngl) stay inside the handlers.
"""
from __future__ import annotations

import argparse
import sys

from ..errors import YcbvssError


def register(subparsers) -> None:
    # ---------------------------------------------------------------- convert
    p = subparsers.add_parser("convert", help="convert a dataset layout (original YCB-Video -> BOP)",
                              description="Convert datasets between layouts.")
    sub = p.add_subparsers(dest="convert_what", required=True, metavar="FORMAT")
    c = sub.add_parser(
        "ycbv", help="original YCB-Video layout -> BOP layout",
        description="Original YCB-Video (data/NNNN/NNNNNN-{color,depth,label}.png + meta.mat, "
                    "models/<name>/textured.obj in metres) -> BOP: models/obj_XXXXXX.ply in mm recentred on "
                    "the bounding-box centre c (+ texture PNG, models_info.json), poses t_bop = 1000 (t + R c), "
                    "rgb/ and depth/ (byte copies, depth_scale 0.1), scene_camera.json (K, cam_R/t_w2c), "
                    "scene_gt.json, and mask/, mask_visib/, scene_gt_info.json rendered with the fast renderer. "
                    "Scene id = video number. Re-running skips finished scenes and models (use --overwrite).")
    c.add_argument("--src", required=True, help="YCB-Video root (contains data/, models/)")
    c.add_argument("--out", required=True, help="BOP dataset root to write")
    c.add_argument("--videos", default=None,
                   help="videos to convert, e.g. 0000,0001 or 0-47 (default: all under data/)")
    c.add_argument("--split", default=None,
                   help="split folder name (default: as BOP ycbv: test for videos 48-59, train_real otherwise)")
    c.add_argument("--objects", default=None,
                   help="obj_ids of the models to convert, e.g. 1,2,13 (default: all 21; objects seen in the "
                        "selected videos are always converted)")
    c.add_argument("--texture-max-px", type=int, default=None,
                   help="downsample model textures larger than this (default: keep the 4096 px textures)")
    c.add_argument("--delta-mm", type=float, default=15.0,
                   help="visibility tolerance for mask_visib (default 15 mm, as BOP)")
    c.add_argument("--workers", type=int, default=2, help="threads for the model conversion (default 2)")
    c.add_argument("--overwrite", action="store_true", help="rewrite finished scenes and models")
    c.set_defaults(func=run_convert_ycbv)

    # ---------------------------------------------------------------- assets
    a = subparsers.add_parser("assets", help="check local data against assets_manifest.yaml",
                              description="Asset manifest tools.")
    asub = a.add_subparsers(dest="assets_what", required=True, metavar="ACTION")
    v = asub.add_parser("verify", help="verify sha256 sums of a local copy of the sample data",
                        description="Compare every file recorded in the manifest's sample_data.files with a local "
                                    "copy: prints OK / missing / mismatch per file; exit 1 if any file is missing "
                                    "or differs.")
    v.add_argument("--root", required=True, help="local copy of the sample data (e.g. ../shared/data)")
    v.add_argument("--manifest", default=None, help="manifest YAML (default: the one shipped with ycbvss)")
    v.add_argument("--quiet", action="store_true", help="print only problems and the summary")
    v.set_defaults(func=run_assets_verify)


def run_convert_ycbv(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..convert import convert_ycbv
    from ..io.ycbv import parse_videos

    objs = None
    if args.objects:
        try:
            objs = [int(x) for x in args.objects.replace(" ", "").split(",") if x]
        except ValueError:
            raise YcbvssError(f"--objects: bad obj_id list {args.objects!r}") from None
    if args.texture_max_px is not None and args.texture_max_px < 1:
        raise YcbvssError("--texture-max-px must be >= 1")
    r = convert_ycbv(args.src, args.out, videos=parse_videos(args.videos), split=args.split,
                     overwrite=args.overwrite, obj_ids=objs, delta_mm=args.delta_mm,
                     texture_max_px=args.texture_max_px, workers=args.workers)
    print(f"converted {len(r['videos'])} videos ({r['frames_written']} frames written, "
          f"{r['frames_skipped']} already done), {len(r['models'])} models -> {r['out']} "
          f"in {r['seconds']:.1f} s (models {r['seconds_models']:.1f} s)")
    sp = r["splits"]
    print(f"split{'s' if len(sp) > 1 else ''}: {', '.join(sp)} (BOP ycbv: videos 48-59 are 'test', the others "
          f"'train_real'); targets, models_eval/ and dataset_info.md written")
    print(f"next: ycbvss synth --dataset {r['out']} --split {sp[0]} --out YCBVSS_ROOT")
    return 0


def run_assets_verify(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..manifest import load_manifest, verify_assets

    res = verify_assets(args.root, load_manifest(args.manifest))
    counts: dict[str, int] = {}
    for rel, status in res:
        counts[status] = counts.get(status, 0) + 1
        if not args.quiet or status != "OK":
            print(f"{status:8s} {rel}")
    print(f"{len(res)} files: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())))
    bad = counts.get("missing", 0) + counts.get("mismatch", 0)
    if bad:
        print(f"ycbvss assets: {bad} file(s) missing or different from the manifest", file=sys.stderr)
    return 1 if bad else 0
