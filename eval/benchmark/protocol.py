"""The paper's subsequence protocol (Sec. 4.2): split every sequence into subsequences
{initial poses, frames}, reproducibly for a seed, and the versioned JSON that holds them.

Rules (defaults per protocol; ``--lengths`` / ``--steps`` override them for short clips):

- lengths from {25, 50, 100, 200} with (almost) the same total number of frames per length: the
  subsequences are drawn in *rounds*; one round holds ``round(Lmax / L)`` subsequences of each
  length L (8 x 25, 4 x 50, 2 x 100, 1 x 200 = 200 frames per length), so every length gets the
  same number of frames. The number of rounds is ``max(1, round(coverage * total frames /
  frames per round))`` (coverage 1: about as many tracked frames as the dataset has frames).
- frame step uniform in [5, 15] (YCB-V) or [1, 4] (BCOT), in positions of the sorted frame list;
  a step is drawn among the steps for which the subsequence fits in the sequence. Direction +1
  (forward) or -1 (backward) with probability 1/2. Start uniform among the positions that fit.
  The sequence is drawn with probability proportional to its remaining frame budget (coverage x
  its frame count minus the frames already drawn from it, floored at 1).
- tracked objects: those with a GT pose in the first frame, minus ``exclude_obj_ids`` (YCB-V: 16,
  036_wood_block, never tracked). YCB-V: with probability ``remove_prob`` (default 0.5) one
  *occluding* object, drawn uniformly, is removed from the tracked list (an unmodelled occluder).
  An object occludes another if their projected convex hulls (model vertices at the first frame's
  GT pose) overlap by more than 1 % of the smaller hull and its mean depth is smaller.
- ``frames[0]`` is the initialisation frame (its GT poses are ``init``); the ``len(frames) - 1``
  following frames are tracked and scored.

JSON schema, version ``1.0`` (see :data:`SCHEMA_DOC`); the dataset's GT poses stay out of it except
the initial ones.
"""
from __future__ import annotations

from collections import Counter
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import numpy as np

from ...errors import YcbvssError
from ...io.atomic import read_json
from .sources import Sequence

VERSION = "1.0"
PROTOCOL_DEFAULTS = {
    "ycbv": {"lengths": (25, 50, 100, 200), "steps": (5, 15), "exclude_obj_ids": (16,), "remove_occluder": True},
    "bcot": {"lengths": (25, 50, 100, 200), "steps": (1, 4), "exclude_obj_ids": (), "remove_occluder": False},
}
SCHEMA_DOC = """\
{ "version": "1.0", "protocol": "ycbv"|"bcot", "seed": int,
  "dataset": {"name", "root", "layout": "bop"|"ycbv"|"bcot", "split", ["bcot_test_scenes"],
              "n_sequences", "n_frames", "objects": {obj_id: name}},
  "options": {"lengths", "steps": [min, max], "coverage", "remove_prob", "exclude_obj_ids",
              "remove_occluder", "occlusion_min_overlap"},
  "subsequences": [ { "id": int, "scene_id": int, "sequence": str, "frames": [im_id, ...] (tracking
      order, frames[0] = init frame), "length": int, "step": int, "direction": 1|-1,
      "objects": [obj_id, ...], "removed": [obj_id] or [], "K": [9 numbers, row-major, of frames[0]],
      ["K_frames": {im_id: [9]}] (only when K varies),
      "init": {obj_id: {"R": [9 numbers, row-major], "t": [3 numbers, mm]}} } ] }
"""


