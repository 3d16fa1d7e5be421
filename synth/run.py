"""``ycbvss synth``: build YCBV-SS (a BOP dataset) from real YCB-V frames.

Stages: (1) open the input (YCB-Video layout or BOP split) and the poses (scene_gt or a refined
BOP19 CSV); (2) per object, the smallest model scale on the grid covering >= 99.5 % of its original
visible pixels; (3) write the enlarged models; (4) per scene, synthesise the frames that are not done
yet (Blender workers, local or Ray), then assemble the scene JSONs from the frames' done markers;
(5) write ``synth_report.json``. Streams scene by scene; every output is written atomically.
"""
from __future__ import annotations

import hashlib
import json
import sys
import warnings
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

from .. import __version__
from ..errors import YcbvssError
from ..geometry.model_frame import bbox_center, recentre_pose
from ..io.atomic import read_json, write_json_atomic, write_text_atomic
from ..io.bop_dataset import targets_filename, write_camera_files, write_models_eval, write_targets
from ..io.provenance import host_record
from ..io.results import read_bop19_csv
from ..progress import progress
from .coverage import SCALE_GRID, TARGET, choose_scale
from .executors import COVERAGE_FUNC, make_executor
from .frame import marker_path
from .frame_files import clean_temporaries
from .inputs import open_input
from .models import centred_mesh, write_dilated_models, write_original_models
from .noise import NoiseParams

STATE_DIR = ".synth_state"


@dataclass
class SynthOptions:
    """All knobs of a run (everything that changes the output is recorded in the report)."""

    seed: int = 0
    samples: int = 4
    denoise: bool = False
    max_bounces: int = 1
    lights: list | None = None
    world_strength: float | None = None
    noise: NoiseParams = field(default_factory=NoiseParams)
    colour_fit: bool = True
    colour_fit_method: str = "adaptive"    # "adaptive" (ridge ladder), "lsq" or "mk" (mean/covariance transfer)
    clear_px: int = 4                      # in-paint real objects (+ this margin) before compositing; 0 = off
    scale_grid: tuple = SCALE_GRID
    coverage_target: float = TARGET
    coverage_stride: int = 1
    scales: dict | None = None            # obj_id -> scale: skip the coverage search (e.g. tests)
    frames: list | None = None            # restrict to these im_ids (every scene)
    max_frames: int | None = None         # per scene, first N frames (after ``frames``)
    workers: int | None = None
    executor: str = "local"
    address: str | None = None
    chunk: int = 8

    def render_settings(self) -> dict:
        r = {"samples": self.samples, "denoise": self.denoise, "max_bounces": self.max_bounces}
        if self.lights is not None:
            r["lights"] = self.lights
        if self.world_strength is not None:
            r["world_strength"] = self.world_strength
        return r


# ------------------------------------------------------------------------------ input
def load_pose_overrides(path: str | Path | None, obj_ids) -> dict:
    """(scene_id, im_id, obj_id) -> T_m2c (mm, recentred BOP model frame) from a BOP19 CSV (best score)."""
    if path is None:
        return {}
    best: dict = {}
    for e in read_bop19_csv(path, obj_ids):
        k = (e.scene_id, e.im_id, e.obj_id)
        if k not in best or e.score > best[k][0]:
            best[k] = (e.score, e.T_m2c)
    return {k: v[1] for k, v in best.items()}


def _select_frames(scene, opts: SynthOptions) -> list:
    frames = scene.frames
    if opts.frames is not None:
        want = set(int(i) for i in opts.frames)
        frames = [f for f in frames if f.im_id in want]
    if opts.max_frames is not None:
        frames = frames[: int(opts.max_frames)]
    return frames


