"""Rendered templates T_ij of a view (all modelled objects at once, so they occlude each other) and
the samples taken from them: edge points (exterior contour + interior Canny) and flow matches,
both lifted to 3D through the rendered depth."""
from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass

import cv2
import numpy as np

from ..geometry.se3 import inv_T
from ..render import Renderer
from .area_kernel import subpixel_sums
from .contour_match import (appearance_offsets, contour_normals, match_contour_to_blur, synthetic_contour_offsets,
                            synthetic_image)
from .edge import all_contour_points, all_interior_points, contact_samples, contour_points, interior_points, subsample
from .jacobians import backproject_px
from .srgb import encode_u8
from .srgb import tables as srgb_tables

_RENDERERS: dict[bool, Renderer] = {}
_SRGB_TEXTURES = False            # the mode get_renderer() serves (set by texture_mode)


def get_renderer():
    """One fast renderer per process (moderngl EGL context) and texture mode (:func:`texture_mode`)."""
    if _SRGB_TEXTURES not in _RENDERERS:
        _RENDERERS[_SRGB_TEXTURES] = Renderer(srgb_textures=_SRGB_TEXTURES)
    return _RENDERERS[_SRGB_TEXTURES]


@contextmanager
def texture_mode(srgb_textures: bool):
    """Within this block :func:`get_renderer` serves the renderer whose textures are filtered in
    linear light (``srgb_textures``, :class:`ycbvss.render.Renderer`), or on their sRGB-encoded
    values (False, the default). ``RefineOptions.template_srgb_textures`` sets it for one refinement."""
    global _SRGB_TEXTURES
    before, _SRGB_TEXTURES = _SRGB_TEXTURES, bool(srgb_textures)
    try:
        yield
    finally:
        _SRGB_TEXTURES = before


def mesh_key(obj_id: int, model) -> tuple:
    return ("ycbvss.refine", int(obj_id), str(getattr(model, "path", "")), id(model))


def ensure_meshes(renderer, models: dict) -> None:
    """Upload each model's mesh once per model object. The key holds ``id(model)``; the renderer keeps
    the model referenced with it, so a later model at a freed model's address (same id, same obj_id,
    e.g. two procedural scenes in one process) is uploaded anew instead of drawn with the old mesh."""
    for oid, m in models.items():
        k = mesh_key(oid, m)
        if not renderer.has_mesh_of(k, m):
            renderer.add_mesh(k, m.mesh, owner=m)


@dataclass
class ViewRender:
    """Render of all objects of one view: instance (H, W) (index into ``obj_index`` + 1, 0 = none),
    depth_mm (H, W), color (H, W, 3) uint8, the poses used and the object indices rendered."""

    instance: np.ndarray
    depth_mm: np.ndarray
    color: np.ndarray
    poses: list[np.ndarray]
    obj_index: list[int]
    normal: np.ndarray | None = None
    back_depth_mm: np.ndarray | None = None
    back_instance: np.ndarray | None = None
    # supersampled templates (:func:`average_subpixels`): the colour integrated over each pixel's area
    # (H, W, 3) uint8 and the share of each pixel's area an object covers (H, W) float32; None:
    # point-sampled only. ``color`` stays point-sampled (f_edge's texture edges and contour appearance)
    area_color: np.ndarray | None = None
    coverage: np.ndarray | None = None
    # the sub-pixel render they come from until :func:`area_template` averages it:
    # ((y0, y1, x0, x1) box, f, (h f, w f, 3) uint8 colour, (h f, w f) bool hit)
    area_src: tuple | None = None

    def label_of(self, j: int) -> int:
        return self.obj_index.index(j) + 1 if j in self.obj_index else -1

    def mask(self, j: int) -> np.ndarray:
        return self.instance == self.label_of(j)


_SRGB_U8_TO_LINEAR255 = None


def _decode_table() -> np.ndarray:
    """(256,) float32: 8-bit sRGB code -> linear light in [0, 255] (:mod:`ycbvss.refine.srgb`'s table)."""
    global _SRGB_U8_TO_LINEAR255
    if _SRGB_U8_TO_LINEAR255 is None:
        _SRGB_U8_TO_LINEAR255 = (255.0 * srgb_tables()["decode_u8"]).astype(np.float32)
    return _SRGB_U8_TO_LINEAR255