@dataclass
class ProtocolOptions:
    """Options of :func:`make_protocol` (None: the protocol's default)."""

    protocol: str = "ycbv"
    lengths: tuple[int, ...] | None = None
    steps: tuple[int, int] | None = None
    coverage: float = 1.0
    remove_prob: float = 0.5
    exclude_obj_ids: tuple[int, ...] | None = None
    remove_occluder: bool | None = None
    occlusion_min_overlap: float = 0.01
    seed: int = 0
    max_points: int = 400

    def resolved(self) -> "ProtocolOptions":
        if self.protocol not in PROTOCOL_DEFAULTS:
            raise YcbvssError(f"unknown protocol {self.protocol!r} (ycbv or bcot)")
        d = PROTOCOL_DEFAULTS[self.protocol]
        o = ProtocolOptions(**asdict(self))
        o.lengths = tuple(int(x) for x in (self.lengths or d["lengths"]))
        o.steps = tuple(int(x) for x in (self.steps or d["steps"]))
        o.exclude_obj_ids = tuple(int(x) for x in (d["exclude_obj_ids"] if self.exclude_obj_ids is None
                                                    else self.exclude_obj_ids))
        o.remove_occluder = d["remove_occluder"] if self.remove_occluder is None else bool(self.remove_occluder)
        if not o.lengths or min(o.lengths) < 2:
            raise YcbvssError(f"lengths must be >= 2 frames (init frame + tracked frames), got {list(o.lengths)}")
        if len(o.steps) != 2 or not 1 <= o.steps[0] <= o.steps[1]:
            raise YcbvssError(f"steps must be MIN,MAX with 1 <= MIN <= MAX, got {list(o.steps)}")
        if not o.coverage > 0:
            raise YcbvssError(f"coverage must be > 0, got {o.coverage}")
        if not 0 <= o.remove_prob <= 1:
            raise YcbvssError(f"remove_prob must be in [0, 1], got {o.remove_prob}")
        return o


def _hull(pts_mm: np.ndarray, T: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, float]:
    X = pts_mm @ T[:3, :3].T + T[:3, 3]
    z = X[:, 2]
    if np.any(z <= 1.0):
        X = X[z > 1.0]
        if len(X) < 3:
            return np.zeros((0, 1, 2), np.float32), float("inf")
    uv = (X @ K.T)
    uv = (uv[:, :2] / uv[:, 2:3]).astype(np.float32)
    return cv2.convexHull(uv), float(X[:, 2].mean())


def occluders(gt: dict[int, np.ndarray], K: np.ndarray, points: dict[int, np.ndarray], obj_ids: list[int],
              min_overlap: float = 0.01) -> list[int]:
    """Objects of ``obj_ids`` that occlude another one of them in a frame (see module doc)."""
    hulls = {o: _hull(points[o], gt[o], K) for o in obj_ids}
    areas = {o: float(cv2.contourArea(h)) if len(h) >= 3 else 0.0 for o, (h, _) in hulls.items()}
    out = set()
    for i, a in enumerate(obj_ids):
        for b in obj_ids[i + 1:]:
            if areas[a] <= 0 or areas[b] <= 0:
                continue
            inter, _ = cv2.intersectConvexConvex(hulls[a][0], hulls[b][0])
            if inter > min_overlap * min(areas[a], areas[b]):
                out.add(a if hulls[a][1] < hulls[b][1] else b)
    return sorted(out)


def _pose_json(T: np.ndarray) -> dict:
    T = np.asarray(T, dtype=np.float64)
    return {"R": [float(x) for x in T[:3, :3].reshape(9)], "t": [float(x) for x in T[:3, 3]]}