def frame_task(frame, layout: str, centres: dict, overrides: dict) -> dict:
    """The JSON task of one frame (paths, K, recentred poses) for the worker."""
    objs = []
    for k, inst in enumerate(frame.instances):
        key = (frame.scene_id, frame.im_id, inst.obj_id)
        T = overrides.get(key)
        T = np.asarray(T, np.float64) if T is not None else recentre_pose(inst.T_m2c, centres[inst.obj_id])
        gt_idx = inst.gt_id if inst.gt_id is not None else k
        ob = {"obj_id": int(inst.obj_id), "T_m2c": T.tolist(), "gt_idx": int(gt_idx)}
        if layout == "bop" and frame.rgb_path is not None:
            ob["mask_visib_path"] = str(Path(frame.rgb_path).parent.parent / "mask_visib"
                                        / f"{frame.im_id:06d}_{gt_idx:06d}.png")
        objs.append(ob)
    return {"scene_id": int(frame.scene_id), "im_id": int(frame.im_id), "rgb_path": str(frame.rgb_path),
            "depth_path": None if frame.depth_path is None else str(frame.depth_path),
            "label_path": None if frame.label_path is None else str(frame.label_path),
            "K": frame.camera.K.tolist(), "depth_scale": float(frame.depth_scale),
            "width": frame.camera.width, "height": frame.camera.height, "objects": objs}


# ------------------------------------------------------------------------------ coverage
def compute_coverage(ds, layout: str, scene_loader, overrides: dict, opts: SynthOptions, ex) -> tuple[dict, dict]:
    """One streaming pass over the selected frames (in the executor's workers): the objects present, their model
    centres, and per object the visible pixel total and covered counts at scale 1.0 and each grid scale.
    Returns (coverage, centres)."""
    scales = (1.0,) + tuple(opts.scale_grid)
    acc: dict = {}
    centres: dict = {}
    model_warnings: list = []
    cfg = {"scales": list(scales), "coverage_meshes": {}}
    for sid in ds.scene_ids:
        scene, _ = scene_loader(sid)
        frames = _select_frames(scene, opts)
        for oid in sorted({i.obj_id for f in frames for i in f.instances} - set(centres)):
            if oid not in ds.models:
                raise YcbvssError(f"object {oid}: no model", ds.root / "models")
            m = ds.models[oid]
            centres[oid] = bbox_center(m.vertices_mm)
            with warnings.catch_warnings(record=True) as caught:   # e.g. texture missing -> grey model
                warnings.simplefilter("always")
                centred_mesh(m, centres[oid])
            for w in caught:
                model_warnings.append(str(w.message))
                print(f"ycbvss synth: warning: {w.message}", file=sys.stderr)
            cfg["coverage_meshes"][f"cov_obj_{oid:06d}"] = {"path": str(m.path), "unit_scale": float(m.unit_scale),
                                                            "centre_mm": centres[oid].tolist()}
            acc[oid] = {"total": 0, "covered": np.zeros(len(scales), np.int64)}
        tasks = [frame_task(f, layout, centres, overrides) for f in frames[:: max(1, int(opts.coverage_stride))]]
        bar = progress(total=len(tasks), desc=f"coverage scene {sid}", unit="frame")

        def add(res):
            bar.update(1)
            for oid, total, cov in res["objects"]:
                acc[oid]["total"] += int(total)
                acc[oid]["covered"] += np.asarray(cov, np.int64)
        try:
            ex.map(cfg, tasks, add, func=COVERAGE_FUNC)
        finally:
            bar.close()
    out = {}
    for oid, a in sorted(acc.items()):
        tot = max(a["total"], 1)
        out[oid] = {"visible_px": a["total"], "coverage_by_scale": {f"{s:g}": round(float(c) / tot, 6)
                                                                  for s, c in zip(scales, a["covered"])},
                    "covered": a["covered"].tolist(), "warnings": [w for w in model_warnings if f"{oid:06d}" in w
                                                                or ds.models[oid].name in w]}
    return out, centres


