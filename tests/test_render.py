"""Tests of the headless renderer (ycbvss.render). Budget: < 20 s total on 2 cores (llvmpipe)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

from ycbvss.camera import backproject, project
from ycbvss.errors import YcbvssError
from ycbvss.geometry.so3 import exp_so3
from ycbvss.render import Renderer, clip_to_pixels, mesh_texture, projection_from_K, roi_K

K0 = np.array([[520.0, 0.0, 161.3], [0.0, 515.0, 118.7], [0.0, 0.0, 1.0]])
W0, H0 = 320, 240


def pose(rotvec=(0.0, 0.0, 0.0), t=(0.0, 0.0, 600.0)) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = exp_so3(np.asarray(rotvec, dtype=float))
    T[:3, 3] = t
    return T


@pytest.fixture(scope="module")
def r() -> Renderer:
    r = Renderer()
    r.add_mesh("sphere", trimesh.creation.icosphere(subdivisions=4, radius=50.0))
    r.add_mesh("box", trimesh.creation.box(extents=(80.0, 60.0, 40.0)))
    # a big 2-triangle quad (z = 0 plane, normal +z, double-sided when rendered without culling)
    quad = trimesh.Trimesh([[-5000, -5000, 0], [5000, -5000, 0], [5000, 5000, 0], [-5000, 5000, 0]],
                           [[0, 1, 2], [0, 2, 3]], process=False)
    r.add_mesh("quad", quad)
    return r


@pytest.fixture(scope="module")
def ycb_mesh(ycbv_root):
    m = trimesh.load(ycbv_root / "models" / "006_mustard_bottle" / "textured.obj", force="mesh", process=False)
    m.apply_scale(1000.0)
    return m


def test_projection_matrix_equals_pinhole():
    rng = np.random.default_rng(1)
    for _ in range(5):
        K = np.array([[rng.uniform(300, 1500), rng.uniform(-2, 2), rng.uniform(-50, 700)],
                      [0, rng.uniform(300, 1500), rng.uniform(-50, 500)], [0, 0, 1.0]])
        X = rng.uniform([-300, -300, 200], [300, 300, 3000], size=(100, 3))
        P = projection_from_K(K, 640, 480, 10.0, 20000.0)
        err = np.abs(clip_to_pixels(P, X, 640, 480) - project(K, X)).max()
        assert err < 1e-9


def test_vertices_project_inside_mask(r, ycb_mesh):
    r.add_mesh("mustard", ycb_mesh)
    T = pose((0.4, -0.3, 0.2), (20.0, -10.0, 700.0))
    out = r.render(K0, W0, H0, [("mustard", T)], outputs=("instance",))
    X = ycb_mesh.vertices @ T[:3, :3].T + T[:3, 3]
    uv = np.rint(project(K0, X)).astype(int)
    assert uv[:, 0].min() >= 0 and uv[:, 0].max() < W0 and uv[:, 1].min() >= 0 and uv[:, 1].max() < H0
    m = out.instance == 1
    # allow 1 px (a vertex on the silhouette may lie in a pixel whose centre is not covered)
    import cv2
    md = cv2.dilate(m.astype(np.uint8), np.ones((3, 3), np.uint8)) > 0
    inside = md[uv[:, 1], uv[:, 0]].mean()
    assert inside >= 0.9995, inside
    # and the rendered mask does not extend beyond the vertices' footprint (bbox within 1 px)
    ys, xs = np.nonzero(m)
    assert abs(xs.min() - uv[:, 0].min()) <= 1 and abs(xs.max() - uv[:, 0].max()) <= 1
    assert abs(ys.min() - uv[:, 1].min()) <= 1 and abs(ys.max() - uv[:, 1].max()) <= 1


def test_plane_depth_matches_ray_intersection(r):
    T = pose((0.5, 0.3, 0.0), (30.0, -20.0, 1200.0))
    out = r.render(K0, W0, H0, [("quad", T)], outputs=("depth", "instance"))
    assert (out.instance == 1).all()
    n, p0 = T[:3, 2], T[:3, 3]
    u, v = np.meshgrid(np.arange(W0, dtype=float), np.arange(H0, dtype=float))
    rays = backproject(K0, np.stack([u, v], -1), np.ones((H0, W0)))  # z = 1
    z_true = (n @ p0) / (rays @ n)
    err = np.abs(out.depth_mm - z_true)
    assert out.depth_mm.dtype == np.float32
    assert err.max() < 1e-3 and np.median(err) < 5e-4, (err.max(), np.median(err))  # mm, z 1.0-1.6 m


def test_principal_point_shift_moves_image_exactly(r):
    items = [("sphere", pose(t=(10.0, 5.0, 500.0))), ("box", pose((0.2, 0.5, 0.1), (-40.0, 10.0, 420.0)))]
    a = r.render(K0, W0, H0, items, outputs=("depth", "instance"))
    K2 = K0.copy()
    K2[0, 2] += 7
    K2[1, 2] -= 4
    b = r.render(K2, W0, H0, items, outputs=("depth", "instance"))
    # b[v, u] == a[v + 4, u - 7]
    sa, sb = a.depth_mm[4:, :-7], b.depth_mm[:-4, 7:]
    assert np.abs(sa - sb).max() < 1e-3
    assert (a.instance[4:, :-7] != b.instance[:-4, 7:]).sum() == 0
    # half-pixel shift: pixel-centre convention -> the silhouette centroid moves by exactly 0.5 px
    K3 = K0.copy()
    K3[0, 2] += 0.5
    c = r.render(K3, W0, H0, items[:1], outputs=("instance",))
    d = r.render(K0, W0, H0, items[:1], outputs=("instance",))
    cx_c = np.nonzero(c.instance)[1].mean()
    cx_d = np.nonzero(d.instance)[1].mean()
    assert abs((cx_c - cx_d) - 0.5) < 0.05


def raycast_pixel_centres(V_cam: np.ndarray, F: np.ndarray, K: np.ndarray, W: int, H: int) -> np.ndarray:
    """Reference ray caster (no GL): z of the first hit of the ray through every pixel centre, 0 if none.

    The ray through pixel centre p hits triangle f iff p lies inside f's projection (triangles in front of
    the camera); the hit's z follows from the ray/plane intersection.  Candidate (triangle, pixel) pairs come
    from each triangle's pixel bounding box.  (trimesh.ray needs rtree, which is not installed.)
    """
    tri = V_cam[F]                                       # (M, 3, 3)
    assert (tri[..., 2] > 1).all()
    uv = project(K, tri)                                 # (M, 3, 2)
    lo = np.ceil(uv.min(1)).astype(int)
    hi = np.floor(uv.max(1)).astype(int)
    nx, ny = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0), np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    cnt = nx * ny
    f = np.repeat(np.arange(len(F)), cnt)
    k = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    px = lo[f, 0] + k % nx[f]
    py = lo[f, 1] + k // nx[f]
    a, b, c = uv[f, 0], uv[f, 1], uv[f, 2]
    p = np.stack([px, py], -1).astype(float)

    def cross(o, q, r_):
        return (q[:, 0] - o[:, 0]) * (r_[:, 1] - o[:, 1]) - (q[:, 1] - o[:, 1]) * (r_[:, 0] - o[:, 0])

    w0, w1, w2 = cross(b, c, p), cross(c, a, p), cross(a, b, p)
    inside = ((w0 >= 0) & (w1 >= 0) & (w2 >= 0)) | ((w0 <= 0) & (w1 <= 0) & (w2 <= 0))
    inside &= (px >= 0) & (px < W) & (py >= 0) & (py < H) & (np.abs(w0 + w1 + w2) > 1e-12)
    f, px, py = f[inside], px[inside], py[inside]
    n = np.cross(tri[f, 1] - tri[f, 0], tri[f, 2] - tri[f, 0])
    ray = backproject(K, np.stack([px, py], -1).astype(float), np.ones(len(f)))
    z = (n * tri[f, 0]).sum(-1) / (n * ray).sum(-1)
    zbuf = np.full(H * W, np.inf)
    np.minimum.at(zbuf, py * W + px, z)
    return np.where(np.isfinite(zbuf), zbuf, 0.0).reshape(H, W)


def test_silhouette_and_depth_match_reference_raycast(r, ycb_mesh):
    r.add_mesh("mustard", ycb_mesh)
    Ws, Hs = 96, 72
    K = np.array([[260.0, 0, 47.3], [0, 258.0, 35.9], [0, 0, 1]])
    T = pose((1.1, 0.2, -0.4), (0.0, 0.0, 520.0))
    out = r.render(K, Ws, Hs, [("mustard", T)], outputs=("depth", "instance"))
    z_ray = raycast_pixel_centres(ycb_mesh.vertices @ T[:3, :3].T + T[:3, 3], np.asarray(ycb_mesh.faces),
                                  K, Ws, Hs)
    m, hit = out.instance > 0, z_ray > 0
    iou = (m & hit).sum() / (m | hit).sum()
    assert iou > 0.995, iou
    both = m & hit
    dz = np.abs(out.depth_mm[both] - z_ray[both])
    assert np.median(dz) < 2e-4 and np.percentile(dz, 99) < 1e-3, (np.median(dz), np.percentile(dz, 99))


def test_mutual_occlusion_instance_and_masks_all(r):
    near = pose(t=(0.0, 0.0, 400.0))
    far = pose(t=(30.0, 0.0, 600.0))
    out = r.render(K0, W0, H0, [("sphere", far), ("box", near)],
                   outputs=("depth", "instance", "mask_all"))
    m_far, m_near = out.masks_all
    assert (out.instance[m_near] == 2).all()
    vis_far = out.instance == 1
    assert (vis_far == (m_far & ~m_near)).all()
    assert 0 < vis_far.sum() < m_far.sum()
    # per-item depth is the unoccluded one; composite depth = min over items
    d_all = np.stack([np.where(d > 0, d, np.inf) for d in out.depth_all_mm])
    comp = np.where(np.isfinite(d_all.min(0)), d_all.min(0), 0)
    assert np.abs(comp - out.depth_mm).max() < 1e-3
    assert abs(out.depth_all_mm[1][m_near].min() - 380.0) < 1e-3  # box front face at z = 400 - 20


def test_normals_of_sphere(r):
    c = np.array([15.0, -10.0, 500.0])
    T = pose((0.3, 0.2, 0.1), c)
    out = r.render(K0, W0, H0, [("sphere", T)], outputs=("depth", "normal"))
    m = out.depth_mm > 0
    Xc = backproject(K0, np.stack(np.meshgrid(np.arange(W0), np.arange(H0)), -1), out.depth_mm)
    n_true = (Xc - c) / np.linalg.norm(Xc - c, axis=-1, keepdims=True)
    cosang = np.clip((out.normal_cam[m] * n_true[m]).sum(-1), -1, 1)
    ang = np.degrees(np.arccos(cosang))
    assert np.percentile(ang, 99) < 2.0, np.percentile(ang, 99)
    assert np.abs(np.linalg.norm(out.normal_cam[m], axis=-1) - 1).max() < 1e-3
    assert (out.normal_cam[~m] == 0).all() and np.isfinite(out.normal_cam).all()


def test_texture_vertex_colour_and_grey():
    r = Renderer(mipmap=False)
    # quad textured with a 2x2 image; uv (0,0) bottom-left (OBJ convention)
    img = np.array([[[255, 0, 0], [0, 255, 0]], [[0, 0, 255], [255, 255, 0]]], np.uint8)  # row 0 = top
    img = np.repeat(np.repeat(img, 64, 0), 64, 1)
    V = np.array([[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]], float)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], float)  # model -y (image top) = uv v 1 = image row 0
    from PIL import Image
    quad = trimesh.Trimesh(V, [[0, 1, 2], [0, 2, 3]], process=False,
                           visual=trimesh.visual.TextureVisuals(uv=uv, image=Image.fromarray(img)))
    r.add_mesh("tq", quad)
    out = r.render(K0, W0, H0, [("tq", pose(t=(0, 0, 1000.0)))], outputs=("color", "instance"))
    # model point (x, y) -> image pixel: x -> right, y -> down. Top-left quadrant (x<0, y<0) = img row 0 col 0
    u0, v0 = K0[0, 2], K0[1, 2]
    off = 0.5 * 100 * K0[0, 0] / 1000.0
    expect = {(-1, -1): (255, 0, 0), (1, -1): (0, 255, 0), (-1, 1): (0, 0, 255), (1, 1): (255, 255, 0)}
    for (sx, sy), rgb in expect.items():
        px = out.color[int(round(v0 + sy * off)), int(round(u0 + sx * off))]
        assert np.abs(px.astype(int) - rgb).max() <= 2, (sx, sy, px)
    assert (out.color[out.instance == 0] == 0).all()
    # vertex colours
    box = trimesh.creation.box(extents=(50, 50, 50))
    box.visual.vertex_colors = np.tile([10, 200, 30, 255], (len(box.vertices), 1))
    r.add_mesh("vc", box)
    # no visual -> grey 0.6
    r.add_mesh("grey", trimesh.Trimesh(box.vertices, box.faces, process=False))
    out = r.render(K0, W0, H0, [("vc", pose(t=(-60, 0, 500.0))), ("grey", pose(t=(60, 0, 500.0)))],
                   outputs=("color", "instance"))
    assert np.abs(np.median(out.color[out.instance == 1], 0) - [10, 200, 30]).max() <= 1
    assert np.abs(np.median(out.color[out.instance == 2], 0) - 153).max() <= 1
    r.release()


def test_srgb_textures_average_a_minified_texture_in_linear_light():
    """A black and white 1-texel checker seen far away (minified about 8x): filtered on its sRGB
    values it reads mid grey 128; as an sRGB texture, averaged in linear light as a camera does, it
    reads the encoding of 0.5, 188. Vertex colours and untextured meshes keep their colour."""
    from PIL import Image

    img = ((np.indices((256, 256)).sum(axis=0) % 2) * 255).astype(np.uint8)
    img = np.repeat(img[..., None], 3, axis=2)
    V = np.array([[-100, -100, 0], [100, -100, 0], [100, 100, 0], [-100, 100, 0]], float)
    uv = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], float)
    quad = trimesh.Trimesh(V, [[0, 1, 2], [0, 2, 3]], process=False,
                           visual=trimesh.visual.TextureVisuals(uv=uv, image=Image.fromarray(img)))
    box = trimesh.creation.box(extents=(50, 50, 50))
    box.visual.vertex_colors = np.tile([10, 200, 30, 255], (len(box.vertices), 1))
    means = {}
    for srgb in (False, True):
        r = Renderer(srgb_textures=srgb)
        r.add_mesh("checker", quad)
        r.add_mesh("vc", box)
        out = r.render(K0, W0, H0, [("checker", pose(t=(0, 0, 3200.0)))], outputs=("color", "instance"))
        means[srgb] = float(out.color[out.instance == 1].mean())
        out = r.render(K0, W0, H0, [("vc", pose(t=(0, 0, 500.0)))], outputs=("color", "instance"))
        assert np.abs(np.median(out.color[out.instance == 1], 0) - [10, 200, 30]).max() <= 1
        r.release()
    assert abs(means[False] - 128.0) < 4.0
    assert abs(means[True] - 188.0) < 4.0


def test_mesh_texture_of_ycb_and_missing_texture(ycb_mesh):
    uv, img = mesh_texture(ycb_mesh)
    assert uv.shape == (len(ycb_mesh.vertices), 2) and uv.dtype == np.float32
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8 and img.shape[0] >= 1024
    bare = trimesh.Trimesh(ycb_mesh.vertices, ycb_mesh.faces, process=False,
                           visual=trimesh.visual.TextureVisuals(uv=ycb_mesh.visual.uv))
    bare.visual.material.image = None
    with pytest.warns(UserWarning, match="no texture"):
        uv2, img2 = mesh_texture(bare)
    assert img2 is None and len(uv2) == len(ycb_mesh.vertices)


def test_textured_ycb_colour_is_textured(r, ycb_mesh):
    r.add_mesh("mustard", ycb_mesh)
    out = r.render(K0, W0, H0, [("mustard", pose((1.5, 0, 0), (0, 0, 600.0)))], outputs=("color", "instance"))
    c = out.color[out.instance == 1].astype(float)
    # mustard bottle is mostly yellow: mean R, G well above B, and texture varies
    assert c[:, 0].mean() > c[:, 2].mean() + 60 and c[:, 1].mean() > c[:, 2].mean() + 40
    assert c.std(0).max() > 10


def test_culling_does_not_change_closed_mesh(ycb_mesh):
    items = [("m", pose((0.7, -1.0, 0.3), (10, 0, 450.0)))]
    outs = {}
    for cull in (True, False):
        rr = Renderer(cull_back_faces=cull)
        rr.add_mesh("m", ycb_mesh)
        outs[cull] = rr.render(K0, W0, H0, items, outputs=("depth", "instance"))
        rr.release()
    assert (outs[True].instance != outs[False].instance).sum() <= 2
    assert np.abs(outs[True].depth_mm - outs[False].depth_mm).max() < 1e-2


def test_scale_about_origin(r):
    T = pose((0.3, 0.2, 0.0), (0, 0, 800.0))
    a = r.render(K0, W0, H0, [("sphere", T)], outputs=("depth",), scales=[1.04])
    # icosphere radius 50 scaled 1.04 == radius 52; nearest depth = 800 - 52 on the optical ray through centre
    z_min = a.depth_mm[a.depth_mm > 0].min()
    assert abs(z_min - (800 - 52)) < 0.2, z_min
    b = r.render(K0, W0, H0, [("sphere", T)], outputs=("depth",))
    ratio = (a.depth_mm > 0).sum() / (b.depth_mm > 0).sum()
    assert abs(ratio - 1.04 ** 2) < 0.02, ratio


def test_robust_near_plane_offscreen_empty(r):
    empty = r.render(K0, W0, H0, [], outputs=("depth", "instance", "normal", "color", "mask_all"))
    assert empty.depth_mm.shape == (H0, W0) and not empty.depth_mm.any() and not empty.instance.any()
    assert empty.masks_all == [] and not empty.color.any()
    behind = r.render(K0, W0, H0, [("sphere", pose(t=(0, 0, -300.0)))], outputs=("depth", "instance"))
    assert not behind.instance.any()
    offimg = r.render(K0, W0, H0, [("sphere", pose(t=(5000, 0, 300.0)))], outputs=("depth", "instance"))
    assert not offimg.instance.any()
    # centre 20 px left of the image, radius ~87 px: must not be frustum-culled; visible part is analytic
    zc = 300.0
    xc = (-20 - K0[0, 2]) * zc / K0[0, 0]
    edge = r.render(K0, W0, H0, [("sphere", pose(t=(xc, 0, zc)))], outputs=("instance", "mask_all"))
    cols = np.nonzero(edge.instance.any(0))[0]
    r_px = K0[0, 0] * 50.0 / np.sqrt(zc ** 2 - 50.0 ** 2)  # apparent radius (tangent cone)
    assert cols.min() == 0 and abs(cols.max() - (-20 + r_px)) < 1.5, (cols.max(), -20 + r_px)
    assert (edge.masks_all[0] == (edge.instance == 1)).all()
    # box straddling the near plane (x 5..85, z 5..45 mm, znear 10), camera outside it
    cut = r.render(K0, W0, H0, [("box", pose(t=(45, 0, 25.0)))], outputs=("depth", "instance", "normal"),
                   znear_mm=10.0)
    d = cut.depth_mm
    assert np.isfinite(d).all() and np.isfinite(cut.normal_cam).all()
    assert cut.instance.sum() > 100 and d[d > 0].min() >= 10.0 - 1e-3 and d.max() <= 45.0 + 1e-3
    # camera inside a closed box (a room): its inner walls are seen although the box is auto-culled
    inside = r.render(K0, W0, H0, [("box", pose(t=(0, 0, 5.0)))], outputs=("depth", "instance"), znear_mm=1.0)
    assert inside.instance.all() and abs(inside.depth_mm[int(K0[1, 2]), int(K0[0, 2])] - 25.0) < 1e-3


def test_roi_render_equals_crop_of_full_render(r):
    items = [("sphere", pose(t=(10.0, 5.0, 500.0))), ("box", pose((0.2, 0.5, 0.1), (-40.0, 10.0, 420.0)))]
    full = r.render(K0, W0, H0, items, outputs=("depth", "instance", "normal"))
    x0, y0, w, h = 101, 57, 90, 70
    crop = r.render(roi_K(K0, x0, y0), w, h, items, outputs=("depth", "instance", "normal"))
    assert (crop.instance != full.instance[y0:y0 + h, x0:x0 + w]).sum() == 0
    assert np.abs(crop.depth_mm - full.depth_mm[y0:y0 + h, x0:x0 + w]).max() < 1e-3
    assert np.abs(crop.normal_cam - full.normal_cam[y0:y0 + h, x0:x0 + w]).max() < 1e-4


def test_headlight_shading_darkens_grazing_surfaces(r):
    out0 = r.render(K0, W0, H0, [("sphere", pose(t=(0, 0, 400.0)))], outputs=("color", "depth"))
    out1 = r.render(K0, W0, H0, [("sphere", pose(t=(0, 0, 400.0)))], outputs=("color", "depth"), shade=1.0)
    m = out0.depth_mm > 0
    u, v = int(round(K0[0, 2])), int(round(K0[1, 2]))
    assert abs(int(out1.color[v, u, 0]) - int(out0.color[v, u, 0])) <= 2     # facing the camera: albedo
    ys, xs = np.nonzero(m)
    rim = (np.hypot(xs - K0[0, 2], ys - K0[1, 2]) > 0.95 * np.hypot(xs - K0[0, 2], ys - K0[1, 2]).max())
    assert out1.color[ys[rim], xs[rim], 0].mean() < 0.5 * out0.color[ys[rim], xs[rim], 0].mean()


def test_mirrored_pose_keeps_surfaces_and_string_outputs(r):
    T = pose((0.2, 0.1, 0.0), (0, 0, 500.0))
    M = T.copy()
    M[:3, 0] *= -1  # reflection x -> -x of the (symmetric) sphere: same surface, flipped winding
    a = r.render(K0, W0, H0, [("sphere", T)], outputs="depth")
    b = r.render(K0, W0, H0, [("sphere", M)], outputs="depth")
    assert a.instance is None and a.depth_mm is not None
    assert ((a.depth_mm > 0) != (b.depth_mm > 0)).sum() <= 4
    both = (a.depth_mm > 0) & (b.depth_mm > 0)
    assert np.median(np.abs(a.depth_mm[both] - b.depth_mm[both])) < 0.05


def test_bad_input_raises(r):
    with pytest.raises(YcbvssError, match="not added"):
        r.render(K0, W0, H0, [("nope", np.eye(4))])
    with pytest.raises(YcbvssError, match="unknown outputs"):
        r.render(K0, W0, H0, [], outputs=("depht",))
    with pytest.raises(YcbvssError, match="4x4"):
        r.render(K0, W0, H0, [("sphere", np.full((4, 4), np.nan))])
    with pytest.raises(YcbvssError):
        r.render(np.zeros((3, 3)), W0, H0, [])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert r.has_mesh("sphere") and not r.has_mesh("nope")


def test_real_ycbv_frame_masks_match_label_png(ycbv_root):
    """Render the objects of a real YCB-Video frame at its meta.mat poses: the instance mask must reproduce
    the dataset's own label.png (same K, pixel convention and model frame) -- measured IoU ~0.997."""
    import cv2
    import scipy.io

    classes = (ycbv_root / "image_sets" / "classes.txt").read_text().split()
    meta = scipy.io.loadmat(ycbv_root / "data" / "0000" / "000001-meta.mat")
    label = cv2.imread(str(ycbv_root / "data" / "0000" / "000001-label.png"), cv2.IMREAD_UNCHANGED)
    ids = meta["cls_indexes"].ravel().astype(int)
    rr, items = Renderer(max_texture_px=64), []  # colour is not used here
    for k, i in enumerate(ids):
        m = trimesh.load(ycbv_root / "models" / classes[i - 1] / "textured.obj", force="mesh", process=False)
        m.apply_scale(1000.0)
        rr.add_mesh(int(i), m)
        T = np.eye(4)
        T[:3, :4] = meta["poses"][:, :, k]
        T[:3, 3] *= 1000.0
        items.append((int(i), T))
    out = rr.render(meta["intrinsic_matrix"], label.shape[1], label.shape[0], items, outputs=("instance",))
    rr.release()
    for k, i in enumerate(ids):
        a, b = out.instance == k + 1, label == i
        iou = (a & b).sum() / (a | b).sum()
        assert iou > 0.99, (classes[i - 1], iou)