def make_protocol(sequences: list[Sequence], dataset_info: dict, options: ProtocolOptions,
                  models: dict | None = None) -> dict:
    """The benchmark configuration (JSON-ready dict, see :data:`SCHEMA_DOC`). ``models`` (obj_id ->
    ObjectModel) are needed for the occluder test (YCB-V) and for object names.

    Subsequences are drawn in rounds (:func:`_round_plan`), longest length first, each from a
    sequence chosen with probability proportional to its remaining frame budget (:func:`_draw_frames`),
    its objects those visible in the first frame minus possibly one occluder (:func:`_objects_at`)."""
    opt = options.resolved()
    rng = np.random.default_rng(opt.seed)
    seqs = [s for s in sequences if len(s.im_ids) >= 2]
    if not seqs:
        raise YcbvssError("no sequence with at least 2 frames")
    per_round, rounds, n_total = _round_plan(seqs, opt)
    budget = np.array([opt.coverage * len(s.im_ids) for s in seqs], dtype=np.float64)
    points = _SubsampledPoints(models, opt.max_points)
    subs = []
    for _ in range(rounds):
        for L in sorted(opt.lengths, reverse=True):
            for _k in range(per_round[L]):
                si, frames, step, direction = _draw_frames(rng, seqs, budget, L, opt.steps)
                budget[si] -= L
                s = seqs[si]
                objs, removed = _objects_at(rng, s, frames[0], opt, models, points)
                subs.append(_subsequence(len(subs), s, frames, L, step, direction, objs, removed))
    obj_ids = sorted({o for s in seqs for fr in s.gt.values() for o in fr})
    names = {str(o): (models[o].label if models is not None and o in models else str(o)) for o in obj_ids}
    ds = {**dataset_info, "n_sequences": len(seqs), "n_frames": int(n_total), "objects": names}
    opts = {"lengths": list(opt.lengths), "steps": list(opt.steps), "coverage": opt.coverage,
            "remove_prob": opt.remove_prob if opt.remove_occluder else 0.0,
            "exclude_obj_ids": list(opt.exclude_obj_ids), "remove_occluder": opt.remove_occluder,
            "occlusion_min_overlap": opt.occlusion_min_overlap, "per_round": {str(k): v for k, v in per_round.items()},
            "rounds": rounds}
    return {"version": VERSION, "protocol": opt.protocol, "seed": int(opt.seed), "dataset": ds, "options": opts,
            "subsequences": subs}


def _round_plan(seqs: list[Sequence], opt) -> tuple[dict, int, int]:
    """(subsequences of each length per round, number of rounds, frames in all sequences): one round
    covers about lcm(lengths) frames equally per length; the rounds reach ``opt.coverage`` of the
    frames. Raises when a length fits no sequence at the smallest step."""
    smin = opt.steps[0]
    lmax = max(opt.lengths)
    lcm = int(np.lcm.reduce(np.array(opt.lengths, dtype=np.int64)))
    unit = lcm if lcm <= 4 * lmax else lmax       # exact equality whenever the lcm is small
    per_round = {L: max(1, int(round(unit / L))) for L in opt.lengths}
    frames_round = sum(L * n for L, n in per_round.items())
    n_total = sum(len(s.im_ids) for s in seqs)
    rounds = max(1, int(round(opt.coverage * n_total / frames_round)))
    for L in opt.lengths:
        if not any((L - 1) * smin + 1 <= len(s.im_ids) for s in seqs):
            longest = max(seqs, key=lambda s: len(s.im_ids))
            raise YcbvssError(f"no sequence fits a subsequence of {L} frames with step >= {smin}: the longest "
                              f"has {len(longest.im_ids)} frames; set shorter --lengths or smaller --steps",
                              where=f"scene {longest.scene_id}")
    return per_round, rounds, n_total