# ------------------------------------------------------------------------------ scene JSONs / report
def assemble_scene(split_dir: Path, scene_id: int) -> dict:
    """Write scene_gt/scene_camera/scene_gt_info.json from the scene's done markers; returns the markers."""
    sdir = split_dir / f"{scene_id:06d}"
    markers = {}
    done = sdir / ".done"
    for p in sorted(done.glob("[0-9]*.json")) if done.is_dir() else []:
        m = read_json(p, "frame done marker")
        markers[int(m["im_id"])] = m
    ok = {i: m for i, m in sorted(markers.items()) if not m.get("skipped")}
    write_json_atomic(sdir / "scene_gt.json", {str(i): m["scene_gt"] for i, m in ok.items()})
    write_json_atomic(sdir / "scene_camera.json", {str(i): m["scene_camera"] for i, m in ok.items()})
    write_json_atomic(sdir / "scene_gt_info.json", {str(i): m["gt_info"] for i, m in ok.items()})
    return markers


def _versions() -> dict:
    try:
        bpy_v = version("bpy")
    except PackageNotFoundError:
        bpy_v = "unknown"
    return {"ycbvss": __version__, "blender_bpy": bpy_v}


def _fingerprint(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:16]


class ReportAccumulator:
    """Per-object colour/dE statistics and skipped frames, reduced scene by scene (never all markers at once)."""

    def __init__(self):
        self.obj: dict = {}
        self.skipped: list = []
        self.warnings: set = set()
        self.n_done = 0

    def add(self, m: dict) -> None:
        self.warnings.update(m.get("warnings", []))
        if m.get("skipped"):
            self.skipped.append({"scene_id": m["scene_id"], "im_id": m["im_id"], "reason": m["skipped"]})
            return
        self.n_done += 1
        for ob in m.get("objects", []):
            d = self.obj.setdefault(ob["obj_id"], {"n_instances": 0, "n_fit": 0, "dE_before": 0.0, "dE_after": 0.0,
                                                   "dE_final": 0.0, "M": np.zeros((3, 3)), "b": np.zeros(3),
                                                   "methods": {}})
            d["n_instances"] += 1
            if ob.get("dE_before") is None:
                continue
            d["n_fit"] += 1
            for k in ("dE_before", "dE_after", "dE_final"):
                d[k] += ob[k]
            d["M"] += np.asarray(ob["M"])
            d["b"] += np.asarray(ob["b"])
            d["methods"][ob.get("method", "?")] = d["methods"].get(ob.get("method", "?"), 0) + 1

    def objects(self, models_state: dict, names: dict) -> dict:
        out = {}
        for oid, st in sorted(models_state["objects"].items(), key=lambda kv: int(kv[0])):
            oid = int(oid)
            e = {"name": names.get(oid, ""), **st}
            d = self.obj.get(oid)
            if d and d["n_fit"]:
                n = d["n_fit"]
                e.update(n_instances=d["n_instances"], n_colour_fits=n,
                         dE_before=round(d["dE_before"] / n, 4), dE_after=round(d["dE_after"] / n, 4),
                         dE_final=round(d["dE_final"] / n, 4),
                         colour_fit_improved=bool(d["dE_after"] < d["dE_before"]),
                         colour_fit_mean={"M": np.round(d["M"] / n, 5).tolist(), "b": np.round(d["b"] / n, 5).tolist()},
                         colour_fit_methods=dict(sorted(d["methods"].items())))
            out[str(oid)] = e
        return out


