"""Run the refiner on the validation suite's clips and tabulate what the issue asks for.

One run = (clip, init mode, seed, variant). Init modes: ``paper`` (GT + an independent random
deviation per (view, object) calibrated to mean ADD 22.1 mm / PRJ 5.2 px, as the paper's initial
poses), ``gt`` (exact ground truth: the bias test), ``add<N>`` (the deviation calibrated to mean
ADD N mm and PRJ N * 5.2 / 22.1 px: the capture-range curve against ADD), ``prj<N>`` (the paper
init's depth error, same random draws, with the lateral and rotational part scaled to mean PRJ
N px: the capture-range curve against PRJ; ADD grows with it). Each run appends its per-pose rows
to ``rows.csv`` under ``out/`` and leaves a done marker, so an interrupted run resumes.

Per pose the rows hold tx, ty, tz (mm), R (deg; for the bowl under ADD-S the rotation about its
axis is excluded), PRJ (px), ADD(-S) (mm), the reported sigma (mm, deg), status and confidence.
"""
from __future__ import annotations

import csv
import gzip
import hashlib
import json
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import YcbvssError
from ..eval.metrics import pose_errors
from ..geometry.so3 import log_so3
from ..io.atomic import read_json, write_json_atomic
from ..io.bop import load_bop_scene
from ..io.provenance import host_record, rgb_sha256
from ..progress import progress
from ..refine.bundle import RefineOptions, refine_scene, ridge_fallback_objects
from ..refine.options import options_to_json
from .perturb import perturb_poses
from .suite import Clip, SuiteScene, build_suite, clip_scene, clips_of
from .suite_report import visibility, write_report

ROW_FIELDS = ("clip", "kind", "scene_id", "held_out", "init", "seed", "variant", "im_id", "obj_id",
              "tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px", "add_mm", "dx_mm", "dy_mm", "dz_mm", "init_add_mm", "init_prj_px",
              "sigma_tx_mm", "sigma_ty_mm", "sigma_tz_mm", "sigma_r_deg", "status", "confidence", "contour_px",
              "time_s", "n_frames", "contour_worst_px", "reason", "rx_obj_deg", "ry_obj_deg", "rz_obj_deg",
              "interior_ncc", "turn_gain_ncc", "ridge_fallback", "slide_restart", "texture_share", "regroup",
              "sweep_again", "sigma_add_mm")
VARIANTS = {"using all": {}, "w/o f_edge": {"use_edge": False}, "w/o f_point": {"use_point": False},
            "w/o f_t": {"use_temporal": False}}


@dataclass(frozen=True)
class Run:
    clip: Clip
    init: str          # "paper" | "gt" | "add<N>" | "prj<N>"
    seed: int
    variant: str = "using all"

    @property
    def key(self) -> str:
        return f"{self.clip.name}_{self.init}_s{self.seed}_{self.variant.replace(' ', '').replace('/', '')}"


def keyframe_step_for(n_frames: int) -> int:
    """About 8 jointly refined keyframes per clip; the other frames are refined camera-only."""
    return 0 if n_frames <= 10 else max(1, int(round(n_frames / 8)))


def init_targets(init: str) -> tuple[float, float] | None:
    """(mean ADD mm, mean PRJ px) of an init mode, None for exact GT."""
    if init == "gt":
        return None
    if init == "paper":
        return 22.1, 5.2
    if init.startswith("add"):
        a = float(init[3:])
        return a, a * 5.2 / 22.1
    if init.startswith("prj"):
        return 22.1, float(init[3:])    # ADD: the paper's depth scale is held, see initial_poses
    raise YcbvssError(f"unknown init mode {init!r} (paper, gt, add<mm>, prj<px>)")


def _seed_of(run: Run) -> int:
    return int(hashlib.sha256(f"{run.clip.name}/{run.init}/{run.seed}".encode()).hexdigest()[:8], 16)


