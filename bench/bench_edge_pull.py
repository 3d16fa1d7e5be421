"""Where f_edge's pull on an object's rotation comes from, at the exact GT of one suite clip.

At the exact pose the cost should be flat. For each of the chosen frames this bench renders the
clip's objects at the GT (fast renderer), takes the object's f_edge candidates as the refiner's
finest level does (contour samples matched to the 1 px blur, interior texture samples gated by the
normal turn of medium bundles, no fold edges) and reads the Cycles image's edge field (colour,
sigma 1 px). Per sample it computes the slope of E along a rotation of the object about one of its
model axes through the model's centroid (dE / d deg, finite difference of 0.2 deg): the sum over
samples is the pull f_edge puts on that rotation at the GT (negative: a positive turn lowers the
cost). The samples are split into

- contour samples whose outward neighbour pixel belongs to another object (a contact line, or the
  object's edge against a neighbour behind it),
- contour samples with another object 2-4 px outside (a narrow gap: the neighbour's edge lies
  within the blur),
- the other contour samples, split by whether their pixel lies within 3 px of where a nearer
  object cuts the silhouette (a T-junction, :func:`ycbvss.refine.edge.junction_mask`),
- interior samples,
- with ``--table-mm H``: the free contour samples whose surface point lies less than H mm above
  the GT table (world z = 0 of the suite's scenes), beside the object's contact shadow,

Interior samples can be taken as the refiner's ``interior_ridge_groups`` takes them (``--ridge``:
located on the template's own edge field; ``--area F``: in the template integrated over each
pixel at F x F sub-pixels; ``--lit``: that template lit by the view's lighting fitted to the
image). The image can be replaced by a re-render of the same frames (``--images ROOT``: a BOP root
written by ``bench_image_formation.py`` (texture as emission) or ``bench_bias_lighting.py``
(ambient light only), checked to hold the same GT) or, as a diagnostic of the sample locator alone,
by the template itself (``--self``: the point-sampled template inside the objects).

Written as Markdown / CSV / LaTeX (``edge_pull.*``) and as a PNG per frame (``edge_pull_<frame>.png``:
the image magnified, each sample a dot sized by its pull, blue = dE / d deg > 0 (pushes the turn
negative), red = dE / d deg < 0; interior samples as rings).

    python bench/bench_edge_pull.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --clip medium-4 --obj 21 --axis z --frames 0,20,40,58 --out bench/results/ycbv21/edge_pull
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

CLASSES = ("contour, touching another object", "contour, another object 2-4 px out", "contour, free",
           "contour, free, within 3 px of a T-junction", "interior", "contour, free, near the table")


def sample_classes(instance: np.ndarray, uv: np.ndarray, normals: np.ndarray, label: int,
                   junction: np.ndarray | None = None) -> np.ndarray:
    """(N,) class index (0-3 of :data:`CLASSES`) of contour samples uv (N, 2) with outward unit
    normals (N, 2): what the instance image holds 1 px and 2-4 px outside along the normal; with
    ``junction`` (H, W) bool (:func:`ycbvss.refine.edge.junction_mask`), the free samples whose
    pixel lies in it are class 3."""
    H, W = instance.shape
    out = np.full(len(uv), 2)
    near = np.zeros(len(uv), bool)
    for k in range(1, 5):
        q = np.clip(np.round(uv + k * normals).astype(int), 0, [W - 1, H - 1])
        lab = instance[q[:, 1], q[:, 0]]
        other = (lab > 0) & (lab != label)
        if k == 1:
            touch = other
        else:
            near |= other
    if junction is not None:
        p = np.clip(np.floor(uv - 0.5 * normals + 0.5).astype(int), 0, [W - 1, H - 1])   # the contour pixel
        out[junction[p[:, 1], p[:, 0]]] = 3
    out[near & ~touch] = 1
    out[touch] = 0
    return out


def classed_samples(vr, cands, K: np.ndarray, T_m2c: np.ndarray, label: int, T_w2c: np.ndarray | None,
                    table_mm: float, junction_px: float):
    """The f_edge samples of the object drawn as ``label`` in ``vr`` from its candidates ``cands``
    (:class:`ycbvss.refine.templates.EdgeCandidates` with contour normals), classed as in
    :data:`CLASSES`: yields (interior, uv (N, 2), model points X (N, 3, mm), class (N,)) for the contour
    then the interior samples. ``junction_px``: the T-junction radius (class 3); ``table_mm`` > 0
    with ``T_w2c``: free contour samples that close to the table (world z = 0) are class 5."""
    from ycbvss.geometry.se3 import inv_T
    from ycbvss.refine.edge import junction_mask, occluded_pixels
    from ycbvss.refine.jacobians import backproject_px

    Pi = inv_T(T_m2c)
    # the object's pixels within the refiner's junction radius of where a nearer object cuts its silhouette
    junction = junction_mask(vr.instance, occluded_pixels(vr.instance, vr.depth_mm) & (vr.instance == label), junction_px)
    c = cands
    for interior, uv, dep, lbl in ((False, c.uv_c, c.d_c, c.l_c), (True, c.uv_i, c.d_i, c.l_i)):
        m = (lbl == label) & (dep > 0)
        X = backproject_px(K, uv[m], dep[m]) @ Pi[:3, :3].T + Pi[:3, 3]
        cls = np.full(int(m.sum()), 4) if interior else sample_classes(vr.instance, uv[m], c.n_c[m], label, junction)
        if table_mm > 0 and not interior and T_w2c is not None:
            P = inv_T(T_w2c)
            height_mm = (X @ T_m2c[:3, :3].T + T_m2c[:3, 3]) @ P[2, :3] + P[2, 3]
            cls[(cls == 2) & (height_mm < table_mm)] = 5
        yield interior, uv[m], X, cls


def rotation_pull(K: np.ndarray, T_m2c: np.ndarray, X_model: np.ndarray, centre: np.ndarray, axis: int,
                  field, step_deg: float = 0.2, across: bool = False) -> np.ndarray:
    """(N,) dE / d deg of each model point X_model (N, 3, mm) for a turn of the object about its
    model axis ``axis`` through ``centre`` (finite difference of ``step_deg``); 0 outside the image.
    ``across``: only E's slope across the edge (along its direction of largest curvature) counts."""
    import cv2

    from ycbvss.refine.edge import sample_field
    from ycbvss.refine.jacobians import project_points

    w = np.zeros(3)
    w[axis] = np.radians(step_deg)
    R = cv2.Rodrigues(w)[0]
    uv0, ok0 = project_points(K, T_m2c, X_model)
    uv1, _ = project_points(K, T_m2c, (X_model - centre) @ R.T + centre)
    _, grad, hess, inside = sample_field(field, np.where(ok0[:, None], uv0, -1e9))
    if across:
        n = np.linalg.eigh(hess)[1][:, :, 1]
        grad = np.einsum("ni,ni->n", grad, n)[:, None] * n
    pull = np.einsum("ni,ni->n", grad, (uv1 - uv0) / step_deg)
    return np.where(ok0 & inside, pull, 0.0)


