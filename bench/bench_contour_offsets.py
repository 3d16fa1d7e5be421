"""Where a Blender image's edges lie relative to the refiner's contour samples at the exact GT:
the shared (per view and object) outward offset and the per-sample scatter about it.

These two numbers set f_edge's contour-dilation nuisance (``RefineOptions.edge_dilation_k``): a
shared offset b of a view's contour with spread sigma_b, and independent per-sample offsets with
spread sigma_s, make the contour's overall size worth k = (sigma_s / sigma_b)^2 samples.

For every (view, object) of the chosen suite frames with at least ``--min-samples`` unoccluded
contour samples: the templates rendered at the GT (fast renderer), contour samples placed where
the level's blurred edge field of their own silhouette has its minimum (as the refiner does), then
the image's edge-field minimum searched along each sample's outward normal (+-1.5 px). The image
is the suite's Cycles render, never the fast renderer's.

    python bench/bench_contour_offsets.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \
        --scenes 1,2,4,5,6,7 --frames 0,20,40 --out bench/results/ycbv21/contour_offsets

``--contact MM``: per object, the lit prediction's offsets on the contour's lower, upper and
sideways stretches, split into samples at a contact line (the image's depth just outside within MM
of the object's) and free ones (``RefineOptions.edge_table_mm``), table ``contour_contact``.

``--objects``: per object, the binary prediction against the appearance predictions (unlit, lit,
lit with the rim's shading held; ``RefineOptions.edge_appearance``, ``template_shading``,
``shading_rim_px``), table ``contour_objects``.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def add_view_args(ap: argparse.ArgumentParser) -> None:
    """The suite frames a GT-view bench reads (shared with ``bench_match_scale.py``)."""
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--suite", default="ycbv21", help="the suite the scenes belong to (ycbv21, ycbv21-fresh2, ...)")
    ap.add_argument("--scenes", default="1,2,4,5,6,7")
    ap.add_argument("--frames", default="0,10,20,30", help="frame positions within each scene's rendered frames")
    ap.add_argument("--supersample", type=int, default=1,
                    help="templates' colour integrated over each pixel at N x N sub-pixels (RefineOptions.template_supersample)")
    ap.add_argument("--srgb-textures", action="store_true",
                    help="templates' textures filtered in linear light (RefineOptions.template_srgb_textures)")
    ap.add_argument("--images", default=None,
                    help="read the frames' images from this BOP root instead (the same scenes re-rendered, e.g. "
                         "with other Blender settings); all its frames are used")


def gt_views(a: argparse.Namespace):
    """The chosen suite frames with their templates at the exact GT: yields (models, scene id,
    frame, Cycles image, ViewRender of the fast renderer, object ids in label order)."""
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import build_suite
    from ycbvss.refine.templates import ensure_meshes, get_renderer, render_view, texture_mode

    root = Path(a.suite_root)
    scene_ids = [int(s) for s in a.scenes.split(",")]
    models, _ = build_suite(a.dataset, root, getattr(a, "suite", "ycbv21"), scene_ids=scene_ids)
    with texture_mode(bool(getattr(a, "srgb_textures", False))):
        r = get_renderer()
    ensure_meshes(r, models)
    ss = int(getattr(a, "supersample", 1))
    other = getattr(a, "images", None)
    for sid in scene_ids:
        sc = load_bop_scene((Path(other) if other else root) / "test", sid, models)
        chosen = sc.frames if other else [sc.frames[int(p)] for p in a.frames.split(",") if int(p) < len(sc.frames)]
        for fr in chosen:
            cam = fr.camera
            oids = [i.obj_id for i in fr.instances]
            vr = render_view(r, models, oids, cam.K, cam.width, cam.height,
                             {j: i.T_m2c for j, i in enumerate(fr.instances)}, supersample=ss)
            yield models, sid, fr, fr.load_rgb(), vr, oids


def gt_view_matches(vr, img: np.ndarray, lit: bool | np.ndarray = False,
                    norm_sigma_px: float | None = None, reflection_K: np.ndarray | None = None) -> tuple[list[int], list]:
    """f_point's template-to-image flow matches of one GT view as the refiner makes them (default
    RefineOptions; crop coordinates): (object indices with at least ``min_visible_px`` visible,
    their (src, dst) matches). ``lit``: True, the template lit by the fitted lighting
    (``RefineOptions.template_shading``); an (H, W, 3) array, that colour as the template (of a
    point-sampled render). Shared by ``bench_match_scale.py``, ``bench_template_shading.py`` and
    ``bench_height_lighting.py``. ``norm_sigma_px``: FlowOptions.template_norm_sigma_px (None: its default).
    ``reflection_K``: with ``lit`` True, the lighting also has the glossy reflection's basis of this
    camera (``RefineOptions.shading_reflection``)."""
    from dataclasses import replace

    from ycbvss.refine.bundle import RefineOptions, _bbox, _view_matches_lit
    from ycbvss.refine.matching import min_eig_map
    from ycbvss.refine.match_mask import match_mask

    opt = RefineOptions()
    if norm_sigma_px is not None:
        opt.flow = replace(opt.flow, template_norm_sigma_px=float(norm_sigma_px))
    objs = [j for j in vr.obj_index if int(vr.mask(j).sum()) >= opt.min_visible_px]
    box = y0, y1, x0, x1 = _bbox(vr.instance > 0, opt.flow_margin_px)
    masks = [match_mask(vr.mask(j), opt.match_erode_px, opt.match_core_px)[y0:y1, x0:x1] for j in objs]
    # as the refiner makes them (a supersampled render: the pixel-area template, see RefineOptions.template_supersample)
    colour = lit if isinstance(lit, np.ndarray) else (True if lit else None)
    matches, _ = _view_matches_lit(vr, img, box, colour, None, masks, opt.flow, min_eig_map(img)[y0:y1, x0:x1],
                                   reflection_K=reflection_K)
    return objs, [(a[: opt.n_matches], b[: opt.n_matches]) for a, b in matches]


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.refine.contour_match import _minimum_along
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.templates import view_edge_candidates

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_args(ap)
    ap.add_argument("--sigma-px", type=float, default=1.0)
    ap.add_argument("--min-samples", type=int, default=40)
    ap.add_argument("--out", required=True)
    ap.add_argument("--directions", action="store_true",
                    help="instead: the offsets by the contour's image direction (outward normal up / down / sideways) "
                         "for the binary contour prediction, the appearance prediction from the unlit template and from "
                         "the lit one (RefineOptions.edge_appearance, template_shading); table contour_directions")
    ap.add_argument("--objects", action="store_true",
                    help="instead: per object, the offsets from the binary contour prediction, the appearance prediction "
                         "from the unlit template, from the lit one, and from the lit one with its rim's shading held "
                         "(RefineOptions.shading_rim_px 3); table contour_objects")
    ap.add_argument("--contact", type=float, default=0.0, metavar="MM",
                    help="instead: per object, the lit appearance prediction's offsets by side (outward normal down / up / "
                         "sideways in the image) for contour samples at a contact line -- the image's own depth (the "
                         "suite's Cycles depth) 1.5-3 px outside lies within MM of the object's -- and the free ones; "
                         "table contour_contact (RefineOptions.edge_table_mm)")
    ap.add_argument("--shift", action="store_true",
                    help="instead: per (view, object) the image edge's offsets from the lit appearance prediction (the "
                         "wide bundles' default) fitted as a shared 2-D shift plus a dilation plus per-sample scatter "
                         "(RefineOptions.edge_shift_k, edge_dilation_k); table contour_shift")
    a = ap.parse_args()
    if a.shift:
        shift(a)
        return
    if a.contact > 0:
        contact(a)
        return
    if a.directions:
        directions(a)
        return
    if a.objects:
        objects(a)
        return
    rows = []
    models: dict = {}
    for models, sid, fr, img, vr, oids in gt_views(a):
        c = view_edge_candidates(vr, blur_sigma_px=a.sigma_px, normals=True)
        fld = edge_field(img, a.sigma_px, colour=True)
        for lab0, oid in enumerate(oids):
            sel = np.flatnonzero((c.l_c == lab0 + 1) & np.any(c.n_c != 0.0, axis=1))
            if len(sel) < a.min_samples:
                continue
            t = _minimum_along(fld, c.uv_c[sel], c.n_c[sel], 1.5, 0.25)
            t = t[np.abs(t) < 1.5 - 0.25]            # a minimum at the window's end: no edge found
            if len(t) < a.min_samples:
                continue
            med = float(np.median(t))
            rows.append({"scene": sid, "im_id": fr.im_id, "obj_id": oid, "n": len(t), "shared_px": med,
                         "scatter_px": float(1.4826 * np.median(np.abs(t - med)))})
    b = np.array([x["shared_px"] for x in rows])
    s = np.array([x["scatter_px"] for x in rows])
    sigma_b = float(np.sqrt(np.mean(b ** 2)))
    sigma_s = float(np.median(s))
    summary = {"groups": len(rows), "sigma_b_px (rms shared offset)": sigma_b, "mean shared offset px": float(b.mean()),
               "sigma_s_px (median per-sample scatter, MAD)": sigma_s, "k = (sigma_s / sigma_b)^2": (sigma_s / sigma_b) ** 2}
    for k, v in summary.items():
        print(f"{k}: {v:.4g}" if isinstance(v, float) else f"{k}: {v}")
    per_obj = {}
    for x in rows:
        per_obj.setdefault(x["obj_id"], []).append(x)
    t = Table(["groups", "shared offset mean (px)", "shared offset rms (px)", "per-sample scatter (px)"],
              label_header="object", digits=3,
              caption=f"Image edge minus contour sample along the outward normal at the exact GT (sigma {a.sigma_px:g} px), "
                      f"scenes {a.scenes}, frame positions {a.frames}; k = (scatter / shared rms)^2 = {(sigma_s / sigma_b) ** 2:.2f}")
    for o, v in sorted(per_obj.items()):
        sb = np.array([x["shared_px"] for x in v])
        t.rows.append(Row(getattr(models[o], "name", None) or str(o),
                          [float(len(v)), float(sb.mean()), float(np.sqrt(np.mean(sb ** 2))),
                           float(np.median([x["scatter_px"] for x in v]))]))
    t.rows.append(Row("all", [float(len(rows)), float(b.mean()), sigma_b, sigma_s], rule_before=True))
    for p in write_table(t, Path(a.out), "contour_offsets"):
        print(p)


def lit_contour_groups(a: argparse.Namespace):
    """The chosen GT views' contour samples as the wide bundles take them (appearance predicted from
    the lit template, blur ``a.sigma_px``), per object of each view (any number of samples): yields
    (models, frame, ViewRender, image's edge field, label index, obj_id, uv (n, 2), outward normals (n, 2))."""
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.shading import lit_template
    from ycbvss.refine.templates import view_edge_candidates

    for models, sid, fr, img, vr, oids in gt_views(a):
        fld = edge_field(img, a.sigma_px, colour=True)
        lit = lit_template(vr.color, vr.normal, vr.instance, img)
        c = view_edge_candidates(vr, blur_sigma_px=a.sigma_px, normals=True, image=img, appearance_color=lit)
        for lab0, oid in enumerate(oids):
            sel = np.flatnonzero((c.l_c == lab0 + 1) & np.any(c.n_c != 0.0, axis=1))
            yield models, fr, vr, fld, lab0, oid, c.uv_c[sel], c.n_c[sel]


def shift_fit(fld, uv: np.ndarray, n: np.ndarray, min_samples: int, half_px: float = 1.5) -> tuple | None:
    """One (view, object)'s image-edge offsets t_k (px, outward +) from its contour samples ``uv``
    along their outward normals ``n`` (minimum of the edge field ``fld`` within +-``half_px``) fitted
    (3-sigma trimmed least squares, three passes) as ``t_k = n_k . s + b + r_k``: (s_u, s_v, b, rms
    of r); None with fewer than ``min_samples`` located samples."""
    from ycbvss.refine.contour_match import _minimum_along

    if len(uv) < min_samples:
        return None
    t = _minimum_along(fld, uv, n, half_px, 0.25)
    ok = np.abs(t) < half_px - 0.25                   # a minimum at the window's end: no edge found
    if ok.sum() < min_samples:
        return None
    t, n = t[ok], n[ok]
    X = np.column_stack([n, np.ones(len(t))])
    keep = np.ones(len(t), bool)
    for _ in range(3):
        p = np.linalg.lstsq(X[keep], t[keep], rcond=None)[0]
        r = t - X @ p
        keep = np.abs(r) < 3.0 * 1.4826 * np.median(np.abs(r[keep])) + 1e-9
    return float(p[0]), float(p[1]), float(p[2]), float(np.sqrt(np.mean(r[keep] ** 2)))


def shift_stats(v: np.ndarray) -> list[float]:
    """Over groups v (G, 4) of :func:`shift_fit`: [G, rms |s|, rms b, median rest, k = rest^2 / (rms |s|^2 / 2)]."""
    s_rms = float(np.sqrt(np.mean(v[:, 0] ** 2 + v[:, 1] ** 2)))
    scat = float(np.median(v[:, 3]))
    return [float(len(v)), s_rms, float(np.sqrt(np.mean(v[:, 2] ** 2))), scat, scat ** 2 / max(s_rms ** 2 / 2.0, 1e-12)]


def mean_and_scatter(groups: list[np.ndarray], min_n: int = 3) -> tuple[int, np.ndarray, np.ndarray]:
    """Over the groups (each (n, 2) shifts, px) with at least ``min_n`` members: (their number, the
    rms over groups of a group's mean (2,), the rms of the members about their group's mean (2,))."""
    gs = [g for g in groups if len(g) >= min_n]
    if not gs:
        return 0, np.zeros(2), np.zeros(2)
    means = np.array([g.mean(axis=0) for g in gs])
    about = np.concatenate([g - g.mean(axis=0) for g in gs])
    return len(gs), np.sqrt(np.mean(means ** 2, axis=0)), np.sqrt(np.mean(about ** 2, axis=0))


def shift(a: argparse.Namespace) -> None:
    """Per (view, object) with at least ``a.min_samples`` located contour samples: the offsets t_k
    (px, outward +) of the image's edge from the lit appearance prediction fitted (3-sigma trimmed
    least squares, three passes) as ``t_k = n_k . s + b + r_k``: a shared image shift s, a dilation b
    and the per-sample rest r. Per object and over all groups: the rms of |s| and of b and the median
    rms of r; k = (rms r)^2 / (rms of s per axis)^2 is the prior's worth in samples."""
    from ycbvss.eval.tables import Row, Table, write_table

    per: dict = {}
    names: dict = {}
    views: dict = {}         # (scene, im_id) -> the shifts of its objects
    for models, fr, _, fld, _, oid, uv, n in lit_contour_groups(a):
        names[oid] = getattr(models[oid], "name", None) or str(oid)
        f = shift_fit(fld, uv, n, a.min_samples)
        if f is not None:
            per.setdefault(oid, []).append(f)
            views.setdefault((fr.scene_id, fr.im_id), []).append(f[:2])
    # per view or per object? the mean shift of a view's objects (what a camera error would make)
    # against its objects' own about it; and does an object keep its shift from view to view (its mean
    # over the views is what its pose absorbs) against its views' shifts about that mean
    for what, groups in (("views with >= 3 objects", views.values()), ("objects in >= 3 views", per.values())):
        n, mean_rms, about_rms = mean_and_scatter([np.asarray(v)[:, :2] for v in groups])
        if n:
            print("{}: {}; rms of the mean shift (u, v) {:.3f} / {:.3f} px, of the shifts about it {:.3f} / {:.3f} px"
                  .format(what, n, *mean_rms, *about_rms))

    t = Table(["groups", "shift |s| rms (px)", "dilation b rms (px)", "per-sample rest (px)", "k"],
              label_header="object", digits=3,
              caption=f"Image edge minus the lit contour prediction at the exact GT (sigma {a.sigma_px:g} px) per (view, "
                      f"object): a shared shift s, a dilation b and the per-sample rest; k = rest^2 / (|s| rms^2 / 2); "
                      f"{a.suite} scenes {a.scenes}, frame positions {a.frames}")
    for o, v in sorted(per.items()):
        t.rows.append(Row(names[o], shift_stats(np.array(v))))
    allv = np.array([x for v in per.values() for x in v])
    t.rows.append(Row("all", shift_stats(allv), rule_before=True))
    print("all: groups {:.0f}, |s| rms {:.3f} px, b rms {:.3f} px, rest {:.3f} px, k {:.2f}".format(*shift_stats(allv)))
    for p in write_table(t, Path(a.out), "contour_shift"):
        print(p)


def contact(a: argparse.Namespace) -> None:
    """Per object, the median image-edge offset (px, outward +) from the lit appearance prediction of
    its contour samples, per view, by side (down / up / sideways by the outward normal's image y)
    and by contact (the frame's own depth, median at 1.5-3 px outside, within ``a.contact`` mm of
    the template's depth 1 px inside) or free; the mean over views, and over objects the mean,
    the rms and the sample counts."""
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.refine.contour_match import _minimum_along
    from ycbvss.refine.edge import sample_bilinear

    sides = ("down", "up", "sideways")
    cols = [(s_, c_) for s_ in sides for c_ in ("contact", "free")]
    acc: dict = {}
    names: dict = {}
    count = {k: 0 for k in cols}
    dep_of = (None, None)                     # (frame, its depth): read once per frame
    for models, fr, vr, fld, lab0, oid, uv, n in lit_contour_groups(a):
        if dep_of[0] is not fr:
            dep_of = (fr, fr.load_depth_mm().astype(np.float32))
        dep = dep_of[1]
        names[oid] = getattr(models[oid], "name", None) or str(oid)
        if len(uv) < a.min_samples:
            continue
        t = _minimum_along(fld, uv, n, 1.5, 0.25)
        own = np.where(vr.instance == lab0 + 1, vr.depth_mm, 0.0).astype(np.float32)[..., None]
        d_in = sample_bilinear(own, uv - n)[0][:, 0]
        d_out = np.median(np.stack([sample_bilinear(dep[..., None], uv + s_ * n)[0][:, 0]
                                    for s_ in (1.5, 2.0, 2.5, 3.0)]), axis=0)
        at = (np.abs(d_out - d_in) < a.contact) & (d_in > 0)
        ok = np.abs(t) < 1.5 - 0.25                   # a minimum at the window's end: no edge found
        for side, m in zip(sides, (n[:, 1] > 0.5, n[:, 1] < -0.5, np.abs(n[:, 1]) <= 0.5)):
            for ct, mm in (("contact", at), ("free", ~at)):
                q = ok & m & mm
                count[(side, ct)] += int(q.sum())
                if q.sum() >= 5:
                    acc.setdefault((oid, side, ct), []).append(float(np.median(t[q])))
    t = Table([f"{s_} {c_} (px)" for s_, c_ in cols], label_header="object", digits=3,
              caption=f"Image edge minus the lit appearance prediction of the contour samples at the exact GT (sigma "
                      f"{a.sigma_px:g} px), by the outward normal's side in the image and by contact (the image's depth "
                      f"1.5-3 px outside within {a.contact:g} mm of the object's); mean over views of the per-view median; "
                      f"scenes {a.scenes}, frame positions {a.frames}")
    for o in sorted(names):
        t.rows.append(Row(names[o], [float(np.mean(acc[(o,) + k])) if (o,) + k in acc else np.nan for k in cols]))
    per = {k: [float(np.mean(v)) for kk, v in acc.items() if kk[1:] == k] for k in cols}
    t.rows.append(Row("mean over objects", [float(np.mean(per[k])) if per[k] else np.nan for k in cols], rule_before=True))
    t.rows.append(Row("rms over objects", [float(np.sqrt(np.mean(np.square(per[k])))) if per[k] else np.nan for k in cols]))
    t.rows.append(Row("samples", [float(count[k]) for k in cols]))
    for p in write_table(t, Path(a.out), "contour_contact"):
        print(p)


def directions(a: argparse.Namespace) -> None:
    """Per (view, object) and contour direction the median image-edge offset (px, outward +) from
    the contour samples of three predictions; table of their mean and rms over (view, object)s."""
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.refine.contour_match import _minimum_along
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.shading import lit_template
    from ycbvss.refine.templates import view_edge_candidates

    dirs = ("up", "down", "sideways", "all")
    acc: dict = {}
    for _, _, _, img, vr, oids in gt_views(a):
        fld = edge_field(img, a.sigma_px, colour=True)
        lit = lit_template(vr.color, vr.normal, vr.instance, img)
        for mode, kw in (("binary", {}), ("appearance, unlit template", {"image": img}),
                         ("appearance, lit template", {"image": img, "appearance_color": lit})):
            c = view_edge_candidates(vr, blur_sigma_px=a.sigma_px, normals=True, **kw)
            for lab0 in range(len(oids)):
                sel = np.flatnonzero((c.l_c == lab0 + 1) & np.any(c.n_c != 0.0, axis=1))
                if len(sel) < 20:
                    continue
                t = _minimum_along(fld, c.uv_c[sel], c.n_c[sel], 1.5, 0.25)
                n = c.n_c[sel]
                ok = np.abs(t) < 1.5 - 0.25
                masks = (n[:, 1] < -0.7, n[:, 1] > 0.7, np.abs(n[:, 0]) > 0.7, np.ones(len(n), bool))
                for d, m in zip(dirs, masks):
                    if np.sum(m & ok) >= 5:
                        acc.setdefault((mode, d), []).append(float(np.median(t[m & ok])))
    t = Table(["(view, object)s", "mean (px)", "rms (px)"], label_header="prediction, contour direction", digits=3,
              caption=f"Image edge minus contour sample along the outward normal at the exact GT (sigma {a.sigma_px:g} px), "
                      f"median per (view, object) and image direction of the outward normal (up: n_v < -0.7, down: "
                      f"n_v > 0.7, sideways: |n_u| > 0.7); scenes {a.scenes}, frame positions {a.frames}")
    for (mode, d), v in acc.items():
        x = np.array(v)
        t.rows.append(Row(f"{mode}: {d}", [float(len(x)), float(x.mean()), float(np.sqrt(np.mean(x ** 2)))]))
        print(f"{mode:28s} {d:9s} n {len(x):4d} mean {x.mean():+.3f} rms {np.sqrt(np.mean(x ** 2)):.3f}")
    for p in write_table(t, Path(a.out), "contour_directions"):
        print(p)


def objects(a: argparse.Namespace) -> None:
    """Per object, the mean over its (view)s of the median image-edge offset (px, outward +) from
    the contour samples of four predictions, and over objects the mean and rms; table of them.

    Second table, per scene: the scale the contours alone give a free-camera bundle. Scaling a
    scene about the camera by (1 + s) moves a contour sample inward by s r_i (r_i: its outward
    displacement per unit scale, (sample - projected object centre) . normal, px), so the
    least-squares s over the samples' offsets d_i is sum r_i d_i / sum r_i^2; the scene's objects
    then move by dz = -s z (mm, z their mean depth)."""
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.refine.contour_match import _minimum_along
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.shading import lit_template
    from ycbvss.refine.templates import view_edge_candidates

    modes = ("binary", "appearance, unlit", "appearance, lit", "appearance, lit, rim held 3 px")
    acc: dict = {}
    names: dict = {}
    scale: dict = {}            # (scene, mode) -> [sum r d, sum r^2, sum r^2 z]
    for models, sid, fr, img, vr, oids in gt_views(a):
        fld = edge_field(img, a.sigma_px, colour=True)
        lit = lit_template(vr.color, vr.normal, vr.instance, img)
        held = lit_template(vr.color, vr.normal, vr.instance, img, rim_px=3)
        for mode, kw in zip(modes, ({}, {"image": img}, {"image": img, "appearance_color": lit},
                                    {"image": img, "appearance_color": held})):
            c = view_edge_candidates(vr, blur_sigma_px=a.sigma_px, normals=True, **kw)
            for lab0, oid in enumerate(oids):
                names[oid] = getattr(models[oid], "name", None) or str(oid)
                sel = np.flatnonzero((c.l_c == lab0 + 1) & np.any(c.n_c != 0.0, axis=1))
                if len(sel) < a.min_samples:
                    continue
                t = _minimum_along(fld, c.uv_c[sel], c.n_c[sel], 1.5, 0.25)
                ok = np.abs(t) < 1.5 - 0.25               # a minimum at the window's end: no edge found
                if ok.sum() >= 10:
                    acc.setdefault((oid, mode), []).append(float(np.median(t[ok])))
                    T = fr.instances[lab0].T_m2c
                    ctr = fr.camera.K @ T[:3, 3]
                    r = np.einsum("ij,ij->i", c.uv_c[sel][ok] - ctr[:2] / ctr[2], c.n_c[sel][ok])
                    sc = scale.setdefault((sid, mode), [0.0, 0.0, 0.0])
                    sc[0] += float(np.sum(r * t[ok]))
                    sc[1] += float(np.sum(r * r))
                    sc[2] += float(np.sum(r * r) * T[2, 3])
    t = Table(["views"] + [f"{m} (px)" for m in modes], label_header="object", digits=3,
              caption=f"Image edge minus contour sample along the outward normal at the exact GT (sigma {a.sigma_px:g} px), "
                      f"mean over each object's views of the per-view median, for four predictions of the contour; "
                      f"scenes {a.scenes}, frame positions {a.frames}")
    per = {m: [] for m in modes}
    for o in sorted(names):
        if (o, modes[0]) not in acc:
            continue
        vals = [float(np.mean(acc.get((o, m), [np.nan]))) for m in modes]
        for m, v in zip(modes, vals):
            per[m].append(v)
        t.rows.append(Row(names[o], [float(len(acc[(o, modes[0])]))] + vals))
    t.rows.append(Row("mean over objects", [np.nan] + [float(np.nanmean(per[m])) for m in modes], rule_before=True))
    t.rows.append(Row("rms over objects", [np.nan] + [float(np.sqrt(np.nanmean(np.square(per[m])))) for m in modes]))
    t.rows.append(Row("rms over (view, object)s", [np.nan] + [
        float(np.sqrt(np.mean(np.square(np.concatenate([acc[k] for k in acc if k[1] == m]))))) for m in modes]))
    for p in write_table(t, Path(a.out), "contour_objects"):
        print(p)
    ts = Table([f"{m}: {q}" for m in modes for q in ("s (%)", "dz (mm)")], label_header="scene", digits=3,
               caption=f"The scale a free-camera bundle's contours alone give each scene at the exact GT: s = sum r d / "
                       f"sum r^2 over its contour samples (d image edge minus sample, r outward displacement per unit "
                       f"scale, px), dz = -s z (mm) at the samples' r^2-weighted mean depth; frame positions {a.frames}")
    for sid in sorted({k[0] for k in scale}):
        vals = []
        for m in modes:
            n, d, dz = scale.get((sid, m), [np.nan, np.nan, np.nan])
            vals += [100.0 * n / d, -n / d * dz / d]
        ts.rows.append(Row(str(sid), vals))
    for p in write_table(ts, Path(a.out), "contour_scale"):
        print(p)


if __name__ == "__main__":
    main()