def initial_poses(run: Run, gt: dict, Ks: dict, pts: dict) -> dict:
    """The run's initial poses {(im_id, obj_id): 4x4}: the exact GT, or the GT plus the calibrated
    deviation of its init mode. ``prj<N>`` draws the same deviations as the paper's init (same
    seed), holds their depth scale and rescales the lateral/rotational part to mean PRJ N px."""
    tgt = init_targets(run.init)
    if tgt is None:
        return {k: T.copy() for k, T in gt.items()}
    if run.init.startswith("prj"):
        seed = _seed_of(Run(run.clip, "paper", run.seed, run.variant))
        a = perturb_poses(gt, Ks, pts, 22.1, 5.2, seed=seed).depth_scale
        return perturb_poses(gt, Ks, pts, tgt[0], tgt[1], seed=seed, depth_scale=a).poses
    return perturb_poses(gt, Ks, pts, tgt[0], tgt[1], seed=_seed_of(run)).poses


def _bowl_free_rotation_deg(R_est: np.ndarray, R_gt: np.ndarray, axis: np.ndarray) -> float:
    """Rotation error (deg) that ignores the turn about a continuous-symmetry axis (model frame):
    the angle between the axis mapped by the estimate and by the GT."""
    a = R_est @ axis
    b = R_gt @ axis
    return float(np.degrees(np.arccos(np.clip(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)), -1.0, 1.0))))


def refine_run(run: Run, scene, models: dict, opts_kw: dict | None = None) -> tuple:
    """Refine one clip of a loaded suite scene from one initialisation, as the suite does; returns
    (RefineResult, the clip's scene, its GT poses, its initial poses, camera matrices per pose key, wall s)."""
    sc = clip_scene(scene, run.clip)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in sc.frames for i in f.instances}
    Ks = {k: next(f.camera.K for f in sc.frames if f.im_id == k[0]) for k in gt}
    pts = {o: models[o].vertices_mm for o in {k[1] for k in gt}}
    init = initial_poses(run, gt, Ks, pts)
    kw = {**(opts_kw or {}), **VARIANTS[run.variant]}      # an ablation variant's removed term stays removed
    step = kw.pop("keyframe_step", keyframe_step_for(len(sc.frames)))
    # the refiner's sampling seed follows the initialisation seed unless the options give their own
    ro = RefineOptions(**{"keyframe_step": step, "seed": run.seed, **kw})
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = refine_scene(sc, models, init, ro)
    return res, sc, gt, init, Ks, time.perf_counter() - t0


