"""Probe: f_t's matches at the exact GT between view pairs: do they carry a scale (a shrink of the
inter-frame displacement)? r = matched xd - GT transfer of Y_k; least squares r = a * disp (+ b)."""
import sys, warnings
import numpy as np
from pathlib import Path
warnings.simplefilter("ignore")
from ycbvss.io.bop import load_bop_scene
from ycbvss.pipeline.suite import SUITES, suite_models
from ycbvss.refine.templates import ensure_meshes, get_renderer, render_view
from ycbvss.refine.bundle import _pair_flows, _pair_matches, _bbox, RefineOptions
from ycbvss.refine.matching import min_eig_map
from ycbvss.refine.flow_prior import relative_motion
from ycbvss.refine.jacobians import backproject_px, project_points
root, sid, mode, suite = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3], sys.argv[4]
frames = [int(x) for x in sys.argv[5].split(",")]
spec = next(s for s in SUITES[suite] if s.scene_id == sid)
models = suite_models("../shared/data/ycbv", Path("/tmp/s91/models_src"), spec.obj_ids)
sc = load_bop_scene(root / "test", sid, models)
fr = {f.im_id: f for f in sc.frames}
opt = RefineOptions()
r = get_renderer(); ensure_meshes(r, models)
def rend(f):
    cam = f.camera
    return render_view(r, models, [i.obj_id for i in f.instances], cam.K, cam.width, cam.height,
                       {j: i.T_m2c for j, i in enumerate(f.instances)})
def T_w2c(f):
    return f.T_w2c
A = []
for p, q in zip(frames[:-1], frames[1:]):
    fa, fb = fr[p], fr[q]
    va, vb = rend(fa), rend(fb)
    ia, ib = fa.load_rgb(), fb.load_rgb()
    box = _bbox((va.instance > 0) | (vb.instance > 0), 2 * opt.flow_margin_px)
    pred = (va.depth_mm, fa.camera.K, fb.camera.K, relative_motion(T_w2c(fa), T_w2c(fb)),
            vb.depth_mm, relative_motion(T_w2c(fb), T_w2c(fa)))
    prior = mode if mode != "plain" else False
    fab, fba = _pair_flows(ia, ib, box, opt.flow, prior, pred if prior else None)
    y0, y1, x0, x1 = box
    xs, xd = _pair_matches(va, opt.match_erode_px, opt.match_core_px, box, (fab, fba), opt.flow, ia, min_eig_map(ia), min_eig_map(ib))
    xs, xd = xs + (x0, y0), xd + (x0, y0)
    d = va.depth_mm[xs[:, 1].round().astype(int), xs[:, 0].round().astype(int)].astype(float)
    ok = d > 0
    Y = backproject_px(fa.camera.K, xs[ok], d[ok])
    T = relative_motion(T_w2c(fa), T_w2c(fb))
    x_gt = project_points(fb.camera.K, T, Y)
    x_gt = x_gt[0] if isinstance(x_gt, tuple) else x_gt
    res = xd[ok] - x_gt
    disp = x_gt - xs[ok]
    a = float((res * disp).sum() / (disp * disp).sum())
    # also depth rounding: exact depth at sub-pixel via bilinear of depth? report mean |disp|
    print(f"pair {p}->{q}: n {ok.sum()}, |disp| mean {np.linalg.norm(disp, axis=1).mean():.2f} px, "
          f"res mean ({res[:,0].mean():+.3f}, {res[:,1].mean():+.3f}) rms {np.sqrt((res**2).sum(1).mean()):.3f} px, "
          f"shrink a = {a*100:+.3f} %")
    A.append(a)
print(f"mean shrink a = {np.mean(A)*100:+.3f} %")
