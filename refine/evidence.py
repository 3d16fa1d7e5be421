"""What a refined pose's status is judged from, measured on the images after the refinement:
each object's contour offset per view (the image's edges against the template's silhouette,
:func:`ycbvss.refine.confidence.contour_offset_px`) and its turned copies' interior fit
(:mod:`ycbvss.refine.turn_check`), both rendered at the refined poses with the other objects in place."""
from __future__ import annotations

from dataclasses import replace as dc_replace
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ..geometry.model_frame import bbox_center
from .confidence import REF_WIDTH_PX, contour_offset_px, worst_views_px
from .edge import gradient_magnitude
from .shading import lit_template
from .templates import ViewRender, _subpixel_K, composite, get_renderer, mesh_key, render_view
from .threads import view_pool as _view_pool
from .view_shift import REACH_PX, object_shift_px, view_shift_px
from .turn_check import (TEXTURED_MIN, axis_turn_transforms, best_turn, interior_mask, interior_ncc, revolution_axes,
                         same_silhouette_turn, silhouette_change_px2, texture_share, turn_transforms, views_ncc)

if TYPE_CHECKING:
    from .bundle import _SceneImages
    from .options import RefineOptions


def _view_contour_offsets(views: list, models: dict, obj_ids: list, ok: np.ndarray, poses: dict,
                          renderer=None, image_mags: list | None = None,
                          lengths: dict | None = None, lit: bool = False,
                          shifts: dict | None = None) -> dict[int, dict[int, float]]:
    """Per view (its index in ``views``, whose images are loaded): obj_id -> offset (px) of the
    object's visible contour from the image's edges at the refined poses
    (:func:`ycbvss.refine.confidence.contour_offset_px`; objects without a visible contour left out).
    ``image_mags``: the views' image gradient magnitudes (σ 1 px) when already computed.
    ``lengths`` (a dict, filled when given): view index -> obj_id -> visible contour pixels.
    ``shifts`` (a dict, filled when given): view index -> obj_id -> the object's 2-D template
    shift (px, :func:`ycbvss.refine.view_shift.object_shift_px`), for every measured object.
    ``lit``: the template is lit by the lighting fitted to the view's image
    (:func:`ycbvss.refine.shading.lit_template`), so shading edges inside the silhouette (a mug's
    inner wall, a can's rim) are in the template as in the image instead of pulling the
    profile's best shift away from the silhouette: at the exact GT, long-1's mug read 2.7-3.0 px in
    its clearest views unlit, 0.17-0.42 px lit (medium-7's potted meat can 1.0-1.35 -> 0.22-0.25)."""
    renderer = renderer or get_renderer()
    out: dict[int, dict[int, float]] = {i: {} for i in range(len(views))}
    pending: list = []          # renders on this thread (the GL context's), the rest on the view pool

    def collect(n_left: int) -> None:
        while len(pending) > n_left:
            i, job = pending.pop(0)
            for o, (r, n_px, sh) in job.result().items():
                if np.isfinite(r):
                    out[i][o] = r
                    if lengths is not None:
                        lengths.setdefault(i, {})[o] = n_px
                if shifts is not None and np.isfinite(sh):
                    shifts.setdefault(i, {})[o] = sh

    for i, v in enumerate(views):
        P = {j: poses[(v.im_id, o)] for j, o in enumerate(obj_ids) if ok[j] and (v.im_id, o) in poses}
        if not P:
            continue
        vr = render_view(renderer, models, obj_ids, v.K, v.width, v.height, P)
        pending.append((i, _view_pool().submit(_one_view_contour_offsets, vr, v.image, obj_ids,
                                               image_mags[i] if image_mags is not None else None, lit,
                                               shifts is not None)))
        collect(4)              # at most 4 views' renders in flight (bounded memory)
    collect(0)
    return out