def build_report(inputs: dict, opts: SynthOptions, models_state: dict, acc: ReportAccumulator, names: dict) -> dict:
    return {
        "versions": _versions(),
        "input": inputs,
        "seed": opts.seed,
        "seeds": {"cycles": "sha256('{seed}/cycles/{scene_id}/{im_id}')[:4] & 0x7fffffff",
                  "noise": "numpy.random.default_rng([seed, scene_id, im_id])"},
        "render": {"engine": "CYCLES", "device": "CPU", **opts.render_settings()},
        "noise": opts.noise.to_dict(),
        "colour_fit": {"enabled": opts.colour_fit, "method": opts.colour_fit_method,
                       "model": "linear RGB: M (3x3) @ render + b, fitted on the object's eroded visible pixels; "
                                "adaptive = ridge towards a per-channel gain, the most regularised fit "
                                "(lambda in 1, .3, .1, .03, .01, 0) reaching half the dE reduction of plain "
                                "least squares"},
        "clear_px": opts.clear_px,
        "scale_grid": list(opts.scale_grid),
        "coverage_target": opts.coverage_target,
        "coverage_stride": opts.coverage_stride,
        "objects": acc.objects(models_state, names),
        "frames": {"done": acc.n_done, "skipped": acc.skipped},
        "warnings": sorted(acc.warnings),
    }


def dataset_info_md(split: str, scales: dict, models: dict) -> str:
    """dataset_info.md of a YCBV-SS root: which models are dilated and which the GT refers to."""
    rows = "\n".join(f"| {o} | {models[o].name} | {scales.get(o, 1.0):g} | "
                      f"{'yes' if scales.get(o, 1.0) != 1.0 else 'no (not rendered)' if o not in scales else 'no'} |"
                      for o in sorted(models))
    return (f"# YCBV-SS (semi-synthetic YCB-Video), written by ycbvss {__version__} (`ycbvss synth`)\n\n"
            f"Split `{split}`, targets `{targets_filename(split)}`. Real YCB-V frames with every annotated object "
            "re-rendered by Blender at the GT poses of `scene_gt.json` (see `synth_report.json`).\n\n"
            "**The GT refers to the DILATED models in `models/`** (what was rendered): each rendered model is the "
            "input model recentred on its bounding-box centre and enlarged about it by the scale below so that it "
            "covers the original object. `models_original/` holds the same models unscaled in the same frame; "
            "evaluate against them with `ycbvss eval --models-subdir models_original` (bop_toolkit: point "
            "`models`/`models_eval` to copies of them). `models_eval/` is `models/` uniformly remeshed.\n\n"
            "| obj_id | name | scale | dilated |\n|---|---|---|---|\n" + rows + "\n\n"
            "scene_gt_info.json, mask/, mask_visib/: bop_toolkit calc_gt_info rules (delta 15 mm against the "
            "written synthetic depth, missing depth visible, 3x canvas, bbox w = x_max - x_min).\n")


def write_dataset_files(out: Path, split: str, scales: dict, models: dict) -> None:
    """Camera files, the split's targets, models_eval/ and dataset_info.md (see ycbvss.io.bop_dataset)."""
    write_camera_files(out)
    write_targets(out, split)
    write_models_eval(out, show_progress=False)
    write_text_atomic(out / "dataset_info.md", dataset_info_md(split, scales, models))
    if len(models) < 21:
        warnings.warn(f"the input has models of {len(models)} objects only (YCB-V has 21): the output holds "
                      "those", stacklevel=2)


# ------------------------------------------------------------------------------ main entry
def run_synth(dataset: str | Path, split: str, out: str | Path, scenes: list[int] | None = None,
              poses: str | Path | None = None, opts: SynthOptions | None = None, executor=None) -> dict:
    """Synthesise YCBV-SS into the BOP root ``out`` (resumable); returns the report dict.

    ``executor``: a :class:`~ycbvss.synth.executors.LocalExecutor` / ``RayExecutor`` to use (not closed here);
    default: one made from ``opts`` (closed at the end)."""
    opts = opts or SynthOptions()
    out = Path(out)
    ds, layout, scene_loader = open_input(dataset, split, scenes)     # input errors before --out is created
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise YcbvssError(f"output folder not writable: {e.strerror}", out) from None
    own_exec = executor is None
    ex = executor or make_executor(opts.executor, opts.workers, opts.address, opts.chunk)
    try:
        return _run(ds, layout, scene_loader, dataset, split, out, poses, opts, ex)
    finally:
        if own_exec:
            ex.close()


