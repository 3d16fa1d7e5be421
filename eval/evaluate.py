"""Evaluate pose estimates against a dataset's GT: per-instance errors, per-object and overall scores.

Protocol (paper Sec. 4, "ADD(-S)"): ADD-S only for objects declared symmetric (default 024_bowl,
obj 13), ADD for the others; AUC bounds 100 mm (ADD(-S)) and 10 px (PRJ); ADD-PRJ-AUC = their
mean; SR at 5 cm / 5 deg; overall = mean over objects. A GT instance without an estimate has
infinite error (counts as failed). Optionally, every GT pose is first replaced by its
symmetric-equivalent (``models_info`` symmetries) closest to the estimate.
"""
from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..errors import YcbvssError
from ..geometry.symmetry import closest_symmetric_gt, continuous_steps, symmetry_transforms
from ..io.bop import read_scene_camera, read_scene_gt, select_scene_ids
from ..progress import progress
from .matching import match
from .metrics import ERROR_KEYS, pose_errors
from .model_points import ModelPoints
from .scores import ADD_BOUND_MM, PRJ_BOUND_PX, mean_finite, object_scores, overall_scores


@dataclass
class EvalOptions:
    """Options of :func:`evaluate`.

    ``symmetric_obj_ids``: objects scored with ADD-S (None: use ``ObjectModel.symmetric``).
    ``use_symmetries``: compare with the GT pose modulo the models_info symmetries.
    ``adds_for``: compute ADD-S for ``"all"`` objects (errors.csv column) or only ``"symmetric"``.
    ``nn_k``: candidates per model point of the exact ADD-S fast path (0 = KD-tree only)."""

    symmetric_obj_ids: tuple[int, ...] | None = (13,)
    symmetric_set: str = "paper"     # name of the ADD-S set, shown in table headers (see symmetric_sets)
    use_symmetries: bool = False
    adds_for: str = "all"
    add_bound_mm: float = ADD_BOUND_MM
    prj_bound_px: float = PRJ_BOUND_PX
    sr_t_mm: float = 50.0
    sr_r_deg: float = 5.0
    nn_k: int = 16
    sym_step_frac: float = 0.01

    def __post_init__(self):
        if self.adds_for not in ("all", "symmetric"):
            raise YcbvssError(f"adds_for must be 'all' or 'symmetric', got {self.adds_for!r}")
        for k in ("add_bound_mm", "prj_bound_px", "sr_t_mm", "sr_r_deg"):
            if not getattr(self, k) > 0:
                raise YcbvssError(f"{k} must be > 0, got {getattr(self, k)}")