def _one_view_contour_offsets(vr: ViewRender, image: np.ndarray, obj_ids: list, mag: np.ndarray | None,
                              lit: bool, with_shift: bool = False) -> dict[int, tuple[float, int, float]]:
    """One view of :func:`_view_contour_offsets`: obj_id -> (offset px, visible contour pixels,
    2-D template shift px at the image width's reach, :func:`ycbvss.refine.view_shift.object_shift_px`)
    of the objects in the template render ``vr`` (NaN offset / shift where not measurable; the shift
    only ``with_shift``)."""
    mag = gradient_magnitude(image, 1.0) if mag is None else mag
    if lit and vr.normal is not None:
        vr = dc_replace(vr, color=lit_template(vr.color, vr.normal, vr.instance, image, max_px=8000))
    mag_t = gradient_magnitude(composite(vr, image), 1.0)
    res = {}
    reach = REACH_PX * image.shape[1] / REF_WIDTH_PX
    for j in vr.obj_index:
        r, n_px = contour_offset_px(mag, mag_t, vr.instance, vr.depth_mm, vr.label_of(j), return_length=True)
        sh = object_shift_px(mag, mag_t, vr.instance == vr.label_of(j), reach)[0] if with_shift else float("nan")
        if np.isfinite(r) or np.isfinite(sh):
            res[obj_ids[j]] = (float(r), int(n_px), float(sh))
    return res


def _object_quality(per_view: dict[int, dict[int, float]], models: dict, obj_ids: list) -> dict:
    """Per object: ``contour_px`` = median over the given views' contour offsets (px) of the object
    (:func:`_view_contour_offsets`), ``contour_views`` how many, ``radius_mm`` = mean vertex
    distance from the model origin."""
    out = {}
    for o in obj_ids:
        vals = [d[o] for d in per_view.values() if o in d]
        m = models[o]
        V = m.vertices_mm if m.path is not None else np.asarray(m.mesh.vertices, np.float64)
        out[o] = {"contour_px": float(np.median(vals)) if vals else float("nan"),
                  "contour_views": len(vals), "radius_mm": float(np.linalg.norm(V, axis=1).mean())}
    return out


def _contour_offsets_all_views(views: list, models: dict, obj_ids: list, ok: np.ndarray, poses: dict,
                               imgs: _SceneImages, chunk: int = 40, lit: bool = True,
                               shifts: dict | None = None) -> tuple[dict, dict]:
    """:func:`_view_contour_offsets` of every view (lit template by default, as the status reads
    them), images loaded ``chunk`` at a time (bounded memory): (view index -> obj_id -> offset px,
    view index -> obj_id -> visible contour pixels). ``shifts`` (a dict, filled when given): view
    index -> obj_id -> 2-D template shift (px)."""
    renderer = get_renderer()
    per_view: dict[int, dict[int, float]] = {}
    lengths: dict[int, dict[int, int]] = {}
    for c0 in range(0, len(views), max(chunk, 1)):
        idx = list(range(c0, min(c0 + chunk, len(views))))
        imgs.keep(idx)
        sub_len: dict = {}
        sub_sh: dict = {}
        sub = _view_contour_offsets([views[i] for i in idx], models, obj_ids, ok, poses, renderer, lengths=sub_len,
                                    lit=lit, shifts=sub_sh)
        per_view.update({idx[k]: d for k, d in sub.items()})
        lengths.update({idx[k]: d for k, d in sub_len.items()})
        if shifts is not None:
            shifts.update({idx[k]: d for k, d in sub_sh.items()})
    imgs.keep([])
    return per_view, lengths


def _worst_views(per_view: dict, lengths: dict, obj_ids: list) -> dict[int, float]:
    """obj_id -> :func:`ycbvss.refine.confidence.worst_views_px` over every view it has a contour offset in."""
    out = {}
    for o in obj_ids:
        seen = [i for i in per_view if o in per_view[i]]
        out[o] = worst_views_px([per_view[i][o] for i in seen], [lengths[i][o] for i in seen])
    return out