def run_one(run: Run, scene, models: dict, opts_kw: dict | None = None) -> list[dict]:
    """Refine one clip from one initialisation (:func:`refine_run`); returns the per-pose rows."""
    res, sc, gt, init, Ks, dt = refine_run(run, scene, models, opts_kw)
    pts = {o: models[o].vertices_mm for o in {k[1] for k in gt}}
    rows = []
    f = res.stats.get("sigma_scale", (1.0, 1.0, 1.0, 1.0))
    fell_back, restarted = restart_flags(res.stats)
    rg = res.stats.get("regroup")
    # 0: the refined cameras confirmed the baseline group; 1: refined again as the group they read, kept; 2: not kept
    regroup = 0 if not rg else (1 if rg.get("kept") else 2)
    for oid in sorted({k[1] for k in gt}):
        keys = sorted(k for k in gt if k[1] == oid and k in res.poses)
        if not keys:
            continue
        m = models[oid]
        E = pose_errors(np.stack([res.poses[k][:3, :3] for k in keys]), np.stack([res.poses[k][:3, 3] for k in keys]),
                        np.stack([gt[k][:3, :3] for k in keys]), np.stack([gt[k][:3, 3] for k in keys]),
                        np.stack([Ks[k] for k in keys]), pts[oid], with_adds=bool(m.symmetric))
        E0 = pose_errors(np.stack([init[k][:3, :3] for k in keys]), np.stack([init[k][:3, 3] for k in keys]),
                         np.stack([gt[k][:3, :3] for k in keys]), np.stack([gt[k][:3, 3] for k in keys]),
                         np.stack([Ks[k] for k in keys]), pts[oid], with_adds=bool(m.symmetric))
        axis = None
        if m.symmetric and m.symmetries_continuous:
            axis = np.asarray(m.symmetries_continuous[0]["axis"], float)
        for n, k in enumerate(keys):
            sp = res.sigma.get("poses", {}).get(k)
            r = (_bowl_free_rotation_deg(res.poses[k][:3, :3], gt[k][:3, :3], axis) if axis is not None
                 else float(E["r_deg"][n]))
            rows.append({
                "clip": run.clip.name, "kind": run.clip.kind, "scene_id": run.clip.scene_id,
                "held_out": int(run.clip.held_out or run.seed >= 5), "init": run.init, "seed": run.seed,
                "variant": run.variant, "im_id": k[0], "obj_id": oid,
                "tx_mm": float(E["tx_mm"][n]), "ty_mm": float(E["ty_mm"][n]), "tz_mm": float(E["tz_mm"][n]),
                "r_deg": r, "prj_px": float(E["prj_px"][n]),
                "dx_mm": float(res.poses[k][0, 3] - gt[k][0, 3]), "dy_mm": float(res.poses[k][1, 3] - gt[k][1, 3]),
                "dz_mm": float(res.poses[k][2, 3] - gt[k][2, 3]),
                "add_mm": float(E["adds_mm"][n] if m.symmetric else E["add_mm"][n]),
                "init_add_mm": float(E0["adds_mm"][n] if m.symmetric else E0["add_mm"][n]),
                "init_prj_px": float(E0["prj_px"][n]),
                # the covariance sigmas before calibration (the report applies the calibration)
                "sigma_tx_mm": sp["sigma_stat_t_mm"][0] / f[0] if sp else float("nan"),
                "sigma_ty_mm": sp["sigma_stat_t_mm"][1] / f[1] if sp else float("nan"),
                "sigma_tz_mm": sp["sigma_stat_t_mm"][2] / f[2] if sp else float("nan"),
                "sigma_r_deg": sp["sigma_stat_r_deg"] / f[3] if sp else float("nan"),
                "status": res.status.get(k, "failed"), "confidence": float(res.confidence.get(k, 0.0)),
                "contour_px": float(res.quality.get(oid, {}).get("contour_px", float("nan"))),
                "time_s": dt, "n_frames": len(sc.frames),
                "contour_worst_px": float(res.quality.get(oid, {}).get("contour_worst_px", float("nan"))),
                "reason": res.reasons.get(k, ""),
                # the refined pose's interior texture fit and its best turned copy's gain (refine.turn_check)
                "interior_ncc": float(res.quality.get(oid, {}).get("interior_ncc", float("nan"))),
                "turn_gain_ncc": float(res.quality.get(oid, {}).get("turn_gain_ncc", float("nan"))),
                # the share of the template's interior pixels with texture (refine.turn_check.texture_share)
                "texture_share": float(res.quality.get(oid, {}).get("texture_share", float("nan"))),
                # 1: the object drifted at the finest level's cap and the level ran again (RefineOptions.ridge_fallback),
                # in the returned pass or in the first pass before a kept slide restart
                "ridge_fallback": int(oid in fell_back),
                # 1: the object slid (or was put back) and the kept result is a restart without the coarsest level
                "slide_restart": int(oid in restarted),
                "regroup": regroup,
                "sweep_again": int(bool(res.stats.get("sweep_again"))),
                # the ADD sigma of the pose's statistical part (what the status reads; the report widens a
                # pose that is not converged with it, refine.confidence.unsettled_sigma_t_mm)
                "sigma_add_mm": float(sp.get("sigma_add_mm", float("nan"))) if sp else float("nan"),
                **dict(zip(("rx_obj_deg", "ry_obj_deg", "rz_obj_deg"),
                           rotation_error_in_model_deg(res.poses[k][:3, :3], gt[k][:3, :3])))})
    return rows


