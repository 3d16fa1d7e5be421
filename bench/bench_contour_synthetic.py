"""Three predictions of where the image shows each object's contour, at the exact GT.

For every (view, object) of the chosen suite frames (Cycles images; templates from the fast renderer
at the exact GT), the image's edge-field minimum along each contour sample's normal is fitted as a
shared 2-D shift s, a dilation b and a per-sample rest (``bench_contour_offsets.shift_fit``),
relative to each prediction:

- ``binary``: the geometric contour moved to the blur minimum of the binary silhouette
  (``refine.contour_match.match_contour_to_blur``);
- ``lit 1-D`` (the refiner's, ``edge_appearance``): that, plus one profile per sample along its
  normal from the lit template's colour and the image's background (``appearance_offsets``);
- ``synthetic 2-D``: the image the template predicts -- the lit template's pixel-area colour mixed
  with the background by each pixel's coverage in linear light (``--supersample`` sub-pixels per
  axis), the background the image's own beyond ``--ring`` px -- searched with the image's own edge
  operator (``refine.contour_match.synthetic_image`` / ``synthetic_contour_offsets``).

A prediction that holds the image's contour leaves s, b and the rest near 0; a shift that persists
over views turns the object (sessions 86-88). Groups where a prediction finds no edge for a sample
lose that sample in that prediction only.

    python bench/bench_contour_synthetic.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \\
        --scenes 1,2 --frames 0,25,50,75,100,125,150,175 --supersample 2 --out /tmp/contour_synthetic
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

PREDICTIONS = ("binary", "lit 1-D", "synthetic 2-D")


def view_fits(vr, img: np.ndarray, oids: list[int], sigma_px: float, ring_px: float, min_samples: int,
              psf_sigma_px: float = 0.0, pixel_filter: str = "box") -> dict:
    """{(prediction, obj_id): (s_u, s_v, b, rest)} of one GT view (see the module docstring)."""
    from bench_contour_offsets import shift_fit

    from ycbvss.refine.contour_match import rim_colour, synthetic_contour_offsets, synthetic_image
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.shading import lit_template
    from ycbvss.refine.templates import area_template, view_edge_candidates

    fld = edge_field(img, sigma_px, colour=True)
    area = area_template(vr)
    lit_point = lit_template(vr.color, vr.normal, vr.instance, img)
    c_lit = view_edge_candidates(vr, blur_sigma_px=sigma_px, normals=True, image=img, appearance_color=lit_point,
                                 appearance_pixel_filter=pixel_filter)
    c_bin = view_edge_candidates(vr, blur_sigma_px=sigma_px, normals=True)
    if area:
        colour = rim_colour(vr.instance, vr.coverage, vr.area_color,
                            lit_template(vr.area_color, vr.normal, vr.instance, img))
    else:
        colour = lit_point
    syn = synthetic_image(vr.instance, vr.coverage if area else None, colour, img, ring_px, psf_sigma_px)
    out = {}
    for lab0, oid in enumerate(oids):
        sb = np.flatnonzero((c_bin.l_c == lab0 + 1) & np.any(c_bin.n_c != 0.0, axis=1))
        sl = np.flatnonzero((c_lit.l_c == lab0 + 1) & np.any(c_lit.n_c != 0.0, axis=1))
        uv, n = c_bin.uv_c[sb], c_bin.n_c[sb]
        t = synthetic_contour_offsets(uv, n, syn, sigma_px)
        ok = np.isfinite(t)
        for name, p, nn in (("binary", uv, n), ("lit 1-D", c_lit.uv_c[sl], c_lit.n_c[sl]),
                            ("synthetic 2-D", uv[ok] + t[ok, None] * n[ok], n[ok])):
            f = shift_fit(fld, p, nn, min_samples)
            if f is not None:
                out[(name, oid)] = f
    return out


def summary(v: np.ndarray) -> list[float]:
    """[groups, rms |s|, mean b, rms b, median rest] of fits v (G, 4)."""
    return [float(len(v)), float(np.sqrt(np.mean(v[:, 0] ** 2 + v[:, 1] ** 2))), float(v[:, 2].mean()),
            float(np.sqrt(np.mean(v[:, 2] ** 2))), float(np.median(v[:, 3]))]


def main() -> None:
    from bench_contour_offsets import add_view_args, gt_views   # this folder (run as a script)

    from ycbvss.eval.tables import Row, Table, write_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_view_args(ap)
    ap.add_argument("--sigma-px", type=float, default=1.0)
    ap.add_argument("--ring", type=float, default=2.5, help="px beside the silhouettes where the background is carried in")
    ap.add_argument("--min-samples", type=int, default=40)
    ap.add_argument("--psf", type=float, default=0.0, help="camera blur (px, Gaussian sigma in linear light) added "
                                                            "to the synthetic image")
    ap.add_argument("--pixel-filter", default="box", help="the lit 1-D prediction's pixel footprint "
                                                           "(RefineOptions.edge_pixel_filter)")
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    fits: dict = {}
    names: dict = {}
    for models, sid, _, img, vr, oids in gt_views(a):
        for (name, oid), f in view_fits(vr, img, oids, a.sigma_px, a.ring, a.min_samples, a.psf,
                                               a.pixel_filter).items():
            fits.setdefault(name, []).append(f)
            fits.setdefault((name, oid), []).append(f)
            names[oid] = getattr(models[oid], "name", None) or str(oid)
    cols = ["groups", "|s| rms (px)", "b mean (px)", "b rms (px)", "rest median (px)"]
    t = Table(cols, label_header="prediction", digits=3,
              caption=f"Contour at the exact GT against three predictions: shared shift s, dilation b and per-sample rest "
                      f"(scenes {a.scenes}, frame positions {a.frames}, blur {a.sigma_px} px, template "
                      f"{a.supersample} x {a.supersample} sub-pixels, camera blur {a.psf} px, lit 1-D pixel filter "
                      f"{a.pixel_filter})")
    for name in PREDICTIONS:
        if fits.get(name):
            t.rows.append(Row(name, summary(np.array(fits[name]))))
            print(f"{name:14s} " + "  ".join(f"{c} {x:.3f}" for c, x in zip(cols, t.rows[-1].values)))
    o_cols = [f"{p} {c}" for p in ("lit 1-D", "synthetic 2-D") for c in ("s_u", "s_v", "b")]
    ot = Table(o_cols, label_header="object", digits=3,
               caption="Per object, the mean over its views of the shift s (u, v) and dilation b (px): the refiner's "
                       "lit 1-D prediction and the synthetic 2-D one")
    for oid in sorted(names):
        vals = []
        for p in ("lit 1-D", "synthetic 2-D"):
            v = np.array(fits.get((p, oid), [[np.nan] * 4]))
            vals += [float(v[:, 0].mean()), float(v[:, 1].mean()), float(v[:, 2].mean())]
        ot.rows.append(Row(names[oid], vals))
    for p in write_table(t, Path(a.out), "contour_synthetic") + write_table(ot, Path(a.out), "contour_synthetic_objects"):
        print(p)


if __name__ == "__main__":
    main()