def _subpixel_K(K: np.ndarray, box: tuple[int, int, int, int], f: int) -> np.ndarray:
    """Intrinsics of the crop ``box`` (y0, y1, x0, x1) rendered at f x f sub-pixels per pixel:
    sub-pixel (a, b) of pixel (x, y) is centred at x - 1/2 + (a + 1/2) / f, i.e. x_hi = f x + (f - 1) / 2."""
    y0, _, x0, _ = box
    Kc = np.array(K, np.float64, copy=True)
    Kc[0, 2] = f * (Kc[0, 2] - x0) + (f - 1) / 2.0
    Kc[1, 2] = f * (Kc[1, 2] - y0) + (f - 1) / 2.0
    Kc[0, 0] *= f
    Kc[0, 1] *= f
    Kc[1, 1] *= f
    return Kc


def average_subpixels(color_hi: np.ndarray, hit_hi: np.ndarray, f: int) -> tuple[np.ndarray, np.ndarray]:
    """Template colour integrated over each pixel's area, as a camera's (and Blender Cycles' pixel
    filter) forms it, from an (h f, w f) render at f x f sub-pixels per pixel (``color_hi`` uint8
    sRGB, ``hit_hi`` bool): averaged in linear light over the sub-pixels that hit an object (a pixel
    on the silhouette keeps the object's colour; :func:`composite` mixes in the background),
    sRGB-encoded. Returns ((h, w, 3) uint8, (h, w) float32 coverage: the share of the pixel's
    sub-pixels that hit an object).

    Why: the fast renderer samples the texture at the pixel centre (mipmapped); an image that
    integrates over the pixel sees a perspective-foreshortened surface's texture shifted towards
    its far side (second order in the pixel size), and dense flow turns the difference into an
    apparent scale: at the exact GT of the suite's long scenes, Cycles images with the texture as
    emission (no lighting) and its 1 px pixel filter read -0.032 % (128 samples, no denoiser)
    smaller than the point-sampled template, -0.017 % against a 2 x 2 template (with the
    silhouette mixed as in :func:`composite`), -0.008 % against 3 x 3; point-sampled Cycles images
    (filter width 0.01) agree with the point-sampled template (``bench/bench_image_formation.py``)."""
    # sums over each pixel's hitting sub-pixels in linear light, compiled (refine.area_kernel)
    s, n = subpixel_sums(np.ascontiguousarray(color_hi), np.ascontiguousarray(hit_hi, dtype=bool), _decode_table(), f)
    avg = s / np.maximum(n, 1.0)
    return encode_u8(avg), (n[..., 0] / float(f * f)).astype(np.float32)


def area_template(vr: "ViewRender") -> bool:
    """Fill ``vr.area_color`` / ``vr.coverage`` from a supersampled render's sub-pixels (kept in
    ``vr.area_src`` by :func:`render_view`) on first use, in the calling thread: the averaging runs
    in f_point's pool job, not on the rendering thread. Returns whether ``vr`` has them."""
    if vr.area_color is None and vr.area_src is not None:
        (y0, y1, x0, x1), f, color_hi, hit_hi = vr.area_src
        sub, c = average_subpixels(color_hi, hit_hi, f)
        area = np.array(vr.color, copy=True)
        hit = c > 0
        area[y0:y1, x0:x1][hit] = sub[hit]
        cov = np.zeros(vr.instance.shape, np.float32)
        cov[y0:y1, x0:x1] = c
        vr.area_color, vr.coverage, vr.area_src = area, cov, None
    return vr.area_color is not None


def render_view(renderer, models: dict, obj_ids: list[int], K: np.ndarray, width: int, height: int,
                poses: dict[int, np.ndarray], back: bool = False, supersample: int = 1) -> ViewRender:
    """Render objects (index j -> pose) in front of the camera; others are skipped. ``back``: also
    the nearest back faces (``back_depth_mm`` / ``back_instance``, for the contour's rim depth).
    ``supersample`` > 1: also the objects' box rendered at f x f sub-pixels, for the colour
    integrated over each pixel's area and the objects' coverage (``area_color``, ``coverage``,
    filled by :func:`area_template` where they are used); depth, instance, normals and ``color``
    stay point-sampled at the pixel centres."""
    items, used, P = [], [], []
    for j, T in poses.items():
        if not np.all(np.isfinite(T)) or T[2, 3] <= 10.0:
            continue
        oid = obj_ids[j]
        items.append((mesh_key(oid, models[oid]), T))
        used.append(j)
        P.append(T)
    if not items:
        return ViewRender(np.zeros((height, width), np.int32), np.zeros((height, width), np.float32),
                          np.zeros((height, width, 3), np.uint8), [], [])
    outs = ("depth", "instance", "color", "normal") + (("back_depth",) if back else ())
    out = renderer.render(K, width, height, items, outputs=outs)
    src = _area_source(renderer, items, K, out.instance, supersample) if supersample > 1 else None
    return ViewRender(out.instance, out.depth_mm, out.color, P, used, out.normal_cam,
                      out.back_depth_mm, out.back_instance, area_src=src)


