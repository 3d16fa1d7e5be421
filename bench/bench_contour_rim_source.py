"""Where the contour's shared shift comes from: the background beside the contour, or the object's
own outer pixels? And does a prediction that reads the image still follow the pose?

At the exact GT each (view, object)'s image edge lies a shared 2-D shift off the lit contour
prediction (rms 0.19 px on suite long-1 and long-2, ``bench_contour_offsets.py --shift``). That
prediction (``refine.contour_match.appearance_offsets``) models the profile across the contour as the
lit template inside and one flat colour of the image outside. Two probes replace part of it with the
image's own profile along the normal:

- ``outside d``: the image from d px outside (held at its value at d nearer), so the background's
  own gradients (a cast shadow's penumbra, a neighbour's edge) within the blur's reach are in;
- ``inside+outside d``: also the image from d px inside, the lit template (scaled to meet it) nearer.

And the template's lighting (``--lightings``): unlit, the SH Lambert fit (the refiner's), with the
rim's shading held, with the glossy reflection basis, and the pixel-area templates. If the shift
came from the background, ``outside`` would remove it; if from the lighting model, another lighting
would. ``--images`` reads the frames from a re-render of the same scene (e.g.
``bench_bias_lighting.py``'s emission variant: no light at all). A prediction that reads the
image near the object's own edge can fit the image at any pose, so each variant is also measured
with every object's template moved by ``--displace-px`` px along the image's u axis (a camera-frame
x translation of d z / f_x mm): a prediction that follows the pose gives a mean fitted shift
s_u of -d more than at the GT, i.e. a response of 1.0; a response below 1 says by how much the
prediction follows the image instead (f_edge would then hold the pose that much less).

    python bench/bench_contour_rim_source.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \
        --scenes 1,2 --frames 0,25,50,75,100,125,150,175 --out bench/results/ycbv21/s87/rim_source

The image is the suite's Cycles render, the templates the fast renderer's.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contour_offsets import add_view_args, shift_fit, shift_stats  # noqa: E402


LIGHTINGS = {"sh": "lit (the refiner's)", "unlit": "unlit template", "rim3": "lit, rim's shading held 3 px",
             "reflection": "lit + glossy reflection", "area": "lit pixel-area template (2 x 2)",
             "area4": "lit pixel-area template (4 x 4)"}
AREA = {"area": 2, "area4": 4}       # lighting -> the render's supersampling


def variants(from_image_px: list[float], lightings: list[str]) -> list[tuple[str, str, dict]]:
    """(label, template lighting, appearance_offsets keywords) of the lit prediction, its image-profile
    probes and the other template lightings (``LIGHTINGS``: ``RefineOptions.template_shading``,
    ``shading_rim_px`` 3, ``shading_reflection``; "unlit": ``edge_appearance_lit`` False)."""
    out = [(LIGHTINGS["sh"], "sh", {})]
    out += [(f"outside {d:g} px", "sh", {"outside_from_image_px": d}) for d in from_image_px]
    out += [(f"inside+outside {d:g} px", "sh", {"outside_from_image_px": d, "inside_from_image_px": d})
            for d in from_image_px]
    out += [(LIGHTINGS[k], k, {}) for k in lightings if k != "sh"]
    return out


def template_colour(vr, img: np.ndarray, K: np.ndarray, lighting: str) -> np.ndarray:
    """The template colour the contour prediction reads, lit as ``lighting`` (see :data:`LIGHTINGS`;
    "area", "area4": the colour integrated over each pixel's area, ``vr`` rendered with that
    supersampling, as f_point's templates are: ``RefineOptions.template_supersample``)."""
    from ycbvss.refine.shading import lit_template, reflection_basis
    from ycbvss.refine.templates import area_template

    if lighting in AREA:
        area_template(vr)
        return lit_template(vr.area_color, vr.normal, vr.instance, img)
    if lighting == "unlit":
        return vr.color
    if lighting == "rim3":
        return lit_template(vr.color, vr.normal, vr.instance, img, rim_px=3)
    if lighting == "reflection":
        return lit_template(vr.color, vr.normal, vr.instance, img, additive=reflection_basis(vr.normal, K))
    return lit_template(vr.color, vr.normal, vr.instance, img)


def displaced(T: np.ndarray, K: np.ndarray, d_px: float) -> np.ndarray:
    """Pose ``T`` (4x4, mm) moved along the camera's x by ``d_px`` px at its own depth."""
    out = np.array(T, dtype=np.float64, copy=True)
    out[0, 3] += d_px * out[2, 3] / K[0, 0]
    return out


def groups(a: argparse.Namespace, d_px: float, vs: list[tuple[str, str, dict]]):
    """Per (view, object), for each variant of ``vs`` (:func:`variants`): the
    :func:`bench_contour_offsets.shift_fit` of the image edge against the contour prediction it makes,
    the templates rendered with every object moved by ``d_px``: yields (obj_id, [fit or None per variant])."""
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import build_suite
    from ycbvss.refine.contour_match import appearance_offsets, contour_normals, match_contour_to_blur
    from ycbvss.refine.edge import all_contour_points, edge_field
    from ycbvss.refine.templates import ensure_meshes, get_renderer, render_view

    root = Path(a.suite_root)
    scene_ids = [int(s) for s in a.scenes.split(",")]
    models, _ = build_suite(a.dataset, root, a.suite, scene_ids=scene_ids)
    r = get_renderer()
    ensure_meshes(r, models)
    sig = a.sigma_px
    for sid in scene_ids:
        sc = load_bop_scene((Path(a.images) if a.images else root) / "test", sid, models)
        for fr in sc.frames if a.images else [sc.frames[int(x)] for x in a.frames.split(",") if int(x) < len(sc.frames)]:
            cam = fr.camera
            oids = [i.obj_id for i in fr.instances]
            poses = {j: displaced(i.T_m2c, cam.K, d_px) for j, i in enumerate(fr.instances)}
            img = fr.load_rgb()
            fld = edge_field(img, sig, colour=True)
            vr = render_view(r, models, oids, cam.K, cam.width, cam.height, poses)
            colours = {lt: template_colour(vr if lt not in AREA else render_view(
                r, models, oids, cam.K, cam.width, cam.height, poses, supersample=AREA[lt]), img, cam.K, lt)
                for lt in {lt for _, lt, _ in vs}}
            # view_edge_candidates' contour steps (no contact or junction rules: every contour sample)
            geo, _, lab = all_contour_points(vr.instance, vr.depth_mm)
            matched = match_contour_to_blur(geo, lab, vr.instance, sig)
            preds = []
            for _, lt, kw in vs:
                off, n = appearance_offsets(geo, lab, vr.instance, colours[lt], img, sig, **kw)
                uv = matched + off[:, None] * n
                preds.append((uv, contour_normals(uv, lab, vr.instance, sig)))
            has_n = [np.any(n != 0.0, axis=1) for _, n in preds]
            for lab0, oid in enumerate(oids):
                sel = [(lab == lab0 + 1) & h for h in has_n]
                yield oid, [shift_fit(fld, uv[s], n[s], a.min_samples, 1.5 + abs(d_px)) for (uv, n), s in zip(preds, sel)]


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_args(ap)
    ap.add_argument("--sigma-px", type=float, default=1.0)
    ap.add_argument("--min-samples", type=int, default=40)
    ap.add_argument("--from-image-px", default="1.0,1.5", help="the probes' distances d (px, comma-separated)")
    ap.add_argument("--lightings", default="sh,unlit,rim3,reflection,area,area4",
                    help="template lightings of the contour prediction to compare (" + ", ".join(LIGHTINGS) + ")")
    ap.add_argument("--displace-px", type=float, default=0.5)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    vs = variants([float(x) for x in a.from_image_px.split(",") if x], [x for x in a.lightings.split(",") if x])
    fits = {}          # displacement -> variant index -> list of (s_u, s_v, b, rest)
    for d in (0.0, a.displace_px):
        fits[d] = {k: [] for k in range(len(vs))}
        for _, fs in groups(a, d, vs):
            if all(f is not None for f in fs):         # the same groups in every variant
                for k, f in enumerate(fs):
                    fits[d][k].append(f)
    t = Table(["groups", "shift |s| rms (px)", "dilation b rms (px)", "per-sample rest (px)", "k",
               f"response to a {a.displace_px:g} px move"], label_header="prediction", digits=3,
              caption=f"Image edge minus the contour prediction at the exact GT per (view, object), fitted as a "
                      f"shared shift s + dilation b + per-sample rest (sigma {a.sigma_px:g} px); response: the mean "
                      f"fitted s_u's change when every template moves {a.displace_px:g} px along u, over -{a.displace_px:g} "
                      f"(1 = the prediction follows the pose); {a.suite} scenes {a.scenes}, frame positions {a.frames}")
    for k, (label, _, _) in enumerate(vs):
        v0, v1 = np.array(fits[0.0][k]), np.array(fits[a.displace_px][k])
        resp = -(v1[:, 0].mean() - v0[:, 0].mean()) / a.displace_px if len(v0) and len(v1) else float("nan")
        t.rows.append(Row(label, shift_stats(v0) + [float(resp)]))
        print(f"{label}: groups {len(v0)}, |s| rms {shift_stats(v0)[1]:.3f} px, rest {shift_stats(v0)[3]:.3f} px, "
              f"response {resp:.3f}")
    for p in write_table(t, Path(a.out), "contour_rim_source"):
        print(p)


if __name__ == "__main__":
    main()