@dataclass
class GtArrays:
    """GT instances as flat arrays (n,): ids, poses (mm) and the intrinsics of their frame."""

    scene_id: np.ndarray
    im_id: np.ndarray
    obj_id: np.ndarray
    gt_id: np.ndarray
    R: np.ndarray       # (n, 3, 3)
    t: np.ndarray       # (n, 3) mm
    K: np.ndarray       # (n, 3, 3)

    def __len__(self) -> int:
        return len(self.obj_id)

    @classmethod
    def from_bop(cls, root, split: str, models: dict | None = None, scene_ids=None) -> "GtArrays":
        """GT of a BOP split from scene_gt.json + scene_camera.json only (no images read)."""
        split_dir = Path(root) / split
        all_ids = select_scene_ids(split_dir, scene_ids)
        rows, Rs, ts, Ks = [], [], [], []
        known = None if models is None else models.keys()
        for sid in progress(all_ids, desc="read GT", unit="scene"):
            sdir = split_dir / f"{sid:06d}"
            cams = read_scene_camera(sdir / "scene_camera.json", sid)
            if not (sdir / "scene_gt.json").is_file():
                raise YcbvssError("missing scene_gt.json", sdir / "scene_gt.json", f"scene {sid}")
            gts = read_scene_gt(sdir / "scene_gt.json", sid, known)
            for im_id in sorted(gts):
                if im_id not in cams:
                    raise YcbvssError("frame has GT but no camera entry", sdir / "scene_camera.json",
                                      f"scene {sid} frame {im_id}")
                for k, inst in enumerate(gts[im_id]):
                    rows.append((sid, im_id, inst.obj_id, k if inst.gt_id is None else inst.gt_id))
                    Rs.append(inst.T_m2c[:3, :3])
                    ts.append(inst.T_m2c[:3, 3])
                    Ks.append(cams[im_id]["K"])
        return cls._build(rows, Rs, ts, Ks)

    @classmethod
    def _build(cls, rows, Rs, ts, Ks) -> "GtArrays":
        a = np.array(rows, dtype=np.int64).reshape(-1, 4)
        return cls(a[:, 0], a[:, 1], a[:, 2], a[:, 3], np.array(Rs, dtype=np.float64).reshape(-1, 3, 3),
                   np.array(ts, dtype=np.float64).reshape(-1, 3), np.array(Ks, dtype=np.float64).reshape(-1, 3, 3))

    @classmethod
    def from_dataset(cls, dataset, scene_ids=None) -> "GtArrays":
        """GT of any :class:`ycbvss.scene.Dataset` (streams its scenes)."""
        rows = []
        Rs, ts, Ks = [], [], []
        ids = dataset.scene_ids if scene_ids is None else scene_ids
        for scene in progress(dataset.iter_scenes(ids), desc="read GT", total=len(ids), unit="scene"):
            for fr in scene.frames:
                K = np.asarray(fr.camera.K, dtype=np.float64)
                for k, inst in enumerate(fr.instances):
                    rows.append((fr.scene_id, fr.im_id, inst.obj_id, k if inst.gt_id is None else inst.gt_id))
                    T = np.asarray(inst.T_m2c, dtype=np.float64)
                    Rs.append(T[:3, :3])
                    ts.append(T[:3, 3])
                    Ks.append(K)
        return cls._build(rows, Rs, ts, Ks)


@dataclass
class EstArrays:
    """Estimates as flat arrays (m,) (from :class:`ycbvss.io.results.Estimate` objects)."""

    scene_id: np.ndarray
    im_id: np.ndarray
    obj_id: np.ndarray
    score: np.ndarray
    R: np.ndarray
    t: np.ndarray

    @classmethod
    def from_estimates(cls, estimates) -> "EstArrays":
        est = list(estimates)
        T = np.array([np.asarray(e.T_m2c, dtype=np.float64) for e in est]).reshape(-1, 4, 4)
        return cls(np.array([e.scene_id for e in est], dtype=np.int64),
                   np.array([e.im_id for e in est], dtype=np.int64),
                   np.array([e.obj_id for e in est], dtype=np.int64),
                   np.array([e.score for e in est], dtype=np.float64), T[:, :3, :3], T[:, :3, 3])


ERROR_COLUMNS = ("scene_id", "im_id", "obj_id", "gt_id", "est_score", "symmetric", "tx_mm", "ty_mm",
                 "tz_mm", "te_mm", "r_deg", "prj_px", "add_mm", "adds_mm", "add_s_mm")


@dataclass
class EvalResult:
    """``errors``: dict of (n_gt,) arrays keyed by :data:`ERROR_COLUMNS` (NaN = no estimate),
    one entry per GT instance. ``per_object``: obj_id -> scores and mean errors (see
    :func:`ycbvss.eval.scores.object_scores`). ``summary``: JSON-ready dict (overall scores,
    per_object keyed by str(obj_id), counts, options)."""

    errors: dict[str, np.ndarray]
    per_object: dict[int, dict]
    summary: dict
    names: dict[int, str] = field(default_factory=dict)
    textureless: dict[int, bool] = field(default_factory=dict)


def _symmetric_ids(models: dict, options: EvalOptions) -> set[int]:
    if options.symmetric_obj_ids is None:
        return {o for o, m in models.items() if getattr(m, "symmetric", False)}
    return set(int(o) for o in options.symmetric_obj_ids)