def test_gil_free_draw_and_read_back_give_moderngl_pixels(r, ycb_mesh, monkeypatch):
    """The ctypes draw and read-back (``ycbvss.render.context.gil_free_gl``) issue moderngl's GL
    calls with the GIL released: every output of a textured, occluded, two-object render is equal
    bit for bit to moderngl's own ``VertexArray.render`` / ``Framebuffer.read_into``, and those two
    are not called on that path. (Session 82: while the main thread rendered a 327k-face sphere at
    1600x1200, a counting Python thread waited at most 19 ms for the GIL through moderngl's calls and
    4.4 ms, the interpreter's switch interval, through these.)"""
    from ycbvss.render import context

    if not context.gil_free_gl().ok:
        pytest.skip("no GLVND libOpenGL.so.0 reaching the moderngl context: the renderer uses moderngl's calls only")
    r.add_mesh("mustard", ycb_mesh)
    items = [("mustard", pose((0.4, -0.3, 0.2), (20.0, -10.0, 700.0))), ("box", pose((0.1, 0.2, 0.0), (40.0, 0.0, 650.0)))]
    outs = ("depth", "instance", "color", "normal")
    fast = r.render(K0, W0, H0, items, outputs=outs)
    monkeypatch.setattr(context, "_GL", (context.os.getpid(), type("Off", (), {"ok": False})()))
    ref = r.render(K0, W0, H0, items, outputs=outs)
    monkeypatch.undo()
    for name in ("depth_mm", "instance", "color", "normal_cam"):
        a, b = getattr(fast, name), getattr(ref, name)
        assert a.shape == b.shape and np.array_equal(a, b), name
    assert (ref.instance == 1).sum() > 1000 and (ref.instance == 2).sum() > 1000   # both objects seen

    # the render goes through ctypes (which releases the GIL around each foreign call), not through
    # moderngl's two methods that hold it
    import moderngl

    def held(*a, **k):
        raise AssertionError("a moderngl call that holds the GIL was used")

    monkeypatch.setattr(moderngl.VertexArray, "render", held)
    monkeypatch.setattr(moderngl.Framebuffer, "read_into", held)
    again = r.render(K0, W0, H0, items, outputs=outs)
    assert np.array_equal(again.depth_mm, ref.depth_mm)