def _run(ds, layout, scene_loader, dataset, split, out: Path, poses, opts: SynthOptions, ex) -> dict:
    """The stages of :func:`run_synth` once the input is open: per-object coverage and scales (cached),
    the models, every selected frame (resumable), then ``synth_report.json`` and the dataset files.
    Returns the report (plus ``_timing``: summed worker seconds per stage and the frame count)."""
    split_dir = out / split
    clean_temporaries(out)
    overrides = load_pose_overrides(poses, ds.models.keys())
    inputs = {"dataset": str(Path(dataset).resolve()), "layout": layout, "split": split,
              "scenes": ds.scene_ids, "poses": None if poses is None else str(Path(poses).resolve()),
              "frames": opts.frames, "max_frames": opts.max_frames}
    state_dir = out / STATE_DIR
    coverage, centres = _cached_coverage(ds, layout, scene_loader, overrides, opts, ex, inputs, state_dir)
    obj_ids = sorted(coverage)
    if not obj_ids:
        raise YcbvssError("no annotated objects in the selected frames", ds.root)
    settings = {"seed": int(opts.seed), "render": opts.render_settings(), "noise": opts.noise.to_dict(),
                "colour_fit": [opts.colour_fit, opts.colour_fit_method], "clear_px": opts.clear_px,
                "layout": layout, "split": split,
                "dataset": inputs["dataset"], "poses": inputs["poses"]}
    prev_scales, prev_centres = _previous_run(state_dir / "run.json", settings, centres, obj_ids, out)
    scales, models_state = _choose_scales(obj_ids, coverage, centres, prev_scales, opts, out)
    all_scales = {**prev_scales, **scales}
    all_centres = {**prev_centres, **centres}
    _write_models(out, ds.models, state_dir, all_scales, all_centres)
    write_json_atomic(state_dir / "run.json", {
        "settings": settings, "scales": {str(k): v for k, v in sorted(all_scales.items())},
        "centres_mm": {str(k): np.asarray(c).tolist() for k, c in sorted(all_centres.items())}})
    config = _frame_config(split_dir, opts, out / "models", obj_ids)
    acc = ReportAccumulator()
    timing = {"render_s": 0.0, "composite_s": 0.0, "gt_s": 0.0, "total_s": 0.0, "n": 0}
    for sid in ds.scene_ids:
        _synth_scene(sid, scene_loader, split_dir, (layout, centres, overrides), opts, ex, config, acc, timing)
    report = build_report(inputs, opts, models_state, acc, {o: ds.models[o].name for o in obj_ids})
    # the host that wrote the report (a resumed synthesis may have rendered earlier frames on another):
    # Cycles' images can differ between hosts (ycbvss.io.provenance)
    report["host"] = host_record()
    write_json_atomic(out / "synth_report.json", report)
    write_dataset_files(out, split, all_scales, ds.models)
    _print_timing(timing)
    report["_timing"] = timing
    return report


def _cached_coverage(ds, layout, scene_loader, overrides, opts: SynthOptions, ex, inputs: dict,
                     state_dir: Path) -> tuple[dict, dict]:
    """(coverage per obj_id, bbox centre (3,) mm per obj_id): read from the state folder when these
    inputs were measured before, else :func:`compute_coverage` and cache them."""
    cov_key = _fingerprint([inputs, list(opts.scale_grid), opts.coverage_stride])
    cov_file = state_dir / f"coverage_{cov_key}.json"
    if cov_file.is_file():
        st = read_json(cov_file)
        coverage = {int(k): v for k, v in st["coverage"].items()}
        centres = {int(k): np.asarray(v) for k, v in st["centres_mm"].items()}
        return coverage, centres
    coverage, centres = compute_coverage(ds, layout, scene_loader, overrides, opts, ex)
    write_json_atomic(cov_file, {"coverage": {str(k): v for k, v in coverage.items()},
                                 "centres_mm": {str(k): v.tolist() for k, v in centres.items()}})
    return coverage, centres