def rerendered_image(root: Path, scene_id: int, frame) -> np.ndarray:
    """RGB of ``frame`` re-rendered under BOP root ``root`` (test split), after checking that its
    scene_gt holds the same objects at the same translations (0.001 mm) as the suite frame."""
    import json

    from ycbvss.io.images import read_rgb

    sd = root / "test" / f"{scene_id:06d}"
    gt = json.loads((sd / "scene_gt.json").read_text())[str(frame.im_id)]
    for g, ins in zip(gt, frame.instances, strict=True):
        if g["obj_id"] != ins.obj_id or not np.allclose(np.asarray(g["cam_t_m2c"], float), ins.T_m2c[:3, 3], atol=1e-3):
            raise SystemExit(f"{sd}: frame {frame.im_id} object {g['obj_id']} is not at the suite's GT")
    return read_rgb(sd / "rgb" / f"{frame.im_id:06d}.png")


def main() -> None:
    import cv2

    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.io.images import write_png
    from ycbvss.pipeline.suite import load_clip
    from ycbvss.refine.bundle import RefineOptions
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.shading import lit_template, view_lighting
    from ycbvss.refine.templates import area_template, ensure_meshes, get_renderer, render_view, view_edge_candidates

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--suite", default="ycbv21", help="the suite of --clip (ycbv21, ycbv21-ci, ycbv21-fresh2, ...)")
    ap.add_argument("--clip", required=True, help="e.g. medium-4")
    ap.add_argument("--obj", type=int, required=True)
    ap.add_argument("--axis", choices=("x", "y", "z"), required=True, help="model axis of the turn")
    ap.add_argument("--frames", default="0", help="frame ids")
    ap.add_argument("--zoom", type=int, default=5)
    ap.add_argument("--ridge", action="store_true", help="interior samples on the template's own edge field")
    ap.add_argument("--area", type=int, default=1, help="interior samples in the pixel-area template (F x F)")
    ap.add_argument("--lit", action="store_true", help="interior samples in the template lit as the image")
    ap.add_argument("--composite", action="store_true", help="with --ridge: the template over the image's background")
    ap.add_argument("--across", action="store_true", help="count only E's slope across each edge")
    ap.add_argument("--images", default=None, help="BOP root with re-renders of the clip's frames (same GT)")
    ap.add_argument("--self", action="store_true", help="the template itself as the image (locator check)")
    ap.add_argument("--table-mm", type=float, default=0.0,
                    help="> 0: free contour samples whose surface point lies less than this above the GT table "
                         "(world z = 0 of the suite's scenes) are a class of their own")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    models, sc = load_clip(a.dataset, a.suite_root, a.clip, suite=a.suite)
    frames = {f.im_id: f for f in sc.frames}
    axis = "xyz".index(a.axis)
    centre = np.asarray(models[a.obj].vertices_mm, np.float64).mean(0)
    r = get_renderer()
    ensure_meshes(r, models)
    rows, totals = [], np.zeros(len(CLASSES))
    for im in (int(x) for x in a.frames.split(",")):
        f = frames[im]
        ids = [i.obj_id for i in f.instances]
        if a.obj not in ids:
            raise SystemExit(f"object {a.obj} is not in frame {im} of {a.clip}")
        img = f.load_rgb()
        if a.images:
            img = rerendered_image(Path(a.images), sc.scene_id, f)
        H, W = img.shape[:2]
        K = f.camera.K
        poses = {j: i.T_m2c for j, i in enumerate(f.instances)}
        vr = render_view(r, models, ids, K, W, H, poses, back=True, supersample=a.area)
        if a.self:
            img = np.where((vr.instance > 0)[..., None], vr.color, img)
        icol = vr.area_color if a.area > 1 and area_template(vr) else vr.color
        if a.lit:
            icol = lit_template(icol, vr.normal, vr.instance, img,
                                coeffs=view_lighting(icol, vr.normal, vr.instance, img))
        c = view_edge_candidates(vr, creases=True, blur_sigma_px=1.0, normals=True, interior_max_turn_deg=20.0,
                                 fold_min_angle_deg=180.0, interior_ridge_sigma_px=1.0 if a.ridge else 0.0,
                                 interior_color=np.where((vr.instance > 0)[..., None], icol, img) if a.composite else icol)
        j = ids.index(a.obj)
        lab = vr.obj_index.index(j) + 1
        T = poses[j]
        fld = edge_field(img, 1.0, colour=True)
        per_class, dots = np.zeros(len(CLASSES)), []
        counts = np.zeros(len(CLASSES), int)
        for interior, uv, X, cls in classed_samples(vr, c, K, T, lab, f.T_w2c, a.table_mm,
                                                    RefineOptions().edge_junction_px * W / 640.0):
            pull = rotation_pull(K, T, X, centre, axis, fld, across=a.across)
            for k in range(len(CLASSES)):
                per_class[k] += pull[cls == k].sum()
                counts[k] += int((cls == k).sum())
            dots += [(p, q, interior) for p, q in zip(uv, pull)]
        totals += per_class
        for k, name in enumerate(CLASSES):
            rows.append(Row(f"frame {im}: {name}", [int(counts[k]), float(per_class[k])]))
        rows[-len(CLASSES)].rule_before = True
        # the map
        ys, xs = np.nonzero(vr.instance == lab)
        x0, y0 = max(xs.min() - 10, 0), max(ys.min() - 10, 0)
        x1, y1 = min(xs.max() + 10, W), min(ys.max() + 10, H)
        z = a.zoom
        big = cv2.resize(np.ascontiguousarray(img[y0:y1, x0:x1]), None, fx=z, fy=z, interpolation=cv2.INTER_NEAREST)
        scale = max(max(abs(q) for _, q, _ in dots), 1e-12)
        for p, q, interior in dots:
            centre_px = tuple(int(v) for v in (p - (x0, y0) + 0.5) * z)
            colour = (0, 0, 255) if q > 0 else (255, 0, 0)
            cv2.circle(big, centre_px, max(1, int(round(6 * abs(q) / scale))), colour, 1 if interior else -1)
        write_png(out / f"edge_pull_{im}.png", big)
    for k, name in enumerate(CLASSES):
        rows.append(Row(f"all frames: {name}", [None, float(totals[k])], rule_before=k == 0))
    t = Table(caption=f"{a.clip}, object {a.obj} ({models[a.obj].name}) at the exact GT: f_edge's pull on a turn about "
                      f"its model {a.axis} axis (sum over samples of dE / d deg; negative: a positive turn lowers the "
                      f"cost), by sample class", label_header="frame: samples",
              columns=["samples", "pull (1/deg)"], rows=rows, digits=3)
    for p in write_table(t, out, "edge_pull"):
        print(p)


if __name__ == "__main__":
    main()