def _draw_frames(rng, seqs: list[Sequence], budget: np.ndarray, L: int, steps: tuple) -> tuple:
    """One subsequence of ``L`` frames: (sequence index, frame ids in tracking order, step, direction
    +1/-1); the sequence drawn with probability proportional to its remaining budget (at least 1)."""
    smin, smax = steps
    fits = np.array([(L - 1) * smin + 1 <= len(s.im_ids) for s in seqs])
    w = np.where(fits, np.maximum(budget, 1.0), 0.0)
    si = int(rng.choice(len(seqs), p=w / w.sum()))
    s = seqs[si]
    n = len(s.im_ids)
    s_fit = min(smax, (n - 1) // (L - 1))
    step = int(rng.integers(smin, s_fit + 1))
    span = (L - 1) * step + 1
    start = int(rng.integers(0, n - span + 1))
    direction = int(rng.choice([1, -1]))
    pos = start + step * np.arange(L)
    if direction < 0:
        pos = pos[::-1]
    return si, [int(s.im_ids[p]) for p in pos], step, direction


class _SubsampledPoints:
    """Model points (mm) of each object, at most about ``max_points`` (every k-th vertex), cached."""

    def __init__(self, models: dict | None, max_points: int):
        self.models, self.max_points, self.points = models, max_points, {}

    def __call__(self, o: int) -> np.ndarray:
        if o not in self.points:
            v = np.asarray(self.models[o].vertices_mm, dtype=np.float64)
            self.points[o] = v[::max(1, len(v) // self.max_points)]
        return self.points[o]


def _objects_at(rng, s: Sequence, f0: int, opt, models: dict | None, points: _SubsampledPoints) -> tuple:
    """(tracked obj_ids, removed obj_ids) of a subsequence starting at frame ``f0``: the GT objects
    there except the excluded ones; with probability ``remove_prob`` one occluder is removed."""
    objs = [o for o in s.objects_in(f0) if o not in opt.exclude_obj_ids]
    removed: list[int] = []
    if opt.remove_occluder and len(objs) >= 2 and models is not None:
        occ = occluders(s.gt[f0], s.K[f0], {o: points(o) for o in objs}, objs, opt.occlusion_min_overlap)
        u = float(rng.random())
        if occ and u < opt.remove_prob:
            r = int(occ[int(rng.integers(len(occ)))])
            removed = [r]
            objs = [o for o in objs if o != r]
    return objs, removed


def _subsequence(idx: int, s: Sequence, frames: list, L: int, step: int, direction: int, objs: list,
                 removed: list) -> dict:
    """The JSON entry of one subsequence (init = the GT poses of the first frame; per-frame K only
    when the intrinsics change within it)."""
    f0 = frames[0]
    K0 = s.K[f0]
    sub = {"id": idx, "scene_id": int(s.scene_id), "sequence": s.name, "frames": frames,
           "length": L, "step": step, "direction": direction, "objects": objs, "removed": removed,
           "K": [float(x) for x in np.asarray(K0).reshape(9)],
           "init": {str(o): _pose_json(s.gt[f0][o]) for o in objs}}
    if np.abs(np.stack([s.K[f] for f in frames]) - K0).max() > 1e-9:
        sub["K_frames"] = {str(f): [float(x) for x in np.asarray(s.K[f]).reshape(9)] for f in frames}
    return sub


# ------------------------------------------------------------------------------ reading
REQUIRED_TOP = ("version", "protocol", "seed", "dataset", "subsequences")
REQUIRED_SUB = ("scene_id", "frames", "step", "direction", "objects", "removed", "init")


def check_config(cfg: dict, path: str | Path = "") -> dict:
    """Validate a benchmark configuration; errors name the file and the subsequence."""
    if not isinstance(cfg, dict):
        raise YcbvssError("benchmark config must be a JSON object", path)
    miss = [k for k in REQUIRED_TOP if k not in cfg]
    if miss:
        raise YcbvssError(f"benchmark config lacks key(s) {miss}", path)
    if str(cfg["version"]).split(".")[0] != VERSION.split(".")[0]:
        raise YcbvssError(f"benchmark config version {cfg['version']} not supported (this is {VERSION})", path)
    if not isinstance(cfg["subsequences"], list):
        raise YcbvssError("'subsequences' must be a list", path)
    for i, s in enumerate(cfg["subsequences"]):
        wh = f"subsequence {i}"
        if not isinstance(s, dict):
            raise YcbvssError("not an object", path, wh)
        miss = [k for k in REQUIRED_SUB if k not in s]
        if miss:
            raise YcbvssError(f"lacks key(s) {miss}", path, wh)
        s.setdefault("id", i)
        if not isinstance(s["frames"], list) or len(s["frames"]) < 2:
            raise YcbvssError("'frames' must list at least 2 im_ids", path, wh)
        if s["direction"] not in (1, -1):
            raise YcbvssError(f"direction must be 1 or -1, got {s['direction']!r}", path, wh)
        for o in s["objects"]:
            p = s["init"].get(str(o))
            if p is None:
                raise YcbvssError("tracked object has no init pose", path, f"{wh} object {o}")
            R, t = np.asarray(p.get("R", []), dtype=np.float64), np.asarray(p.get("t", []), dtype=np.float64)
            if R.size != 9 or t.size != 3 or not (np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
                raise YcbvssError("init pose needs R (9 numbers) and t (3 numbers, mm)", path, f"{wh} object {o}")
    return cfg


def read_config(path: str | Path) -> dict:
    path = Path(path)
    if not path.is_file():
        raise YcbvssError("benchmark config not found", path)
    return check_config(read_json(path, "benchmark config"), path)


def init_pose(sub: dict, obj_id: int) -> np.ndarray:
    p = sub["init"][str(obj_id)]
    T = np.eye(4)
    T[:3, :3] = np.asarray(p["R"], dtype=np.float64).reshape(3, 3)
    T[:3, 3] = np.asarray(p["t"], dtype=np.float64)
    return T


def frame_K(sub: dict, im_id: int) -> np.ndarray:
    kf = sub.get("K_frames")
    k = kf[str(im_id)] if kf and str(im_id) in kf else sub["K"]
    return np.asarray(k, dtype=np.float64).reshape(3, 3)


# ------------------------------------------------------------------------------ summary
def protocol_stats(cfg: dict) -> dict:
    subs = cfg["subsequences"]
    by_len = Counter(len(s["frames"]) for s in subs)
    frames_by_len = Counter()
    for s in subs:
        frames_by_len[len(s["frames"])] += len(s["frames"])
    return {"n_subsequences": len(subs), "n_frames": int(sum(frames_by_len.values())),
            "n_tracked_frames": int(sum(len(s["frames"]) - 1 for s in subs)),
            "subsequences_per_length": dict(sorted(by_len.items())),
            "frames_per_length": dict(sorted(frames_by_len.items())),
            "steps": dict(sorted(Counter(int(s["step"]) for s in subs).items())),
            "directions": {"forward": sum(s["direction"] == 1 for s in subs),
                           "backward": sum(s["direction"] == -1 for s in subs)},
            "removed": {"subsequences_with_removal": sum(bool(s["removed"]) for s in subs),
                        "by_object": dict(sorted(Counter(o for s in subs for o in s["removed"]).items()))},
            "tracked_objects": dict(sorted(Counter(o for s in subs for o in s["objects"]).items())),
            "object_frames": int(sum((len(s["frames"]) - 1) * len(s["objects"]) for s in subs))}


def summary_text(cfg: dict) -> str:
    """The summary ``make`` prints: subsequences and frames per length, step histogram,
    directions, removals."""
    st = protocol_stats(cfg)
    ds = cfg["dataset"]
    lines = [f"benchmark {cfg['protocol']} (seed {cfg['seed']}, schema {cfg['version']}): "
             f"{ds.get('n_sequences')} sequences, {ds.get('n_frames')} frames of {ds.get('name')} ({ds.get('layout')})"]
    if ds.get("bcot_test_scenes"):
        lines.append(f"BCOT test scenes ({len(ds['bcot_test_scenes'])}): {', '.join(ds['bcot_test_scenes'])}")
    lines.append(f"{st['n_subsequences']} subsequences, {st['n_frames']} frames "
                 f"({st['n_tracked_frames']} tracked, {st['object_frames']} object-frames)")
    lines.append("| length | subsequences | frames |")
    lines.append("|---:|---:|---:|")
    for L, n in st["subsequences_per_length"].items():
        lines.append(f"| {L} | {n} | {st['frames_per_length'][L]} |")
    hist = st["steps"]
    peak = max(hist.values()) if hist else 1
    lines.append("steps: " + ", ".join(f"{k}:{v}" for k, v in hist.items()))
    for k, v in hist.items():
        lines.append(f"  step {k:>3} {'#' * max(1, round(30 * v / peak))} {v}")
    lines.append(f"directions: {st['directions']['forward']} forward, {st['directions']['backward']} backward")
    rm = st["removed"]
    lines.append(f"removed occluders: {rm['subsequences_with_removal']} of {st['n_subsequences']} subsequences"
                 + (" (" + ", ".join(f"obj {o}: {n}" for o, n in rm["by_object"].items()) + ")" if rm["by_object"] else ""))
    excl = cfg.get("options", {}).get("exclude_obj_ids") or []
    if excl:
        lines.append(f"never tracked: {excl}")
    return "\n".join(lines)