def _model_points(model, k: int) -> ModelPoints:
    try:
        pts = model.vertices_mm
    except YcbvssError:
        raise
    except Exception as e:  # unreadable mesh
        raise YcbvssError(f"cannot read model points: {e}", getattr(model, "path", None),
                          f"object {model.obj_id}") from None
    return ModelPoints(pts, k=k)


def evaluate_arrays(gt: GtArrays, est: EstArrays, models: dict, options: EvalOptions | None = None
                    ) -> EvalResult:
    """Match estimates to GT instances and compute all errors and scores (see module doc).

    ``gt`` (n instances) and ``est`` (m estimates): flat arrays, poses in mm; ``models``: obj_id ->
    ObjectModel (points in mm). Stages: :func:`_match` (one estimate per GT instance, by score and
    ADD(-S)), :func:`_instance_errors` (the (n,) error columns), :func:`_summary` (scores)."""
    opt = options or EvalOptions()
    sym_ids = _symmetric_ids(models, opt)
    missing_models = sorted(set(gt.obj_id.tolist()) - set(models))
    if missing_models:
        raise YcbvssError(f"GT has objects without a model: {missing_models}")
    points = _PointsCache(models)
    m = _match(gt, est, points, sym_ids)
    err = _instance_errors(gt, est, m.est_for_gt, points, models, sym_ids, opt)
    obj_ids = sorted(set(gt.obj_id.tolist()))
    per_object = {}
    for o in obj_ids:
        sel = gt.obj_id == o
        per_object[o] = object_scores({k: err[k][sel] for k in err}, opt.add_bound_mm, opt.prj_bound_px,
                                      opt.sr_t_mm, opt.sr_r_deg)
        per_object[o]["symmetric"] = o in sym_ids
    names = {o: getattr(models[o], "label", str(o)) for o in obj_ids}
    textureless = {o: bool(getattr(models[o], "textureless", False)) for o in obj_ids}
    summary = _summary(err, per_object, names, textureless, m, len(est.obj_id), opt, sym_ids)
    return EvalResult(err, per_object, summary, names, textureless)


class _PointsCache:
    """One :class:`ModelPoints` per object, built on first use; rebuilt with the ADD-S candidate
    fast path (``k`` > 0) when that is asked for after a plain one."""

    def __init__(self, models: dict):
        self.models = models
        self.points: dict[int, ModelPoints] = {}

    def get(self, o: int, k: int = 0) -> ModelPoints:
        if o not in self.points or (k and self.points[o].k == 0):
            self.points[o] = _model_points(self.models[o], k)
        return self.points[o]

    def drop(self, o: int) -> None:
        self.points.pop(o, None)


def _match(gt: GtArrays, est: EstArrays, points: _PointsCache, sym_ids: set):
    """:func:`ycbvss.eval.matching.match` with the ADD(-S) [mm] between the estimates and GT
    instances of one (image, object) group as the cost; warns about ignored estimates."""
    def cost(gt_idx, est_idx):
        o = int(gt.obj_id[gt_idx[0]])
        ei, gi = np.repeat(est_idx, len(gt_idx)), np.tile(gt_idx, len(est_idx))
        e = pose_errors(est.R[ei], est.t[ei], gt.R[gi], gt.t[gi], gt.K[gi], points.get(o),
                        with_adds=o in sym_ids)
        return (e["adds_mm"] if o in sym_ids else e["add_mm"]).reshape(len(est_idx), len(gt_idx))

    m = match(gt.scene_id, gt.im_id, gt.obj_id, est.scene_id, est.im_id, est.obj_id, est.score, cost)
    if m.n_est_no_image:
        warnings.warn(f"{m.n_est_no_image} estimate(s) for images not in the GT were ignored")
    if m.n_est_no_object:
        warnings.warn(f"{m.n_est_no_object} estimate(s) for objects absent from their image were ignored")
    if m.n_groups_surplus:
        warnings.warn(f"{m.n_groups_surplus} (image, object) pair(s) had more estimates than GT "
                      f"instances: kept the highest-scored ({m.n_est_surplus} estimate(s) ignored)")
    return m