def _previous_run(run_file: Path, settings: dict, centres: dict, obj_ids: list, out: Path) -> tuple[dict, dict]:
    """An existing output fixes its settings and models: resume/extend only with the same ones.
    Returns its (scales {obj_id: float}, centres {obj_id: (3,) mm}), empty for a new output."""
    prev = read_json(run_file, "synth run state") if run_file.is_file() else None
    if prev is not None and json.loads(json.dumps(settings)) != prev["settings"]:
        diff = sorted(k for k in settings if json.loads(json.dumps(settings[k])) != prev["settings"].get(k))
        raise YcbvssError(f"output was synthesised with different settings ({', '.join(diff)}); "
                          "use a new --out or delete it", out)
    prev_scales = {int(k): float(v) for k, v in (prev or {}).get("scales", {}).items()}
    prev_centres = {int(k): np.asarray(v) for k, v in (prev or {}).get("centres_mm", {}).items()}
    for oid in obj_ids:
        if oid in prev_centres and np.abs(prev_centres[oid] - centres[oid]).max() > 1e-6:
            raise YcbvssError(f"object {oid}: model differs from the one this output was made with", out)
    return prev_scales, prev_centres


def _choose_scales(obj_ids: list, coverage: dict, centres: dict, prev_scales: dict, opts: SynthOptions,
                   out: Path) -> tuple[dict, dict]:
    """The dilation scale of every object (given by --scales or the previous run, else the smallest
    of the grid reaching the coverage target) and the per-object report entries ("objects")."""
    models_state = {"objects": {}}
    scales = {}
    for oid in obj_ids:
        c = coverage[oid]
        fixed = dict(opts.scales or {})
        if oid in prev_scales:
            if oid in fixed and abs(fixed[oid] - prev_scales[oid]) > 1e-12:
                raise YcbvssError(f"object {oid}: --scales {fixed[oid]} differs from the scale {prev_scales[oid]} "
                                  "this output was made with", out)
            fixed[oid] = prev_scales[oid]
        if oid in fixed:
            s = float(fixed[oid])
            cov_after = c["coverage_by_scale"].get(f"{s:g}")
            flagged = cov_after is not None and cov_after < opts.coverage_target
        else:
            s, cov_after, flagged = choose_scale(np.asarray(c["covered"][1:]), c["visible_px"],
                                                 tuple(opts.scale_grid), opts.coverage_target)
        if flagged:
            warnings.warn(f"object {oid}: coverage {cov_after:.4f} < {opts.coverage_target} even at scale {s}",
                          stacklevel=3)
        scales[oid] = s
        models_state["objects"][oid] = {
            "scale": s, "centre_mm": np.round(centres[oid], 6).tolist(), "visible_px": c["visible_px"],
            "coverage_before": c["coverage_by_scale"]["1"],
            "coverage_after": None if cov_after is None else round(float(cov_after), 6),
            "coverage_by_scale": c["coverage_by_scale"], "flagged": bool(flagged),
            "model_warnings": c.get("warnings", [])}
    return scales, models_state


def _write_models(out: Path, models: dict, state_dir: Path, all_scales: dict, all_centres: dict) -> None:
    """models/ (dilated) and models_original/, unless written already for these scales and centres:
    every model of the input, the rendered objects enlarged, the others at scale 1 (never rendered)."""
    models_dir = out / "models"
    mkey = _fingerprint([{str(k): v for k, v in sorted(all_scales.items())},
                         {str(k): np.asarray(c).tolist() for k, c in sorted(all_centres.items())}])
    mstate = state_dir / f"models_{mkey}.done"
    if mstate.is_file() and (models_dir / "models_info.json").is_file():
        return
    others = {o: bbox_center(models[o].vertices_mm) for o in sorted(set(models) - set(all_scales))}
    write_dilated_models(models_dir, models, {**others, **all_centres}, {**{o: 1.0 for o in others}, **all_scales})
    write_original_models(out / "models_original", models, {**others, **all_centres})
    write_json_atomic(mstate, {"scales": {str(k): v for k, v in sorted(all_scales.items())}})


