"""Time and peak memory of refining one long video (YCB-V videos have ~2000 frames) with keyframes.

A table-top scene of six YCB-V models (``ycbvss.procedural.ycbv_scene``) on a slow hand-held path;
the images are drawn on demand by the fast renderer (this measures time and memory, not accuracy:
the suite does that with Blender images) and never all held at once; the initial poses are the GT
with the paper's per-(view, object) deviation. Prints wall time, time per frame and per
frame*object, and the peak RSS; run it at two lengths to see that memory does not grow with the
video.

    python bench/bench_refine_long.py --frames 2000 --models /path/to/bop/ycbv/models
    python bench/bench_refine_long.py --frames 2000 --models ... --objects 1,5,8,10,14,19 --keyframes-only \
        --opt flow_prior_levels=all        # the keyframe bundle alone (~4 min), with option overrides
"""
from __future__ import annotations

import argparse
import re
import resource
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np


class LazyImages:
    """``images.get(im_id)`` renders frame ``im_id`` when the refiner asks for it (nothing cached)."""

    def __init__(self, scene):
        from ycbvss.procedural.render import _renderer, render_frame_fast
        self.scene, self.render = scene, render_frame_fast
        self.gl = _renderer(scene)          # one GL context with the meshes, reused for every frame
        self.frames = {f.im_id: f for f in scene.frames}
        self.n_rendered = 0

    def get(self, im_id, default=None):
        f = self.frames.get(im_id)
        if f is None:
            return default
        self.n_rendered += 1
        return self.render(self.scene, f, self.gl, noise_sigma=1.5)[0]


