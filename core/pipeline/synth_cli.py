"""``ycbvss synth`` and ``ycbvss synth preview`` (heavy imports inside the handlers)."""
from __future__ import annotations

import argparse

from ..errors import YcbvssError


def _scenes(text: str | None, what: str = "scene list"):
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..io.ycbv import parse_videos
    return parse_videos(text, what)


def register(sub) -> None:
    p = sub.add_parser(
        "synth", help="synthesise YCBV-SS (real YCB-V frames with objects re-rendered at known poses)",
        description="Build YCBV-SS as a BOP dataset: every annotated object of each real frame is "
                    "re-rendered (Blender Cycles, enlarged textured model, colour-matched, noised) at its "
                    "pose, giving exact GT. `ycbvss synth preview --dataset OUT` writes QA images. "
                    "Resumable: re-running skips finished frames.")
    p.add_argument("action", nargs="?", choices=["run", "preview"], default="run",
                   help="run (default) or preview (QA images of a YCBV-SS output)")
    p.add_argument("--dataset", required=True, help="input: BOP root or YCB-Video root (for preview: the YCBV-SS root)")
    p.add_argument("--split", default=None,
                   help="BOP split to read and to write (default: the input's only split; 'test' for a YCB-Video root)")
    p.add_argument("--out", help="output BOP root (run); preview folder (preview, default DATASET/preview)")
    p.add_argument("--scenes", help="scene/video ids, e.g. 0,1 or 48-59 (default: all)")
    p.add_argument("--poses", help="BOP19 results CSV with refined poses (recentred BOP model frame) to render "
                                   "instead of scene_gt")
    p.add_argument("--seed", type=int, default=0,
                   help="master seed: Cycles and noise seeds are derived from (seed, scene, frame), so a frame is "
                        "identical whatever the workers, executor or resume (default 0)")
    p.add_argument("--workers", type=int, default=None, help="Blender worker processes (default: cores/2, each with cores/workers render threads: "
                                                     "all cores)")
    p.add_argument("--executor", choices=["local", "ray"], default="local",
                   help="local: Blender worker processes on this machine (default); ray: Ray tasks on a cluster "
                        "(needs `pip install ycbvss[ray]` and --address)")
    p.add_argument("--address", default=None, help="Ray address (e.g. auto or ray://HOST:10001)")
    p.add_argument("--chunk", type=int, default=8,
                   help="frames per Ray task (larger: less scheduling overhead, coarser load balance; default 8)")
    p.add_argument("--samples", type=int, default=4, help="Cycles samples per pixel")
    p.add_argument("--denoise", action="store_true", help="OpenImageDenoise (slower)")
    p.add_argument("--max-bounces", type=int, default=1)
    p.add_argument("--shot-noise", type=float, default=2e-3, help="shot noise variance per unit linear signal")
    p.add_argument("--read-noise", type=float, default=4e-3, help="read noise sigma (linear units)")
    p.add_argument("--blur", type=float, default=0.0, help="Gaussian blur sigma of the render (px)")
    p.add_argument("--no-colour-fit", action="store_true")
    p.add_argument("--colour-fit-method", choices=["adaptive", "lsq", "mk"], default="adaptive")
    p.add_argument("--clear-px", type=int, default=4,
                   help="in-paint the real objects grown by this many px from the background before compositing, "
                        "so no rim of a misannotated real object survives outside the render (0 = off; default 4)")
    p.add_argument("--coverage-stride", type=int, default=1, help="use every N-th frame for the coverage search")
    p.add_argument("--scales", help="fixed model scales per object, e.g. 8:1.02,14:1.03 (skips the coverage choice)")
    p.add_argument("--max-frames", type=int, default=None, help="first N frames per scene")
    p.add_argument("--frames", help="only these im_ids (e.g. 1,2,5-9)")
    p.set_defaults(func=_handler)


def _handler(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..io.bop_dataset import resolve_split, split_names
    if args.action == "preview" or split_names(args.dataset):
        args.split = resolve_split(args.dataset, args.split)
    elif args.split is None:
        args.split = "test"                      # YCB-Video root input: the output split name
    if args.action == "preview":
        # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
        from ..synth.preview import write_preview
        out = write_preview(args.dataset, args.split, args.out, _scenes(args.scenes))
        print(f"preview written to {out}")
        return 0
    if not args.out:
        raise YcbvssError("--out is required")
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..synth.noise import NoiseParams
    from ..synth.run import SynthOptions, run_synth
    opts = SynthOptions(seed=args.seed, samples=args.samples, denoise=args.denoise, max_bounces=args.max_bounces,
                        noise=NoiseParams(shot=args.shot_noise, read=args.read_noise, blur_sigma_px=args.blur),
                        colour_fit=not args.no_colour_fit, colour_fit_method=args.colour_fit_method,
                        clear_px=args.clear_px,
                        coverage_stride=args.coverage_stride, max_frames=args.max_frames,
                        frames=_scenes(args.frames, "frame list"), workers=args.workers, executor=args.executor,
                        address=args.address, chunk=args.chunk,
                        scales={int(k): float(v) for k, v in (kv.split(":") for kv in args.scales.split(","))}
                        if args.scales else None)
    rep = run_synth(args.dataset, args.split, args.out, _scenes(args.scenes), args.poses, opts)
    n_new = rep.get("_timing", {}).get("n", 0)
    n_done = rep["frames"]["done"]
    print(f"YCBV-SS split {args.split}: {n_done} frames done ({n_new} synthesised now, {n_done - n_new} resumed from "
          f"an earlier run), {len(rep['frames']['skipped'])} skipped -> {args.out}")
    for s in rep["frames"]["skipped"][:10]:
        print(f"  skipped scene {s['scene_id']} frame {s['im_id']}: {s['reason']}")
    for oid, o in rep["objects"].items():
        print(f"  obj {int(oid):2d} {o['name']:<22s} scale {o['scale']:.3f} coverage {o['coverage_before']:.4f} -> "
              f"{o['coverage_after']}{' FLAGGED' if o['flagged'] else ''}  dE {o.get('dE_before')} -> {o.get('dE_after')}")
    return 0