def _render_items(models: dict, obj_ids: list[int], poses: dict[int, np.ndarray]) -> list:
    """(mesh key, pose) of the objects :func:`render_view` draws (finite poses in front of the camera)."""
    return [(mesh_key(obj_ids[j], models[obj_ids[j]]), T) for j, T in poses.items()
            if np.all(np.isfinite(T)) and T[2, 3] > 10.0]


def _area_source(renderer, items: list, K: np.ndarray, instance: np.ndarray, f: int) -> tuple | None:
    """The objects' box (of ``instance``, grown by 1 px) rendered at f x f sub-pixels: the
    ``area_src`` of a :class:`ViewRender`, None when nothing is drawn."""
    if not np.any(instance > 0):
        return None
    height, width = instance.shape
    ys = np.flatnonzero((instance > 0).any(axis=1))
    xs = np.flatnonzero((instance > 0).any(axis=0))
    y0, y1 = max(int(ys[0]) - 1, 0), min(int(ys[-1]) + 2, height)
    x0, x1 = max(int(xs[0]) - 1, 0), min(int(xs[-1]) + 2, width)
    f = int(f)
    box = (y0, y1, x0, x1)
    hi = renderer.render(_subpixel_K(K, box, f), (x1 - x0) * f, (y1 - y0) * f, items, outputs=("instance", "color"))
    return box, f, hi.color, hi.instance > 0


def with_area(renderer, models: dict, obj_ids: list[int], K: np.ndarray, vr: "ViewRender",
              poses: dict[int, np.ndarray], f: int) -> "ViewRender":
    """``vr`` (a point-sampled :func:`render_view` at ``poses``) with the sub-pixel render a
    supersampled one would carry: the same result as ``render_view(..., supersample=f)``."""
    if f <= 1 or vr.area_src is not None or vr.area_color is not None:
        return vr
    from dataclasses import replace
    return replace(vr, area_src=_area_source(renderer, _render_items(models, obj_ids, poses), K, vr.instance, f))