def _quality_on_views(views: list, models: dict, obj_ids: list, ok: np.ndarray, poses: dict, opt: RefineOptions,
                      imgs: _SceneImages, n_views: int = 8, chunk: int = 40) -> tuple[dict, np.ndarray, np.ndarray]:
    """Contour offsets of every view (:func:`_contour_offsets_all_views`). Returns (per-object
    quality from up to ``n_views`` evenly spaced views, :func:`_object_quality`, with
    ``contour_worst_px`` from all views, :func:`_worst_views`; per-view median over its objects'
    offsets (n,), NaN where no contour is visible): a camera left off puts every object of its view
    off the image edges, which the per-object median over a few views does not see; per-view median
    of its objects' 2-D template shifts (n,) px (:func:`ycbvss.refine.view_shift.view_shift_px`), the
    same check for a camera several pixels off, beyond the contour offset's reach."""
    n = len(views)
    shifts: dict = {}
    per_view, lengths = _contour_offsets_all_views(views, models, obj_ids, ok, poses, imgs, chunk, shifts=shifts)
    q_idx = np.unique(np.round(np.linspace(0, n - 1, min(n_views, n))).astype(int))
    quality = _object_quality({int(i): per_view[int(i)] for i in q_idx}, models, obj_ids)
    for o, w in _worst_views(per_view, lengths, obj_ids).items():
        quality[o]["contour_worst_px"] = w
    view_px = np.array([float(np.median(list(per_view[i].values()))) if per_view[i] else float("nan")
                        for i in range(n)])
    view_shift = np.array([view_shift_px(shifts.get(i, {}).values()) for i in range(n)])
    return quality, view_px, view_shift


class _TurnFit(NamedTuple):
    """An object's turned-copy check (:mod:`ycbvss.refine.turn_check`): the best turn's mean gain
    (NCC) over the refined pose, its label and model-frame transform (None when no turn was
    measured), the refined pose's own interior NCC (mean over views weighted by their interior
    pixels) and the best turned copy's (mean over views)."""

    gain: float
    label: str
    transform: np.ndarray | None
    ncc: float
    fit: float
    texture: float = float("nan")   # the refined pose's template texture share (turn_check.texture_share)
    # untextured objects only: the turn about the body's axis whose visible silhouette stays closest to
    # the refined pose's in every checked view, and that change (px^2 at 640 px,
    # turn_check.same_silhouette_turn); "" / NaN when not measured
    silhouette_label: str = ""
    silhouette_px2: float = float("nan")


