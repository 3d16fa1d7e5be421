"""Objects cut by the image border (as 002_master_chef_can in YCB-V video 0001): the truncated
side of the rendered silhouette is no image edge, so the refiner must not pull it onto one.
Procedural scene (fast renderer, exact GT) whose principal point is shifted so that one object's
silhouette is cut about in half by the right image border (a textureless box in seed 1).
Note: with the border exclusion of ycbvss.refine.edge removed, this scene gave PRJ 0.71 px
(vs 0.47 px): on rendered data a truncated side lies exactly on the border, where the edge field
is flat, so it pulls little; the test guards the truncated-object path as a whole. Budget: ~6 s."""
from __future__ import annotations

import numpy as np
import pytest

from ycbvss.camera import Camera
from ycbvss.refine import RefineOptions, refine_scene
from ycbvss.eval.metrics import pose_errors_4x4
from ycbvss.refine.deviation import deviate_scene


@pytest.fixture(scope="module")
def cut_scene():
    from ycbvss.procedural.render import render_frame_fast
    from ycbvss.procedural.scene import make_scene

    W, H = 320, 240
    ps = make_scene(seed=1, n_frames=3, width=W, height=H, arc_deg=30)
    f0 = ps.frames[0]
    K = f0.camera.K
    # the object whose centre projects right-most in the first frame; per frame, shift cx to put its
    # centre on the right border (each frame keeps its own K)
    u = {i.obj_id: K[0, 0] * i.T_m2c[0, 3] / i.T_m2c[2, 3] + K[0, 2] for i in f0.instances}
    cut = max(u, key=u.get)
    for f in ps.frames:
        T = next(i.T_m2c for i in f.instances if i.obj_id == cut)
        K2 = f.camera.K.copy()
        K2[0, 2] += (W - 1) - (K2[0, 0] * T[0, 3] / T[2, 3] + K2[0, 2])
        f.camera = Camera(K2, W, H)
    imgs, masks = {}, {}
    for f in ps.frames:
        rgb, _, inst = render_frame_fast(ps, f, noise_sigma=1.0)
        imgs[f.im_id], masks[f.im_id] = rgb, inst
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    pts = {o: np.asarray(m.mesh.vertices)[:: max(1, len(m.mesh.vertices) // 400)] for o, m in ps.models.items()}
    return ps, imgs, masks, gt, pts, cut


def test_object_cut_by_the_image_border_is_refined(cut_scene):
    ps, imgs, masks, gt, pts, cut = cut_scene
    # the object really is cut: it touches the right border in every frame
    for im_id, inst in masks.items():
        assert (inst[:, -1] == cut).sum() >= 10, im_id
    init = deviate_scene(ps.T_m2w, {f.im_id: f.T_w2c for f in ps.frames}, np.random.default_rng(3),
                         t_sigma_mm=(3.0, 3.0, 20.0), r_sigma_deg=2.0)
    res = refine_scene(ps.scene, ps.models, init, RefineOptions(compute_uncertainty=False), images=imgs)
    Ks = {f.im_id: f.camera.K for f in ps.frames}

    def err(poses, o):
        e = [pose_errors_4x4(poses[k], gt[k], Ks[k[0]], pts[o]) for k in gt if k[1] == o]
        return {m: float(np.mean([x[m] for x in e])) for m in ("tz_mm", "r_deg", "prj_px", "add_mm")}

    e0, e1 = err(init, cut), err(res.poses, cut)
    assert e0["prj_px"] > 2.0 and e0["add_mm"] > 8.0, e0          # the init really is off
    # measured (seed 3): init PRJ 4.3 px / ADD 20.3 mm -> PRJ 0.47 px, R 0.43 deg, ADD 5.6 mm (depth is
    # weaker than for the uncut object, ADD 0.85 mm: half of its contour is gone)
    assert e1["prj_px"] < 0.8, (e0, e1)                           # sub-pixel although half of it is cut
    assert e1["r_deg"] < 1.5 and e1["add_mm"] < e0["add_mm"] / 2.5, (e0, e1)
