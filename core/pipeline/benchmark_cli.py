"""`ycbvss benchmark make|run|score`: the paper's tracking benchmark (see ycbvss.eval.benchmark).

- ``make`` reads only GT and camera files and writes the subsequence JSON; prints its summary.
- ``run`` runs a tracker (``baseline`` = refine's edge + flow terms frame to frame, all objects in
  one bundle; ``baseline-per-object``; ``static``; or ``module:Class``) on every subsequence,
  one results CSV per subsequence, resuming.
- ``score`` scores one or more results folders: ranking table (.md/.tex/.csv), scores.json,
  curves.png, per-frame errors.
"""
from __future__ import annotations

import argparse
import importlib
import time
from pathlib import Path

from ..errors import YcbvssError

TRACKERS = {
    "baseline": "ycbvss.refine.tracker:EdgeFlowTracker",
    "baseline-per-object": "ycbvss.refine.tracker:EdgeFlowTrackerPerObject",
    "static": "ycbvss.eval.benchmark.run:StaticTracker",
}


def _ints(text: str, what: str) -> tuple[int, ...]:
    try:
        v = tuple(int(x) for x in str(text).replace(" ", "").split(",") if x)
    except ValueError:
        raise YcbvssError(f"{what}: expected comma-separated integers, got {text!r}") from None
    if not v:
        raise YcbvssError(f"{what}: empty list")
    return v


def register(subparsers) -> None:
    p = subparsers.add_parser("benchmark", help="the paper's tracking benchmark: make subsequences, run a "
                                                "tracker, score and rank trackers",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="benchmark_command", required=True, metavar="SUBCOMMAND")

    m = sub.add_parser("make", help="split every sequence into subsequences (JSON)")
    m.add_argument("--dataset", required=True, help="BOP root, original YCB-Video root or BCOT root")
    m.add_argument("--protocol", choices=("ycbv", "bcot"), required=True)
    m.add_argument("--out", required=True, help="benchmark config JSON to write")
    m.add_argument("--seed", type=int, default=0)
    m.add_argument("--lengths", default=None, help="subsequence lengths (default 25,50,100,200)")
    m.add_argument("--steps", default=None, help="frame step MIN,MAX (default ycbv 5,15; bcot 1,4)")
    m.add_argument("--coverage", type=float, default=1.0,
                   help="tracked frames per dataset frame (default 1: about as many as the dataset has)")
    m.add_argument("--remove-prob", type=float, default=0.5,
                   help="ycbv: probability to remove one occluding object from a subsequence (default 0.5)")
    m.add_argument("--exclude", default=None, help="obj_ids never tracked (default ycbv: 16 = 036_wood_block)")
    m.add_argument("--split", default=None, help="BOP split folder (default: test, val, ... whichever exists)")
    m.add_argument("--scenes", default=None, help="only these scene ids / videos, e.g. 48-59 (the YCB-V test videos) or 48,50")
    m.add_argument("--bcot-scenes", default=None,
                   help="BCOT test scenes, comma-separated (default: ycbvss's 11-scene split, see ycbvss.io.bcot)")
    m.set_defaults(func=cmd_make)

    r = sub.add_parser("run", help="run a tracker on every subsequence (resumes)")
    r.add_argument("--config", required=True)
    r.add_argument("--tracker", required=True, help=f"{' | '.join(TRACKERS)} | module:Class")
    r.add_argument("--out", required=True, help="results folder (one NNNNN.csv per subsequence)")
    r.add_argument("--dataset", default=None, help="dataset root (default: the one in the config)")
    r.add_argument("--subsequences", default=None, help="only these subsequence ids (comma-separated)")
    r.add_argument("--label", default=None, help="tracker name in tables (default: --tracker)")
    r.set_defaults(func=cmd_run)

    s = sub.add_parser("score", help="score and rank results folders")
    s.add_argument("--config", required=True)
    s.add_argument("--results", required=True, nargs="+", help="results folders (one per tracker)")
    s.add_argument("--out", required=True)
    s.add_argument("--dataset", default=None, help="dataset root (default: the one in the config)")
    s.add_argument("--symmetric", default=None,
                   help="ADD-S set: paper (13 = 024_bowl), bop, posecnn, none or comma-separated obj_ids "
                        "(ycbvss.eval.symmetric_sets; default ycbv: paper, bcot: none)")
    s.add_argument("--adds-all", action="store_true", help="also compute ADD-S for every object (errors CSV)")
    s.add_argument("--no-curves", action="store_true")
    s.add_argument("--no-frame-errors", action="store_true", help="skip errors_<tracker>.csv")
    s.set_defaults(func=cmd_score)