def _turn_gains(views: list, models: dict, obj_ids: list, ok: np.ndarray, poses: dict, syms: list,
                imgs: _SceneImages, n_views: int = 3) -> dict[int, _TurnFit]:
    """Per object: its :class:`_TurnFit`, from up to ``n_views`` evenly spaced views. Each object
    is rendered, refined and turned, with the others in place so they still occlude it, in a window
    around its bounding sphere only (the turns are about the sphere's centre, so it holds them all;
    the window's size is rounded up to 32 px so the renderer reuses its buffers)."""
    renderer = get_renderer()
    n = len(views)
    idx = [int(i) for i in np.unique(np.round(np.linspace(0, n - 1, min(n_views, n))).astype(int))]
    turns, sphere, verts = {}, {}, {}
    for j, o in enumerate(obj_ids):
        if ok[j]:
            V = models[o].vertices_mm if models[o].path is not None else np.asarray(models[o].mesh.vertices, np.float64)
            c = bbox_center(V)
            sphere[j] = (c, float(np.linalg.norm(V - c, axis=1).max()))
            # only the evaluation's symmetries (ADD-S objects) are skipped: a geometric symmetry of a
            # textured object (the tuna can's axis) is no symmetry of its appearance
            turns[j] = turn_transforms(c, syms[j] if models[o].symmetric else None)
            verts[j] = V
    base: dict[int, list] = {j: [] for j in turns}
    alt: dict[int, dict[str, list]] = {j: {lab: [] for lab, _ in turns[j]} for j in turns}
    # untextured objects only, made when first needed: turns about the body's axis and their silhouette changes
    axis_turns: dict[int, list] = {}
    sil: dict[int, dict[str, list]] = {j: {} for j in turns}
    imgs.keep(idx)
    for i in idx:
        v = views[i]
        P = {j: poses[(v.im_id, obj_ids[j])] for j in turns if (v.im_id, obj_ids[j]) in poses}
        P = {j: T for j, T in P.items() if np.isfinite(T).all() and T[2, 3] > 10.0}
        if not P:
            continue
        mag = gradient_magnitude(v.image, 1.0)
        for j in P:
            box = _sphere_window(v, P[j], *sphere[j])
            if box is None:
                continue
            y0, y1, x0, x1 = box
            K = _subpixel_K(v.K, box, 1)      # the window's intrinsics
            others = [(mesh_key(obj_ids[k], models[obj_ids[k]]), T) for k, T in P.items() if k != j]
            key = mesh_key(obj_ids[j], models[obj_ids[j]])
            crop, mag_c = v.image[y0:y1, x0:x1], mag[y0:y1, x0:x1]

            W, H = x1 - x0, y1 - y0
            # the others once, the object alone per turn; the z-test of the two is done per pixel
            # in _turn_ncc (the same picture as drawing them together, but each turn draws one mesh)
            occ = (renderer.render(K, W, H, others, outputs=("depth", "color")) if others else None)
            occ_d, occ_c = (None, None) if occ is None else (occ.depth_mm, occ.color)

            def fit(T):
                out = renderer.render(K, W, H, [(key, T)], outputs=("depth", "color"))
                return _view_pool().submit(_turn_ncc, crop, mag_c, out.depth_mm, out.color, occ_d, occ_c)

            # renders here (the GL thread), the NCCs on the view pool; results collected below. The
            # refined pose's template picture is made here: its texture share decides the silhouette turns
            b0 = renderer.render(K, W, H, [(key, P[j])], outputs=("depth", "color"))
            tm, inner = _template_magnitude(crop, b0.depth_mm, b0.color, occ_d, occ_c)
            share = texture_share(tm, inner, erode_px=0)
            base[j].append(_view_pool().submit(_base_ncc, mag_c, tm, inner, share))
            for lab, A in turns[j]:
                alt[j][lab].append(fit(P[j] @ A))
            if np.isfinite(share) and share < TEXTURED_MIN:      # untextured: turned about its body's axis
                if j not in axis_turns:
                    axis_turns[j] = axis_turn_transforms(revolution_axes(verts[j]),
                                                         syms[j] if models[obj_ids[j]].symmetric else None)
                vis0 = _visible(b0.depth_mm, occ_d)
                for lab, A in axis_turns[j]:
                    d = renderer.render(K, W, H, [(key, P[j] @ A)], outputs=("depth",)).depth_mm
                    sil[j].setdefault(lab, []).append(silhouette_change_px2(vis0, _visible(d, occ_d), v.width,
                                                                            REF_WIDTH_PX))
    base_res = {j: np.asarray([f.result() for f in fs], float).reshape(-1, 3) for j, fs in base.items()}  # (NCC, texture, px) per view
    alt = {j: {lab: [f.result()[0] for f in fs] for lab, fs in d.items()} for j, d in alt.items()}
    imgs.keep([])

    def finite_mean(a: np.ndarray) -> float:
        return float(np.mean(a[np.isfinite(a)])) if np.isfinite(a).any() else float("nan")

    out = {}
    for j in turns:
        b, t, n_px = base_res[j][:, 0], base_res[j][:, 1], base_res[j][:, 2]
        gain, lab, fit = best_turn(b, alt[j])
        s_lab, s_px2 = same_silhouette_turn(sil[j])
        out[obj_ids[j]] = _TurnFit(gain, lab, dict(turns[j]).get(lab), views_ncc(b, n_px), fit, finite_mean(t),
                                   s_lab, s_px2)
    return out


def _visible(depth_mm: np.ndarray, occ_depth_mm: np.ndarray | None) -> np.ndarray:
    """The object's visible pixels (H, W bool): rendered (``depth_mm`` > 0) and nearer than the other
    objects (``occ_depth_mm``, 0 = none; None: no others), as :func:`_template_magnitude` pastes it."""
    obj = depth_mm > 0
    if occ_depth_mm is not None:
        obj &= (occ_depth_mm <= 0) | (depth_mm < occ_depth_mm)
    return obj


