"""`ycbvss validate`: the paper's validation loop on data with exact ground truth.

    synthesise YCBV-SS (or take a dataset whose GT is exact)  ->  perturb the GT (calibrated mean
    ADD / PRJ)  ->  bundle pose refinement (all terms + ablations)  ->  evaluate  ->  tables
    (Table 4 / Table 5 layouts), overlays, error curves, one HTML report.

``--real`` refines the original annotations of real frames instead and reports the difference
"original vs refined" (the last row of the paper's Table 4).
"""
from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import math
import multiprocessing as mp
import os
import resource
import sys
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import YcbvssError
from ..io.atomic import read_json, write_json_atomic
from ..progress import progress
from ..refine.bundle import RefineOptions, refine_scene
from ..scene import Scene
from ..synth.run import SynthOptions, run_synth
from . import report as rep
from .datasets import enlarged_model_scales, open_dataset, select_frames
from .perturb import perturb_poses
from .pose_sets import pose_set_errors

VARIANTS = {"using all": {}, "w/o f_edge": {"use_edge": False}, "w/o f_point": {"use_point": False},
            "w/o f_t": {"use_temporal": False}}


@dataclass
class ValidateOptions:
    """Options of :func:`run_validate` (the CLI flags, one to one)."""

    dataset: Path
    out: Path
    split: str | None = None
    scenes: list[int] | None = None
    seed: int = 0
    init_add_mm: float = 22.1
    init_prj_px: float = 5.2
    real: bool = False
    gt_exact: bool = False            # the dataset's GT is exact (rendered): skip YCBV-SS synthesis
    ablation: bool = True
    keyframe_step: int | None = None  # None: automatic (about 8 keyframes per scene)
    max_frames: int | None = None
    frame_step: int = 1
    workers: int | None = None
    samples: int = 8
    overlays: int = 3
    max_iters: int | None = None
    parallel: bool = True             # ablation runs in a second process when there are >= 2 cores
    title: str = "ycbvss validation"
    originals: dict | None = None     # {(scene_id, im_id): path of the original (real) image} for overlays
    extra_info: dict = field(default_factory=dict)
    # RefineOptions fields set for every refinement run (``--options``); an ablation variant's own
    # setting (use_edge, use_point, use_temporal, table_contact) wins over them
    refine_options: dict = field(default_factory=dict)

    def check(self) -> None:
        for name in ("init_add_mm", "init_prj_px"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise YcbvssError(f"--{name.replace('_', '-')} must be a positive number, got {v}")
        if self.keyframe_step is not None and self.keyframe_step < 1:
            raise YcbvssError(f"--keyframe-step must be >= 1, got {self.keyframe_step}")
        if self.max_frames is not None and self.max_frames < 2:
            raise YcbvssError(f"--max-frames must be >= 2 (a bundle needs several views), got {self.max_frames}")
        if self.frame_step < 1:
            raise YcbvssError(f"--frame-step must be >= 1, got {self.frame_step}")
        if self.overlays < 0:
            raise YcbvssError(f"--overlays must be >= 0, got {self.overlays}")


class Stages:
    """Named stages with wall-clock timings; prints one line per stage start to stderr."""

    def __init__(self, quiet: bool = False):
        self.times: dict[str, float] = {}
        self.cpu: dict[str, tuple[float, float]] = {}   # stage -> (CPU s of this process, of child processes)
        self.quiet = quiet
        self.t0 = time.perf_counter()

    @staticmethod
    def _cpu() -> tuple[float, float]:
        a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
        return a.ru_utime + a.ru_stime, b.ru_utime + b.ru_stime

    @contextmanager
    def stage(self, name: str):
        if not self.quiet:
            print(f"ycbvss: == {name} ==", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        c0 = self._cpu()
        try:
            yield
        finally:
            self.times[name] = self.times.get(name, 0.0) + time.perf_counter() - t0
            c1 = self._cpu()
            prev = self.cpu.get(name, (0.0, 0.0))
            self.cpu[name] = (prev[0] + c1[0] - c0[0], prev[1] + c1[1] - c0[1])

    @property
    def total_s(self) -> float:
        return time.perf_counter() - self.t0


# ----------------------------------------------------------------------------- refinement
def auto_keyframe_step(n_frames: int, target_keyframes: int = 8) -> int:
    return max(1, int(round(n_frames / target_keyframes)))


def keyframe_scene(sc: Scene, step: int) -> Scene:
    """The keyframes of a scene (every ``step``-th frame, as the refiner picks them)."""
    return Scene(sc.scene_id, sc.frames[::max(1, step)], sc.root)


def _refine_job(vname: str, sc: Scene, models: dict, init: dict, kw: dict, opts: "ValidateOptions") -> tuple:
    """One refinement run (a variant on a scene); returns (variant, scene_id, poses, stats, marks) with
    marks {(scene, im, obj): (status, confidence, reason)}, the refiner's own (its covariance is
    computed, so the status rule reads the pose's sigma as ``ycbvss refine`` does)."""
    step = opts.keyframe_step or auto_keyframe_step(len(sc.frames))
    run_sc = sc if vname == "using all" else keyframe_scene(sc, step)
    run_step = step if vname == "using all" else 1
    kw = {**opts.refine_options, **kw}
    if opts.max_iters:
        kw["max_iters"] = int(opts.max_iters)
    ro = RefineOptions(keyframe_step=run_step if run_step > 1 else 0, seed=opts.seed, **kw)
    ims = {f.im_id for f in run_sc.frames}
    sc_init = {(k[1], k[2]): T for k, T in init.items() if k[0] == sc.scene_id and k[1] in ims}
    t0 = time.perf_counter()
    res = refine_scene(run_sc, models, sc_init, ro)
    poses = {(sc.scene_id, im, oid): np.asarray(T, np.float64) for (im, oid), T in res.poses.items()}
    marks = {(sc.scene_id, im, oid): (res.status.get((im, oid), "failed"), float(res.confidence.get((im, oid), 0.0)),
                                      res.reasons.get((im, oid), "")) for (im, oid) in res.poses}
    return vname, sc.scene_id, poses, {"time_s": time.perf_counter() - t0, "converged": bool(res.converged),
                                       "keyframe_step": step, "n_frames": len(run_sc.frames)}, marks


def _refine_jobs_child(jobs: list, models: dict, init: dict, opts: "ValidateOptions") -> list:
    """Worker-process entry: run several refinement jobs sequentially (no progress bars)."""
    os.environ["YCBVSS_NO_PROGRESS"] = "1"
    return [_refine_job(v, sc, models, init, kw, opts) for v, sc, kw in jobs]


def _portable_models(models: dict) -> dict | None:
    """Copies of the models without loaded meshes (cheap to send to a process); None if a model
    only exists in memory."""
    if any(m.path is None for m in models.values()):
        return None
    return {o: dataclasses.replace(m, _mesh=None) for o, m in models.items()}


def refine_all(scenes: list[Scene], models: dict, init: dict, variants: dict, opts: ValidateOptions) -> dict:
    """Run the refiner for every variant on every scene. Returns {variant: {(scene, im, obj): 4x4}}
    plus ``"_stats"``: {variant: {scene_id: stats}} and ``"_marks"``: {variant: {(scene, im, obj):
    (status, confidence, reason)}}.

    "using all" runs on all frames (keyframes jointly, the other frames camera-only); the ablation
    variants run on the keyframes only (the joint stage, which is where the terms matter) -- their
    poses therefore exist for the keyframes only. With several cores the ablation runs go to a
    second process while this one runs "using all" (the refiner is mostly single-threaded)."""
    out: dict = {v: {} for v in variants}
    stats: dict = {v: {} for v in variants}
    marks: dict = {v: {} for v in variants}
    main_jobs = [("using all", sc, variants["using all"]) for sc in scenes if "using all" in variants]
    side_jobs = [(v, sc, variants[v]) for v in variants if v != "using all" for sc in scenes]
    bar = progress(total=len(main_jobs) + len(side_jobs), desc="refine", unit="run")
    fut = pool = None
    # a second process pays ~5 s of start-up (imports, GL context): only worth it for bigger runs
    big = sum(len(sc.frames) for sc in scenes) >= 12
    portable = (_portable_models(models) if side_jobs and big and (os.cpu_count() or 1) >= 2 and opts.parallel
                else None)
    if portable is not None:
        pool = cf.ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("spawn"))
        fut = pool.submit(_refine_jobs_child, side_jobs, portable, init, opts)
        bar.set_postfix_str(f"{len(side_jobs)} ablation run(s) in a second process")
    try:
        for vname, sc, kw in (main_jobs if fut is not None else main_jobs + side_jobs):
            bar.set_postfix_str(f"{vname}, scene {sc.scene_id}" + (" (+ ablations in parallel)" if fut else ""))
            v, sid, poses, st, mk = _refine_job(vname, sc, models, init, kw, opts)
            out[v].update(poses)
            stats[v][sid] = st
            marks[v].update(mk)
            bar.update(1)
        if fut is not None:
            bar.set_postfix_str("waiting for the ablation runs")
            for v, sid, poses, st, mk in fut.result():
                out[v].update(poses)
                stats[v][sid] = st
                marks[v].update(mk)
                bar.update(1)
    finally:
        bar.close()
        if pool is not None:
            pool.shutdown(wait=True, cancel_futures=True)
    out["_stats"] = stats
    out["_marks"] = marks
    return out


# ----------------------------------------------------------------------------- main loop
def _gt_of(scenes: list[Scene]) -> tuple[dict, dict]:
    gt, Ks = {}, {}
    for sc in scenes:
        for f in sc.frames:
            for inst in f.instances:
                k = (sc.scene_id, f.im_id, inst.obj_id)
                if k in gt:
                    raise YcbvssError(f"object {inst.obj_id} annotated twice (multiple instances of one object "
                                      "are not supported by the bundle refiner)", where=f.where)
                gt[k] = np.asarray(inst.T_m2c, np.float64)
                Ks[k] = f.camera.K
    return gt, Ks


def _synthesise(opts: ValidateOptions, stages: Stages, split: str) -> tuple[Path, str]:
    """YCBV-SS from the given real frames into <out>/ycbvss; returns (BOP root, split)."""
    ds_root = Path(opts.dataset)
    out = Path(opts.out) / "ycbvss"
    so = SynthOptions(seed=opts.seed, samples=opts.samples, workers=opts.workers,
                      max_frames=None if opts.frame_step > 1 else opts.max_frames)
    if opts.frame_step > 1 or opts.max_frames:
        # synthesise only the frames the refinement will use
        ds, _, _ = open_dataset(ds_root, opts.split, opts.scenes)
        ims = sorted({f.im_id for sc in ds.iter_scenes() for f in select_frames(sc, opts.max_frames, opts.frame_step).frames})
        so.frames, so.max_frames = ims, None
    with stages.stage("synthesise YCBV-SS (Blender)"):
        run_synth(ds_root, split, out, scenes=opts.scenes, opts=so)
    return out, split


def run_validate(opts: ValidateOptions, stages: Stages | None = None) -> dict:
    """The whole loop; returns the summary dict (also written as ``<out>/summary.json``)."""
    opts.check()
    stages = stages or Stages()
    out = Path(opts.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise YcbvssError(f"cannot create output folder: {e.strerror}", out) from None
    originals = dict(opts.originals or {})
    src_layout = None
    if opts.real:
        with stages.stage("load dataset"):
            ds, src_layout, split = open_dataset(opts.dataset, opts.split, opts.scenes)
            scenes = [select_frames(sc, opts.max_frames, opts.frame_step) for sc in ds.iter_scenes()]
        return _run_real(opts, ds, scenes, stages)
    if opts.gt_exact:
        root, split = Path(opts.dataset), opts.split
    else:
        with stages.stage("load dataset"):
            src, src_layout, src_split = open_dataset(opts.dataset, opts.split, opts.scenes)
            for sc in src.iter_scenes():
                for f in select_frames(sc, opts.max_frames, opts.frame_step).frames:
                    originals[(sc.scene_id, f.im_id)] = f.rgb_path
        root, split = _synthesise(opts, stages, src_split)
    with stages.stage("load dataset"):
        ds, _, split = open_dataset(root, split, opts.scenes)
        scenes = [select_frames(sc, opts.max_frames, opts.frame_step) for sc in ds.iter_scenes()]
        scenes = [sc for sc in scenes if len(sc.frames) >= 2]
        if not scenes:
            raise YcbvssError("no scene with >= 2 annotated frames", root)
        gt, Ks = _gt_of(scenes)
        models = ds.models
        missing = sorted({k[-1] for k in gt} - set(models))
        if missing:
            raise YcbvssError(f"objects {missing} have no model", Path(root) / "models")
    with stages.stage("perturb ground truth"):
        pts = {o: (models[o].vertices_mm if models[o].path is not None else np.asarray(models[o].mesh.vertices))
               for o in {k[-1] for k in gt}}
        pr = perturb_poses(gt, Ks, pts, opts.init_add_mm, opts.init_prj_px, seed=opts.seed)
        print("ycbvss: " + pr.summary(), file=sys.stderr)
    variants = dict(VARIANTS) if opts.ablation else {"using all": {}}
    if enlarged_model_scales(root):     # YCBV-SS: enlarged models, so no table contact (see there)
        variants = {k: {**v, "table_contact": False, "support_check": False} for k, v in variants.items()}
    with stages.stage("bundle pose refinement" + (" + ablations" if opts.ablation else "")):
        refined = refine_all(scenes, models, pr.poses, variants, opts)
    with stages.stage("evaluate"):
        errs = {"initial": pose_set_errors(pr.poses, gt, Ks, models),
                "using all": pose_set_errors(refined["using all"], gt, Ks, models)}
        errs_kf = {}
        if opts.ablation:   # Table 5: every variant on the keyframes (where the ablation runs were made)
            kf = {(sc.scene_id, f.im_id) for sc in scenes
                  for f in keyframe_scene(sc, opts.keyframe_step or auto_keyframe_step(len(sc.frames))).frames}
            gt_kf = {k: T for k, T in gt.items() if k[:2] in kf}
            errs_kf = {v: pose_set_errors(refined[v], gt_kf, Ks, models) for v in variants}
            errs_kf["initial"] = pose_set_errors(pr.poses, gt_kf, Ks, models)
    with stages.stage("tables, figures, report"):
        summary = rep.write_validation_outputs(out, opts, scenes, models, gt, Ks, pr, refined, errs, stages,
                                               originals, src_layout, errs_kf)
    _finish(summary, stages)
    return summary


def _finish(summary: dict, stages: Stages) -> None:
    """Record the final timings (incl. the report stage) in summary.json."""
    p = Path(summary["out"]) / "summary.json"
    data = read_json(p)
    data["timings_s"] = dict(stages.times)
    data["total_s"] = stages.total_s
    write_json_atomic(p, data)
    summary["timings_s"] = dict(stages.times)


def _run_real(opts: ValidateOptions, ds, scenes: list[Scene], stages: Stages) -> dict:
    """Refine the original annotations of real frames; write the original-vs-refined difference table."""
    scenes = [sc for sc in scenes if len(sc.frames) >= 2]
    if not scenes:
        raise YcbvssError("no scene with >= 2 annotated frames", opts.dataset)
    orig, Ks = _gt_of(scenes)
    models = ds.models
    with stages.stage("bundle pose refinement"):
        refined = refine_all(scenes, models, orig, {"using all": {}}, opts)
    with stages.stage("evaluate"):
        diff = pose_set_errors(orig, refined["using all"], Ks, models)   # original measured against refined
    with stages.stage("tables, figures, report"):
        summary = rep.write_real_outputs(Path(opts.out), opts, scenes, models, orig, Ks, refined, diff, stages)
    _finish(summary, stages)
    return summary