def restart_flags(stats: dict) -> tuple[set[int], set[int]]:
    """From a refinement's ``stats``: (objects the finest level's ridge fallback put back, in the
    returned pass or in the first pass before a kept slide restart; objects whose kept result is a
    slide restart's)."""
    restart = stats.get("slide_restart", {})
    restarted = {int(o) for o in restart.get("objects", [])} if restart.get("kept") else set()
    groups = list(stats.get("ridge_fallback", [])) + (list(restart.get("ridge_fallback", [])) if restarted else [])
    return ridge_fallback_objects(groups), restarted


def plan(specs: list[SuiteScene], kinds=("short", "medium", "long"), seeds=(0,), inits=("paper",),
         variants=("using all",), gt_kinds=None, ablation_kinds=("long",)) -> list[Run]:
    """The runs: every clip of ``kinds`` x ``inits`` x ``seeds`` with all terms, the exact-GT run
    (seed 0) on ``gt_kinds``, and the ablation variants on ``ablation_kinds``."""
    runs = []
    for spec in specs:
        for c in clips_of(spec, kinds):
            for init in inits:
                for s in seeds:
                    runs.append(Run(c, init, s))
                    if c.kind in ablation_kinds and init == "paper":
                        runs += [Run(c, init, s, v) for v in variants if v != "using all"]
            if gt_kinds is not None and c.kind in gt_kinds:
                runs.append(Run(c, "gt", 0))
    return runs


def rotation_error_in_model_deg(R_est, R_gt) -> tuple[float, float, float]:
    """Rotation error as a rotation vector in the model frame (deg): R_est = R_gt Exp(w). Its
    direction tells a roll about an object's own axis from a tilt of that axis."""
    w = np.degrees(log_so3(np.asarray(R_gt, float).T @ np.asarray(R_est, float)))
    return float(w[0]), float(w[1]), float(w[2])


def _header(path: Path) -> list[str]:
    with open(path, newline="") as fh:
        return next(csv.reader(fh))


def scene_provenance(root: Path, scene_ids) -> dict:
    """Per suite scene under ``root/test`` the digest of its images and the host that rendered them,
    as its marker (``suite_scene.json``) records them (None for scenes rendered before the marker
    held them), and the digest of the images on disk now (:mod:`ycbvss.io.provenance`)."""
    out = {}
    for sid in sorted(set(int(s) for s in scene_ids)):
        sdir = Path(root) / "test" / f"{sid:06d}"
        marker = sdir / "suite_scene.json"
        m = read_json(marker, "suite marker") if marker.is_file() else {}
        out[str(sid)] = {"rgb_sha256": rgb_sha256(sdir), "marker_rgb_sha256": m.get("rgb_sha256"),
                         "rendered_on": m.get("rendered_on"), "hash": m.get("hash")}
    return out