def _keyframes_only(ps, gt: dict, init: dict, opt, imgs, oids: list[int]) -> int:
    """Refine up to the keyframe bundle and print each object's error in the keyframes (the
    bundle's world poses, which the non-keyframe stage keeps): a diagnostic that wraps the private
    ``ycbvss.refine.bundle._refine_keyframes`` and stops the run after it."""
    import ycbvss.refine.bundle as bundle
    from ycbvss.refine import refine_scene

    class _Done(Exception):
        pass

    inner = bundle._refine_keyframes

    def report(views, kf, obj_ids, T_c_kf, T_m, tag):
        for j, o in enumerate(obj_ids):
            e = np.array([(T_c_kf[a] @ T_m[j])[:3, 3] - gt[(views[i].im_id, o)][:3, 3]
                          for a, i in enumerate(kf) if (views[i].im_id, o) in gt])
            print(f"  {tag} obj {o}: |t err| median {np.median(np.linalg.norm(e, axis=1)):.2f} mm, "
                  f"mean signed dz {e[:, 2].mean():+.2f} mm")

    def wrapped(views, models, obj_ids, known, pb0, kf, opt_, log, stats, imgs_):
        report(views, kf, obj_ids, pb0.T_c[kf], pb0.T_m, "initial")
        t0 = time.perf_counter()
        ks = inner(views, models, obj_ids, known, pb0, kf, opt_, log, stats, imgs_)
        print(f"keyframe bundle: {len(kf)} keyframes, {time.perf_counter() - t0:.0f} s, "
              f"bias removal {stats.get('bias_removal')}")
        report(views, kf, obj_ids, ks.T_c[kf], ks.T_m, "refined")
        raise _Done

    bundle._refine_keyframes = wrapped
    try:
        refine_scene(ps.scene, ps.models, init, opt, images=imgs)
    except _Done:
        pass
    finally:
        bundle._refine_keyframes = inner
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--frames", type=int, default=2000)
    ap.add_argument("--objects", default="2,3,5,10,14,19", help="obj_ids (default: six of the 21)")
    ap.add_argument("--models", type=Path, required=True, help="BOP models folder of YCB-V (e.g. from ycbvss convert)")
    ap.add_argument("--keyframes", type=int, default=16, help="number of jointly refined keyframes")
    ap.add_argument("--width", type=int, default=640)
    ap.add_argument("--keyframes-only", action="store_true",
                    help="stop after the keyframe bundle (initialised from every frame, as in the full run) and "
                         "print its per-object error in the keyframes: the world poses every frame inherits, in minutes")
    ap.add_argument("--opt", nargs="*", default=[], help="RefineOptions overrides NAME=VALUE (Python literals)")
    args = ap.parse_args(argv)

    from bench_refine import _option_override    # NAME=VALUE -> a RefineOptions override (checked)
    from ycbvss.io.bop import load_models
    from ycbvss.pipeline.perturb import perturb_poses
    from ycbvss.procedural.ycbv_scene import make_ycbv_scene
    from ycbvss.refine import RefineOptions, refine_scene

    models = load_models(args.models)
    oids = [int(x) for x in args.objects.split(",")]
    t0 = time.perf_counter()
    ps = make_ycbv_scene(models, oids, seed=7, n_frames=args.frames, arc_deg=75.0, width=args.width,
                         height=args.width * 3 // 4)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    Ks = {k: ps.frames[0].camera.K for k in gt}
    # the paper's initial error (ADD 22.1 mm, PRJ 5.2 px at YCB-V's 640 px): PRJ scales with the width,
    # so that a smaller image gets the same angular error (unscaled, 320 px had twice the paper's)
    init = perturb_poses(gt, Ks, {o: models[o].vertices_mm for o in oids}, 22.1, 5.2 * args.width / 640, seed=1).poses
    t_setup = time.perf_counter() - t0
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    imgs = LazyImages(ps)
    opt = RefineOptions(keyframe_step=max(1, args.frames // args.keyframes), **dict(_option_override(a) for a in args.opt))
    if args.keyframes_only:
        return _keyframes_only(ps, gt, init, opt, imgs, oids)
    t0 = time.perf_counter()
    res = refine_scene(ps.scene, ps.models, init, opt, images=imgs)
    wall = time.perf_counter() - t0
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    err = np.array([np.linalg.norm(res.poses[k][:3, 3] - gt[k][:3, 3]) for k in gt])
    n = len(ps.frames)
    print(f"frames {n}, objects {len(oids)}, {args.width}px, keyframe step {max(1, args.frames // args.keyframes)}")
    print(f"setup {t_setup:.1f} s; refine {wall:.1f} s wall = {wall / n:.3f} s/frame = "
          f"{wall / (n * len(oids)):.3f} s per frame*object; images rendered {imgs.n_rendered}")
    print(f"of it choosing the non-keyframes' initial cameras {res.stats.get('nonkey_choose_s', 0.0):.1f} s "
          f"({res.stats.get('nonkey_switched', 0)} switched to the keyframes' interpolation)")
    print(f"peak RSS {rss:.0f} MB (before refining {rss0:.0f} MB); median |t err| {np.median(err):.2f} mm; "
          f"statuses {{{', '.join(f'{s}: {sum(v == s for v in res.status.values())}' for s in ('converged', 'uncertain', 'failed'))}}}")
    # what the statuses rest on: the translation error per status and per object, and the reasons
    keys = list(gt)
    e_by = {k: float(e) for k, e in zip(keys, err)}
    for s in ("converged", "uncertain", "failed"):
        es = [e_by[k] for k in keys if res.status.get(k) == s]
        if es:
            print(f"  {s}: {len(es)} poses, |t err| median {np.median(es):.2f} / 90 % {np.percentile(es, 90):.2f} / max {max(es):.2f} mm")
    for o in oids:
        ks = [k for k in keys if k[1] == o]
        st = {s: sum(res.status.get(k) == s for k in ks) for s in ("converged", "uncertain", "failed")}
        print(f"  obj {o}: |t err| median {np.median([e_by[k] for k in ks]):.2f} mm, {st}")
    kinds = Counter(re.sub(r"[-+]?[0-9]+(\.[0-9]+)?", "#", part) for k in keys
                    for part in (res.reasons.get(k) or "").split("; ") if part)
    for kind, n_k in kinds.most_common(6):
        print(f"  reason ({n_k} poses): {kind}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