def cmd_make(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..eval.benchmark import ProtocolOptions, load_models, load_sequences, make_protocol, summary_text
    from ..eval.benchmark.sources import detect_layout
    from ..io.atomic import dumps_json, write_text_atomic

    layout = detect_layout(args.dataset)
    if args.protocol == "bcot" and layout != "bcot":
        raise YcbvssError("protocol bcot needs a BCOT root (models/*.obj, <scene>/K.txt)", args.dataset)
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..io.ycbv import parse_videos
    scenes = parse_videos(args.scenes, "--scenes") if args.scenes else None
    bcot_scenes = [x for x in args.bcot_scenes.split(",") if x] if args.bcot_scenes else None
    seqs, info = load_sequences(args.dataset, layout, args.split, scenes, bcot_scenes)
    models = load_models(args.dataset, layout)
    opt = ProtocolOptions(protocol=args.protocol, seed=args.seed, coverage=args.coverage, remove_prob=args.remove_prob,
                          lengths=_ints(args.lengths, "--lengths") if args.lengths else None,
                          steps=_ints(args.steps, "--steps") if args.steps else None,
                          exclude_obj_ids=_ints(args.exclude, "--exclude") if args.exclude else None)
    cfg = make_protocol(seqs, info, opt, models)
    write_text_atomic(args.out, dumps_json(cfg, indent=1))
    print(summary_text(cfg))
    print(f"wrote {args.out}")
    return 0


def _tracker_factory(spec: str, models: dict):
    target = TRACKERS.get(spec, spec)
    if ":" not in target:
        raise YcbvssError(f"unknown tracker {spec!r} (known: {', '.join(TRACKERS)}, or module:Class)")
    mod_name, cls_name = target.split(":", 1)
    try:
        cls = getattr(importlib.import_module(mod_name), cls_name)
    except (ImportError, AttributeError) as e:
        raise YcbvssError(f"cannot import tracker {target!r}: {e}") from None
    return lambda: cls(models)


def cmd_run(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..eval.benchmark import load_models, read_config, run_benchmark

    cfg = read_config(args.config)
    root = Path(args.dataset or cfg["dataset"].get("root", ""))
    models = load_models(root, cfg["dataset"].get("layout", "bop"))
    ids = list(_ints(args.subsequences, "--subsequences")) if args.subsequences else None
    info = run_benchmark(cfg, _tracker_factory(args.tracker, models), args.out, root=root,
                         tracker_name=args.label or args.tracker, models=models, subsequence_ids=ids)
    print(f"{info['done']} subsequence(s) tracked ({info['frames']} frames, {info['seconds']:.1f} s), "
          f"{info['skipped']} already done; results in {args.out}")
    return 0


def cmd_score(args: argparse.Namespace) -> int:
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..eval.benchmark import load_models, load_sequences, read_config, read_result_dir, score_benchmark
    from ..eval.benchmark.report import ranking_markdown, write_report

    cfg = read_config(args.config)
    ds = cfg["dataset"]
    root = Path(args.dataset or ds.get("root", ""))
    layout = ds.get("layout", "bop")
    # lazy: the command's code loads only when it runs (`ycbvss --help` stays fast)
    from ..eval.symmetric_sets import parse_symmetric
    if args.symmetric is None:
        sym, sym_label = ((13,), "paper") if cfg["protocol"] == "ycbv" else ((), "none")
    else:
        sym, sym_label = parse_symmetric(args.symmetric)
    scenes = sorted({int(s["scene_id"]) for s in cfg["subsequences"]})
    seqs, _ = load_sequences(root, layout, ds.get("split") or None, scenes, ds.get("bcot_test_scenes"))
    models = load_models(root, layout)
    results, names_seen = {}, set()
    for d in args.results:
        res, info = read_result_dir(d, cfg)
        name = info["name"]
        if name in names_seen:
            name = f"{name} ({Path(d).name})"
        names_seen.add(name)
        if info["n_missing_files"]:
            print(f"{name}: {info['n_missing_files']} of {len(cfg['subsequences'])} subsequence file(s) missing "
                  f"(their frames count as failures)")
        results[name] = res
    if not results:
        raise YcbvssError("no results folder given")
    t0 = time.perf_counter()
    gti, scores = score_benchmark(cfg, seqs, models, results, sym, args.adds_all)
    dt = time.perf_counter() - t0
    names = {int(k): v for k, v in ds.get("objects", {}).items()}
    names.update({o: m.label for o, m in models.items() if o not in names})
    paths = write_report(scores, gti, cfg, args.out, names,
                         {"symmetric_obj_ids": list(sym), "symmetric_set": sym_label, "adds_all": args.adds_all},
                         curves=not args.no_curves, per_frame=not args.no_frame_errors)
    print(ranking_markdown(scores, names))
    print(f"scored {len(gti)} (frame, object) pairs x {len(scores)} tracker(s) in {dt:.2f} s; "
          f"wrote {', '.join(sorted(paths))} to {args.out}")
    return 0