def execute(runs: list[Run], root: Path, models: dict, out: Path, opts_kw: dict | None = None) -> Path:
    """Run what is not done yet; append rows to ``out/rows.csv``. Returns the CSV path. Writes
    ``out/provenance.json``: per call the refining host, the options and the runs it refines (none
    when resumed with all done), and the images each scene's rows come from
    (:func:`scene_provenance`), merged with an earlier call's record in the same folder."""
    out.mkdir(parents=True, exist_ok=True)
    done_dir = out / "done"
    done_dir.mkdir(exist_ok=True)
    rows_path = out / "rows.csv"
    todo = [r for r in runs if not (done_dir / f"{r.key}.json").is_file()]
    prov_path = out / "provenance.json"
    prov = read_json(prov_path, "suite provenance") if prov_path.is_file() else {}
    options = options_to_json(opts_kw)
    # rows refined with other options are not this call's: resuming them would mix two refiners
    earlier = [c.get("options", {}) for c in prov.get("refined_on", []) if c.get("runs")]
    resumed = len(todo) < len(runs)
    if resumed and any(o != options for o in earlier):
        other = next(o for o in earlier if o != options)
        raise YcbvssError(f"its runs were refined with the options {json.dumps(other, sort_keys=True)}, this call's are "
                          f"{json.dumps(options, sort_keys=True)}: use another output folder", out)
    prov.setdefault("refined_on", []).append({"host": host_record(), "options": options,
                                              "runs": [r.key for r in todo]})
    prov.setdefault("scenes", {}).update(scene_provenance(root, {r.clip.scene_id for r in runs}))
    write_json_atomic(prov_path, prov)
    scenes: dict = {}
    bar = progress(total=len(todo), desc="suite", unit="run")
    try:
        for r in todo:
            bar.set_postfix_str(r.key)
            sid = r.clip.scene_id
            if sid not in scenes:
                scenes.clear()
                scenes[sid] = load_bop_scene(root / "test", sid, models)
            rows = run_one(r, scenes[sid], models, opts_kw)
            new = not rows_path.is_file()
            # a rows file begun by older code keeps its own columns (resumed runs stay aligned)
            fields = ROW_FIELDS if new else _header(rows_path)
            with open(rows_path, "a", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore", restval="")
                if new:
                    w.writeheader()
                w.writerows(rows)
            write_json_atomic(done_dir / f"{r.key}.json", {"n_rows": len(rows)})
            bar.update(1)
    finally:
        bar.close()
    return rows_path


def read_rows(path: Path) -> list[dict]:
    """The rows of a suite run's ``rows.csv`` (or a gzip-compressed ``rows.csv.gz``, as the results
    folders keep them), numbers parsed."""
    num = {"scene_id", "held_out", "seed", "im_id", "obj_id", "n_frames"}
    out = []
    opener = gzip.open if str(path).endswith(".gz") else open
    with opener(path, "rt", newline="") as fh:
        for r in csv.DictReader(fh):
            d = {}
            for k, v in r.items():
                if k in num:
                    d[k] = int(v)
                elif k in ("clip", "kind", "init", "variant", "status", "reason"):
                    d[k] = v
                else:
                    d[k] = float(v) if v != "" else float("nan")
            out.append(d)
    return out


CAPTURE_LEVELS = ("add5", "add10", "add22.1", "add40", "add60")
# the PRJ axis of the capture range: the paper init's depth error held, the lateral/rotational part scaled (ADD grows)
CAPTURE_PRJ_LEVELS = ("prj2", "prj10", "prj15", "prj20")


def run_suite(src: str | Path, out: str | Path, suite: str = "ycbv21", scene_ids=None,
              kinds=("short", "medium", "long"), seeds=(0, 5), bias: bool = True, ablation: bool = True,
              capture_kinds=(), capture_seeds=(0,), quiet: bool = False, refine_options: dict | None = None) -> dict:
    """Build the suite (cached) under ``out/dataset``, run what is not done yet, write the report
    into ``out/report``. ``refine_options``: RefineOptions fields set on every run (``--options``).
    Returns {"rows": path, "tables": {name: path}, "n_rows": int}."""
    out = Path(out)
    models, specs = build_suite(src, out / "dataset", suite, scene_ids=scene_ids, quiet=quiet)
    runs = plan(specs, kinds, seeds, ("paper",), variants=tuple(VARIANTS) if ablation else ("using all",),
                gt_kinds=tuple(kinds) if bias else None, ablation_kinds=("long",) if ablation else ())
    for spec in specs:
        for c in clips_of(spec, capture_kinds):
            runs += [Run(c, lv, s) for lv in CAPTURE_LEVELS + CAPTURE_PRJ_LEVELS for s in capture_seeds]
    rows_path = execute(runs, out / "dataset", models, out / "runs", refine_options or None)
    rows = read_rows(rows_path) if rows_path.is_file() else []
    tables = write_report(rows, models, out / "report", visibility(out / "dataset", [s.scene_id for s in specs]))
    write_json_atomic(out / "report" / "suite.json", {
        "suite": suite, "scenes": [s.scene_id for s in specs], "kinds": list(kinds), "seeds": list(seeds),
        "bias": bias, "ablation": ablation, "capture_kinds": list(capture_kinds), "n_rows": len(rows),
        "refine_options": options_to_json(refine_options),
        "held_out": "scenes 3, 8, 9 and seeds >= 5"})
    return {"rows": rows_path, "tables": tables, "n_rows": len(rows)}
