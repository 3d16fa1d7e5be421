"""How much of the rotation rest would a perfect contour prediction remove? An oracle.

At the exact GT each (view, object)'s image edge lies a shared 2-D shift s off f_edge's lit contour
prediction (``bench_contour_offsets.py --shift``). This bench measures that s on the frames of a
``bench_bias_lighting.py`` re-render (cameras known), then refines them from the exact GT with the
cameras held there (as ``bench_bias_lighting.py`` does), once as the refiner is and once with every
contour candidate of f_edge moved by its (view, object)'s measured s at the finest blur level
(where the appearance prediction applies). The difference is what the shift does to the poses. An
oracle, not a method: s comes from the GT.

    python bench/bench_bias_lighting.py --dataset ../shared/data/ycbv --out /tmp/bl1 --scene 1 --variants suite
    python bench/bench_contour_shift_oracle.py --dataset ../shared/data/ycbv --bias-root /tmp/bl1 \
        --suite-root /tmp/suite/full --scene 1
"""
from __future__ import annotations

import argparse
import hashlib
import sys
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_bias_lighting import bias_from_gt  # noqa: E402
from bench_contour_offsets import lit_contour_groups, shift_fit  # noqa: E402


def _key(image: np.ndarray) -> str:
    """A view's identity by its image's content (the refiner passes the images, not their ids)."""
    return hashlib.md5(np.ascontiguousarray(image[::5, ::5]).tobytes()).hexdigest()


def measured_shifts(a: argparse.Namespace, images: Path) -> tuple[dict, dict]:
    """({(im_id, obj_id): (s_u, s_v, b, rest)} at the exact GT, {image key: im_id})."""
    ns = argparse.Namespace(suite_root=a.suite_root, dataset=a.dataset, suite=a.suite, scenes=str(a.scene),
                            frames="", supersample=1, images=str(images), sigma_px=1.0, min_samples=a.min_samples)
    shifts, views = {}, {}
    for _, fr, _, fld, _, oid, uv, n in lit_contour_groups(ns):
        views[_key(fr.load_rgb())] = fr.im_id
        f = shift_fit(fld, uv, n, a.min_samples)
        if f is not None:
            shifts[(fr.im_id, oid)] = f
    return shifts, views


def with_oracle(shifts: dict, views: dict, max_sigma_px: float = 1.5):
    """Patch the refiner so that f_edge's contour candidates of each (view, object) move by its
    measured shift at blur levels up to ``max_sigma_px``; returns the function that undoes it."""
    import ycbvss.refine.bundle as B

    obs, lec = B._observations, B._lit_edge_candidates
    obj_ids: list = []

    def observations(*args, **kw):
        out = obs(*args, **kw)
        obj_ids[:] = out[1]                   # the problem's object index -> obj_id
        return out

    def lit_edge_candidates(vr, image, *args, **kw):
        out = lec(vr, image, *args, **kw)
        sig = args[3].get("blur_sigma_px") if len(args) > 3 else None
        im_id = views.get(_key(image)) if image is not None else None
        if im_id is None or sig is None or sig > max_sigma_px:
            return out
        c = out[2]
        uv = c.uv_c.copy()
        for k, j in enumerate(vr.obj_index):
            f = shifts.get((im_id, obj_ids[j]))
            if f is not None:
                uv[c.l_c == k + 1] += (f[0], f[1])
        return out[:2] + (replace(c, uv_c=uv),)

    B._observations, B._lit_edge_candidates = observations, lit_edge_candidates

    def undo() -> None:
        B._observations, B._lit_edge_candidates = obs, lec
    return undo


def main() -> None:
    from ycbvss.pipeline.suite import SUITES, suite_models

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--bias-root", required=True, type=Path, help="a bench_bias_lighting.py --out folder")
    ap.add_argument("--variant", default="suite_lights", help="its rendered lighting (subfolder)")
    ap.add_argument("--suite-root", required=True, help="the suite's root (its models)")
    ap.add_argument("--suite", default="ycbv21")
    ap.add_argument("--scene", type=int, default=1)
    ap.add_argument("--min-samples", type=int, default=40)
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    images = a.bias_root / a.variant
    spec = next(s for s in SUITES[a.suite] if s.scene_id == a.scene)
    models = suite_models(a.dataset, a.bias_root / "models_src", spec.obj_ids)
    base = bias_from_gt(images, spec, models, {})
    shifts, views = measured_shifts(a, images)
    undo = with_oracle(shifts, views)
    try:
        oracle = bias_from_gt(images, spec, models, {})
    finally:
        undo()
    print(f"scene {a.scene}, {len(views)} frames, cameras fixed at the GT, from the exact GT; {len(shifts)} "
          f"(view, object) shifts measured; R (deg) and mean translation (mm): as the refiner is -> with the oracle")
    for o in sorted(base):
        (r0, _, t0), (r1, _, t1) = base[o], oracle[o]
        print(f"  {getattr(models[o], 'name', None) or o!s:24s} R {r0:.3f} -> {r1:.3f}   "
              f"t {np.round(t0, 3)} -> {np.round(t1, 3)}")
    print(f"  mean R {np.mean([v[0] for v in base.values()]):.3f} -> {np.mean([v[0] for v in oracle.values()]):.3f}")


if __name__ == "__main__":
    main()