def _base_ncc(mag_c: np.ndarray, tm: np.ndarray, inner: np.ndarray, share: float) -> tuple[float, float, int]:
    """:func:`_turn_ncc`'s result with ``texture`` for a template picture already made (its gradient
    magnitude ``tm``, visible interior ``inner`` and texture share ``share``)."""
    return interior_ncc(mag_c, tm, inner, erode_px=0), share, int(inner.sum())


def _turn_ncc(crop: np.ndarray, mag_c: np.ndarray, depth_mm: np.ndarray, color: np.ndarray,
              occ_depth_mm: np.ndarray | None, occ_color: np.ndarray | None,
              texture: bool = False) -> tuple[float, float, int]:
    """Interior NCC of gradient magnitudes between the image window ``crop`` (its gradient
    magnitude ``mag_c``) and the template picture of :func:`_template_magnitude`, over the object's
    visible pixels. Returns (NCC, the template's texture share there with ``texture``,
    :func:`ycbvss.refine.turn_check.texture_share`, else NaN; the number of interior pixels)."""
    tm, inner = _template_magnitude(crop, depth_mm, color, occ_depth_mm, occ_color)
    return (interior_ncc(mag_c, tm, inner, erode_px=0),
            texture_share(tm, inner, erode_px=0) if texture else float("nan"), int(inner.sum()))


def _template_magnitude(crop: np.ndarray, depth_mm: np.ndarray, color: np.ndarray,
                        occ_depth_mm: np.ndarray | None, occ_color: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """The image window ``crop`` with the rendered objects pasted in -- the object under test
    (``depth_mm``, 0 = background, and template ``color``) in front of the other objects
    (``occ_depth_mm``, ``occ_color``; None: none) where it is nearer -- as (its gradient magnitude
    (H, W), the object's visible pixels eroded by the interior margin (H, W) bool)."""
    obj = depth_mm > 0
    tmpl = crop.copy()
    if occ_depth_mm is not None:
        occ = occ_depth_mm > 0
        obj &= ~occ | (depth_mm < occ_depth_mm)
        np.copyto(tmpl, occ_color, where=(occ & ~obj)[..., None])
    np.copyto(tmpl, color, where=obj[..., None])
    return gradient_magnitude(tmpl, 1.0), interior_mask(obj)     # eroded once for every measure


def _sphere_window(view, T: np.ndarray, centre_mm: np.ndarray, radius_mm: float, margin_px: int = 8,
                   step_px: int = 32) -> tuple[int, int, int, int] | None:
    """Pixel window (y0, y1, x0, x1) of ``view`` that holds the projection of the sphere (model
    frame centre, radius, mm) at pose ``T`` plus ``margin_px``, its size rounded up to ``step_px``
    (within the image); None when the sphere reaches behind the camera or misses the image."""
    c = T[:3, :3] @ centre_mm + T[:3, 3]
    if c[2] <= radius_mm * 1.05:
        return None
    K = view.K
    half = radius_mm / np.sqrt(c[2] ** 2 - radius_mm ** 2)       # tangent of the sphere's half-angle
    u, w = K[0, 0] * c[0] / c[2] + K[0, 2], K[1, 1] * c[1] / c[2] + K[1, 2]
    # half-extent of the projected sphere, generously for off-axis positions
    hu = K[0, 0] * half * (1.0 + abs(c[0]) / c[2]) * 1.1 + margin_px
    hv = K[1, 1] * half * (1.0 + abs(c[1]) / c[2]) * 1.1 + margin_px
    W, H = view.width, view.height
    x0, x1 = int(max(np.floor(u - hu), 0)), int(min(np.ceil(u + hu), W))
    y0, y1 = int(max(np.floor(w - hv), 0)), int(min(np.ceil(w + hv), H))
    if x1 - x0 < 8 or y1 - y0 < 8:
        return None
    sw, sh = min(-(-(x1 - x0) // step_px) * step_px, W), min(-(-(y1 - y0) // step_px) * step_px, H)
    x0, y0 = min(x0, W - sw), min(y0, H - sh)
    x1, y1 = x0 + sw, y0 + sh
    return y0, y1, x0, x1