def _instance_errors(gt: GtArrays, est: EstArrays, est_for_gt: np.ndarray, points: _PointsCache, models: dict,
                     sym_ids: set, opt: EvalOptions) -> dict[str, np.ndarray]:
    """The (n,) columns of :data:`ERROR_COLUMNS` for the n GT instances; ``est_for_gt`` (n,) index
    of each instance's estimate or -1 (its errors stay NaN). Errors in mm, deg, px."""
    n = len(gt)
    err = {k: np.full(n, np.nan) for k in ERROR_COLUMNS}
    for k in ("scene_id", "im_id", "obj_id", "gt_id"):
        err[k] = getattr(gt, k).copy()
    err["symmetric"] = np.isin(gt.obj_id, list(sym_ids)).astype(np.int64)
    matched = est_for_gt >= 0
    err["est_score"][matched] = est.score[est_for_gt[matched]]
    for o in progress(sorted(set(gt.obj_id.tolist())), desc="errors", unit="obj"):
        gi = np.flatnonzero((gt.obj_id == o) & matched)
        if len(gi) == 0:
            continue
        ei = est_for_gt[gi]
        Rg, tg = gt.R[gi], gt.t[gi]
        mp = points.get(o, opt.nn_k)
        if opt.use_symmetries:
            syms = symmetry_transforms(models[o], continuous_steps(opt.sym_step_frac))
            Rg, tg, _ = closest_symmetric_gt(est.R[ei], est.t[ei], Rg, tg, syms, mp.points)
        with_adds = opt.adds_for == "all" or o in sym_ids
        e = pose_errors(est.R[ei], est.t[ei], Rg, tg, gt.K[gi], mp, with_adds=with_adds)
        for k in ERROR_KEYS:
            err[k][gi] = e[k]
        err["te_mm"][gi] = np.linalg.norm(est.t[ei] - tg, axis=1)
        err["add_s_mm"][gi] = e["adds_mm"] if o in sym_ids else e["add_mm"]
        points.drop(o)                      # free the per-object index
    return err


def _summary(err: dict, per_object: dict, names: dict, textureless: dict, m, n_est: int, opt: EvalOptions,
             sym_ids: set) -> dict:
    """The JSON-ready summary: overall scores, means over all instances, per-object scores, counts
    and the options used."""
    n = len(err["obj_id"])
    matched = m.est_for_gt >= 0
    obj_ids = sorted(per_object)
    all_means = {f"mean_{k}": mean_finite(err[k]) for k in
                 ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px", "add_mm", "adds_mm", "add_s_mm")}
    return {
        **overall_scores(per_object),
        "n_objects": len(obj_ids),
        "all_instances": {"n_gt": int(n), "n_missing": int((~matched).sum()), **all_means},
        "per_object": {str(o): {"name": names[o], "textureless": textureless[o], **per_object[o]}
                       for o in obj_ids},
        "counts": {"n_gt": int(n), "n_estimates": int(n_est), "n_matched": int(matched.sum()),
                   "n_gt_missing": int((~matched).sum()), "n_est_no_image": m.n_est_no_image,
                   "n_est_no_object": m.n_est_no_object, "n_est_surplus": m.n_est_surplus},
        "options": {**asdict(opt), "symmetric_obj_ids": sorted(sym_ids)},
    }


def evaluate(dataset, estimates, options: EvalOptions | None = None, scene_ids=None) -> EvalResult:
    """Evaluate ``estimates`` (:class:`ycbvss.io.results.Estimate` list) on a
    :class:`ycbvss.scene.Dataset` (only GT poses, cameras and models are read; no images)."""
    gt = GtArrays.from_dataset(dataset, scene_ids)
    return evaluate_arrays(gt, EstArrays.from_estimates(estimates), dataset.models, options)