def _frame_config(split_dir: Path, opts: SynthOptions, models_dir: Path, obj_ids: list) -> dict:
    """The per-run part of every frame task (what the workers need besides the frame)."""
    return {"split_dir": str(split_dir), "seed": int(opts.seed), "render": opts.render_settings(),
            "noise": opts.noise.to_dict(), "colour_fit": opts.colour_fit,
            "colour_fit_method": opts.colour_fit_method, "clear_px": int(opts.clear_px),
            "meshes": {f"obj_{o:06d}": {"path": str((models_dir / f"obj_{o:06d}.ply").resolve())}
                       for o in obj_ids}}


def _synth_scene(sid: int, scene_loader, split_dir: Path, frame_inputs: tuple, opts: SynthOptions, ex,
                 config: dict, acc: ReportAccumulator, timing: dict) -> None:
    """Synthesise the selected frames of scene ``sid`` not done yet (``frame_inputs`` = (layout,
    centres, pose overrides)), then assemble its scene files and add its frame markers to ``acc``.
    Frames the loader skipped get a "skipped" marker; ``timing`` sums the workers' seconds."""
    layout, centres, overrides = frame_inputs
    scene, load_skipped = scene_loader(sid)
    frames = _select_frames(scene, opts)
    for im_id, reason in load_skipped:
        if opts.frames is not None and im_id not in set(opts.frames):
            continue
        mp = marker_path(split_dir, sid, im_id)
        if not mp.is_file():
            print(f"ycbvss synth: warning: scene {sid} frame {im_id} skipped: {reason}", file=sys.stderr)
            write_json_atomic(mp, {"scene_id": sid, "im_id": im_id, "skipped": reason, "warnings": []})
    todo = [frame_task(f, layout, centres, overrides) for f in frames
            if not marker_path(split_dir, sid, f.im_id).is_file()]
    bar = progress(total=len(frames), desc=f"synth scene {sid}", unit="frame", initial=len(frames) - len(todo))
    try:
        ex.map(config, todo, lambda r: _on_frame_result(r, bar, timing))
    finally:
        bar.close()
    markers = assemble_scene(split_dir, sid)
    want = {f.im_id for f in frames} | {i for i, _ in load_skipped}
    for i, m in sorted(markers.items()):
        if i in want:
            acc.add(m)


def _on_frame_result(r: dict, bar, timing: dict) -> None:
    """One finished frame task: progress, timings, its warnings and skip reason on stderr."""
    bar.update(1)
    if r.get("timing"):
        for k in ("render_s", "composite_s", "gt_s", "total_s"):
            timing[k] += r["timing"][k]
        timing["n"] += 1
    for w in r.get("warnings", []):
        print(f"ycbvss synth: warning: {w}", file=sys.stderr)
    if r.get("skipped"):
        print(f"ycbvss synth: warning: scene {r['scene_id']} frame {r['im_id']} skipped: "
              f"{r['skipped']}", file=sys.stderr)


def _print_timing(timing: dict) -> None:
    """Mean worker seconds per synthesised frame and stage, on stderr (nothing if no frame was made)."""
    if timing["n"]:
        n = timing["n"]
        print(f"ycbvss synth: {n} frames synthesised; per frame (worker time): render "
              f"{timing['render_s'] / n:.2f} s, composite {timing['composite_s'] / n:.2f} s, "
              f"GT+files {timing['gt_s'] / n:.2f} s, total {timing['total_s'] / n:.2f} s", file=sys.stderr)