def edge_samples(vr: ViewRender, j: int, K: np.ndarray, n_max: int, rng: np.random.Generator,
                 erode_px: int = 2) -> np.ndarray:
    """Up to n_max model points (mm) on the exterior contour (half) and interior Canny edges (half)
    of object j's template; the contour takes the interior's unused share."""
    lab = vr.label_of(j)
    if lab < 0:
        return np.zeros((0, 3))
    uv_c, d_c = contour_points(vr.instance, vr.depth_mm, lab)
    uv_i, d_i = interior_points(vr.instance, vr.depth_mm, vr.color, lab, erode_px=erode_px, normal=vr.normal)
    n_i = min(len(uv_i), n_max // 2)
    n_c = min(len(uv_c), n_max - n_i)
    ii = subsample(n_i, len(uv_i), rng)
    ic = subsample(n_c, len(uv_c), rng)
    uv = np.concatenate([uv_c[ic], uv_i[ii]])
    d = np.concatenate([d_c[ic], d_i[ii]])
    ok = d > 0
    Y = backproject_px(K, uv[ok], d[ok])
    P = vr.poses[lab - 1]
    return Y @ inv_T(P)[:3, :3].T + inv_T(P)[:3, 3]


@dataclass
class EdgeCandidates:
    """All edge pixels of one view's template before sampling: exterior contour (``uv_c`` (N, 2),
    ``d_c`` depth (N,), ``l_c`` label (N,)) and interior (``uv_i``, ``d_i``, ``l_i``)."""

    uv_c: np.ndarray
    d_c: np.ndarray
    l_c: np.ndarray
    uv_i: np.ndarray
    d_i: np.ndarray
    l_i: np.ndarray
    n_c: np.ndarray | None = None   # (N, 2) outward unit normals of the contour samples (``normals=True``)


def near_plane(uv: np.ndarray, depth_mm: np.ndarray, n_c: np.ndarray, d_c: float, K: np.ndarray,
               height_mm: float) -> np.ndarray:
    """Which image points uv (N, 2, px) at depths ``depth_mm`` (N,) lie less than ``height_mm`` above
    the plane n_c . X = d_c (camera frame, mm; n_c unit, towards the camera): (N,) bool.

    Used for the contour samples where an object meets the table: there the table's contact shadow
    and the object's own occlusion of the room light darken both sides of the silhouette in a real
    or Cycles image, which the templates (no shadows) lack. Measured at the exact GT of the ycbv21
    suite (scenes 1-9, ``bench/bench_contour_offsets.py --contact 15``): on the contours' lower
    stretches at a contact line the image's edge lies 0.185 px (rms over objects of the per-object
    mean offset) from the lit template's prediction, on their free upper stretches 0.044 px."""
    uv = np.asarray(uv, np.float64)
    Ki = np.linalg.inv(np.asarray(K, np.float64))
    ray = np.c_[uv, np.ones(len(uv))] @ Ki.T
    P = ray * np.asarray(depth_mm, np.float64)[:, None]
    return (P @ np.asarray(n_c, np.float64) - float(d_c)) < float(height_mm)


def view_edge_candidates(vr: ViewRender, erode_px: int = 2, creases: bool = True,
                         fold_min_angle_deg: float = 25.0, blur_sigma_px: float | None = None,
                         image: np.ndarray | None = None, normals: bool = False,
                         appearance_color: np.ndarray | None = None,
                         interior_max_turn_deg: float = 0.0, interior_min_sharpness: float = 0.0,
                         contact_mm: float = 0.0, normals_contact_mm: float = 0.0,
                         junction_px: float = 0.0, interior_ridge_sigma_px: float = 0.0,
                         interior_color: np.ndarray | None = None,
                         table_plane: tuple | None = None, table_offset: bool = False,
                         interior_turn_labels: np.ndarray | None = None,
                         appearance_model: str = "profile",
                         appearance_coverage: np.ndarray | None = None,
                         appearance_psf_px: float = 0.0,
                         appearance_pixel_filter: str = "box",
                         appearance_linear_labels: frozenset = frozenset()) -> EdgeCandidates:
    """Contour and interior edge pixels of every rendered object of a view (no random numbers
    drawn, so views can be processed concurrently; :func:`select_edge_samples` draws from them).
    ``creases``: add the template's crease edges (folds sharper than ``fold_min_angle_deg``,
    self-occlusions) to the interior candidates, see :func:`ycbvss.refine.edge.crease_edges`.
    ``blur_sigma_px``: move the contour samples to where an edge field of that blur shows the
    silhouette (:func:`ycbvss.refine.contour_match.match_contour_to_blur`); None: half a pixel
    outside the contour pixels. ``image`` (with ``blur_sigma_px``): also move them by what the
    template's texture and the image's background beside them predict
    (:func:`ycbvss.refine.contour_match.appearance_offsets`); ``appearance_color`` (H, W, 3 uint8):
    the template colour that prediction uses instead of ``vr.color`` (e.g. the lit template of
    :func:`ycbvss.refine.shading.lit_template`). ``normals``: also the contour samples' outward
    normals (``n_c``, f_edge's contour-dilation nuisance). ``interior_max_turn_deg`` > 0: interior
    texture (Canny) candidates only where the surface is flat at the pixel scale
    (:func:`ycbvss.refine.interior_edges.flat_at`; needs ``vr.normal``); crease and self-occlusion
    candidates are kept; ``interior_turn_labels``: only these labels' candidates are so gated (None: all).
    ``interior_min_sharpness`` > 0: interior texture candidates only where
    the template's edge is sharp (:func:`ycbvss.refine.interior_edges.sharp_at`). ``contact_mm`` > 0:
    no contour samples where another object's surface lies less than that far behind (contact
    lines, see :func:`ycbvss.refine.edge.all_contour_points`). ``normals_contact_mm`` > 0 (with
    ``normals``): only the contour samples on contact lines (:func:`ycbvss.refine.edge.contact_samples`
    with that distance) keep their normals, the others get zero rows (f_edge's contact-offset nuisance).
    ``junction_px`` > 0: no contour samples that close to where their object borders a nearer one
    (T-junctions, :func:`ycbvss.refine.edge.junction_mask`). ``interior_ridge_sigma_px`` > 0: interior
    texture candidates located on the template's own edge field at that blur
    (:func:`ycbvss.refine.edge.ridge_edges`), in ``interior_color`` (e.g. the pixel-area template
    ``vr.area_color``; None: ``vr.color``). ``table_plane`` (n_c, d_c, K, height_mm): no contour
    samples less than that high above the table plane (:func:`near_plane`); with ``table_offset``
    they are kept and, with ``normals_contact_mm`` > 0, keep their normals like contact-line samples.
    ``appearance_model`` "synthetic" (with ``image``): the appearance prediction is not one profile
    per sample but the image the template predicts, searched with the image's own edge operator
    (:func:`ycbvss.refine.contour_match.synthetic_contour_offsets`): ``appearance_color`` (the objects'
    colour wherever they cover part of a pixel) mixed with the image's background by
    ``appearance_coverage`` (H, W; None: the binary silhouettes) and blurred by a camera blur of
    ``appearance_psf_px`` (:func:`ycbvss.refine.contour_match.synthetic_image`); samples where it shows
    no edge are dropped. ``appearance_pixel_filter``: the camera pixel's footprint the "profile" model
    integrates each profile over (:func:`ycbvss.refine.contour_match.pixel_filter_kernel`).
    ``appearance_linear_labels``: the labels whose "profile" prediction stays in linear light
    (``linear_labels`` of :func:`ycbvss.refine.contour_match.appearance_offsets`)."""
    uv_c, d_c, l_c = all_contour_points(vr.instance, vr.depth_mm, vr.back_depth_mm, vr.back_instance,
                                        contact_mm=contact_mm, junction_px=junction_px)
    at_table = None
    if table_plane is not None and len(uv_c):
        at_table = near_plane(uv_c, d_c, *table_plane)
        if not table_offset:                    # dropped; else kept, sharing one offset (see below)
            uv_c, d_c, l_c = uv_c[~at_table], d_c[~at_table], l_c[~at_table]
            at_table = None
    if blur_sigma_px is not None:
        geo = uv_c
        uv_c = match_contour_to_blur(uv_c, l_c, vr.instance, blur_sigma_px)
        if image is not None and appearance_model == "synthetic":
            col = vr.color if appearance_color is None else appearance_color
            n = contour_normals(uv_c, l_c, vr.instance, blur_sigma_px)
            syn = synthetic_image(vr.instance, appearance_coverage, col, image, psf_sigma_px=appearance_psf_px)
            off = synthetic_contour_offsets(uv_c, n, syn, blur_sigma_px)
            ok = np.isfinite(off)
            uv_c = uv_c[ok] + off[ok, None] * n[ok]
            geo, d_c, l_c = geo[ok], d_c[ok], l_c[ok]
            at_table = None if at_table is None else at_table[ok]
        elif image is not None:
            col = vr.color if appearance_color is None else appearance_color
            off, n = appearance_offsets(geo, l_c, vr.instance, col, image, blur_sigma_px,
                                        pixel_filter=appearance_pixel_filter,
                                        linear_labels=frozenset(appearance_linear_labels))
            uv_c = uv_c + off[:, None] * n
    icol = vr.color if interior_color is None else interior_color
    uv_i, d_i, l_i = all_interior_points(vr.instance, vr.depth_mm, icol, vr.normal if creases else None,
                                         erode_px=erode_px, fold_min_angle_deg=fold_min_angle_deg,
                                         back_depth=vr.back_depth_mm, back_inst=vr.back_instance,
                                         texture_max_turn_deg=interior_max_turn_deg, surface_normal=vr.normal,
                                         texture_min_sharpness=interior_min_sharpness,
                                         texture_ridge_sigma_px=interior_ridge_sigma_px,
                                         texture_turn_labels=interior_turn_labels)
    n_c = contour_normals(uv_c, l_c, vr.instance, blur_sigma_px or 1.0) if normals else None
    if n_c is not None and normals_contact_mm > 0.0:
        on_line = contact_samples(vr.instance, vr.depth_mm, geo if blur_sigma_px is not None else uv_c, n_c, l_c,
                                  normals_contact_mm)
        if at_table is not None:
            on_line = on_line | at_table
        n_c[~on_line] = 0.0
    return EdgeCandidates(uv_c, d_c, l_c, uv_i, d_i, l_i, n_c)


def select_edge_samples(vr: ViewRender, K: np.ndarray, cands: EdgeCandidates, n_max: int,
                        rng: np.random.Generator, normals: dict | None = None,
                        contour: dict | None = None) -> dict[int, np.ndarray]:
    """Up to n_max model points (mm) per rendered object from a view's :class:`EdgeCandidates`:
    interior edges (at most half) and contour (the rest), drawn with ``rng`` object by object.
    ``normals`` (a dict, filled when the candidates carry ``n_c``): object -> (N, 2) outward image
    normals of its samples, zero rows for the interior ones (same order as the points).
    ``contour`` (a dict, filled): object -> (N,) bool, True for its exterior-contour samples."""
    c = cands
    out = {}
    for lab0, j in enumerate(vr.obj_index):
        lab = lab0 + 1
        ci, ii_ = np.flatnonzero(c.l_c == lab), np.flatnonzero(c.l_i == lab)
        n_i = min(len(ii_), n_max // 2)
        n_c = min(len(ci), n_max - n_i)
        sel_i = ii_[subsample(n_i, len(ii_), rng)]
        sel_c = ci[subsample(n_c, len(ci), rng)]
        uv = np.concatenate([c.uv_c[sel_c], c.uv_i[sel_i]])
        d = np.concatenate([c.d_c[sel_c], c.d_i[sel_i]])
        ok = d > 0
        Pinv = inv_T(vr.poses[lab0])
        out[j] = backproject_px(K, uv[ok], d[ok]) @ Pinv[:3, :3].T + Pinv[:3, 3]
        if normals is not None and c.n_c is not None:
            normals[j] = np.concatenate([c.n_c[sel_c], np.zeros((len(sel_i), 2))])[ok]
        if contour is not None:
            contour[j] = np.concatenate([np.ones(len(sel_c), bool), np.zeros(len(sel_i), bool)])[ok]
    return out





def composite(vr: ViewRender, image: np.ndarray, box: tuple[int, int, int, int] | None = None,
              area: bool = False) -> np.ndarray:
    """The template: rendered colour where an object was rendered, else the image itself
    (``box`` = (y0, y1, x0, x1): only that crop of it, the same pixels as cropping the whole).
    ``area`` (a supersampled template, ``vr.coverage`` set): ``vr.color`` is taken as the
    area-integrated colour, and a partly covered pixel mixes it with the background by the coverage."""
    y0, y1, x0, x1 = (0, image.shape[0], 0, image.shape[1]) if box is None else box
    out = image[y0:y1, x0:x1].copy()
    if not area or vr.coverage is None:
        np.copyto(out, vr.color[y0:y1, x0:x1], where=(vr.instance[y0:y1, x0:x1] > 0)[..., None])
        return out
    # area-integrated template: a partly covered pixel mixes the object's colour with the background
    # in linear light by its coverage, as the camera mixes them
    a = vr.coverage[y0:y1, x0:x1]
    np.copyto(out, vr.color[y0:y1, x0:x1], where=(a >= 1.0)[..., None])
    part = (a > 0.0) & (a < 1.0)
    if part.any():
        dec = _decode_table()
        # the background under a partly covered pixel: the mean of the uncovered pixels within 2 px
        # (the image's own value there already holds part of the object); with none within 2 px, its own
        free = (a <= 0.0).astype(np.float32)
        lin = dec[out]
        num = cv2.boxFilter(lin * free[..., None], -1, (5, 5), normalize=False)[part]
        den = cv2.boxFilter(free, -1, (5, 5), normalize=False)[part][:, None]
        bg = np.where(den > 0, num / np.maximum(den, 1e-6), lin[part])
        w = a[part][:, None]
        out[part] = encode_u8(w * dec[vr.color[y0:y1, x0:x1][part]] + (1.0 - w) * bg)
    return out


def lift(vr: ViewRender, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Camera points (N, 3) at integer-rounded pixels uv (N, 2) through the rendered depth; valid (N,)."""
    H, W = vr.depth_mm.shape
    u = np.clip(np.round(uv[:, 0]).astype(int), 0, W - 1)
    v = np.clip(np.round(uv[:, 1]).astype(int), 0, H - 1)
    d = vr.depth_mm[v, u].astype(np.float64)
    return d, d > 0
