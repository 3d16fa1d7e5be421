"""Where the image's edges lie at the exact GT in four edge spaces: is a specular-invariant space
free of the contour's shared shift?

A glossy dielectric's rim reflects the light's colour (white in the suite), and in linear light a
white addition (k, k, k) cancels in the opponent channels R - G and (R + G) / 2 - B. If the shared
per-(view, object) shift of the contour (sessions 86-87: about 0.19 px rms, kept from view to view
by each object, so the pose absorbs it) were that rim, an edge field on the opponent channels
would not show it. Per (view, object) of the chosen suite frames, the image edge's offsets from the
contour samples along their outward normals are fitted as ``t_k = n_k . s + b + r_k``
(``bench_contour_offsets.shift_fit``) in:

- ``A`` the refiner's medium and wide bundles: sRGB colour edges, the contour placed by the lit
  template's 1-D appearance prediction (``RefineOptions.edge_appearance``);
- ``B`` linear-light colour edges, the binary (geometric) contour;
- ``C`` linear-light opponent channels, the binary contour;
- ``D`` opponent channels with the lit appearance prediction made in that space (the prediction's
  sRGB encoding swapped for the opponent transform while the candidates are made);
- ``E`` linear-light colour edges with the lit appearance prediction made in linear light (the
  prediction's sRGB encoding swapped for the identity): ``A`` without the encoding on either side.

Printed: per space the rms of |s|, of b, the per-sample rest and, over objects seen in >= 3 views,
the rms of each object's mean shift (what its pose absorbs); per object that mean shift's length.
The images are the suite's Cycles renders, never the fast renderer's.

    python bench/bench_contour_spaces.py --suite-root /tmp/suite/full --dataset ../shared/data/ycbv \\
        --scenes 1 --frames 0,25,50,75,100,125,150,175
"""
from __future__ import annotations

import argparse
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contour_offsets import add_view_args, gt_views, mean_and_scatter, shift_fit, shift_stats  # noqa: E402

SPACES = "ABCDE"


def opponent(lin: np.ndarray) -> np.ndarray:
    """Linear-light RGB (..., 3) -> (R - G, (R + G) / 2 - B, 0): a white addition cancels."""
    return np.stack([lin[..., 0] - lin[..., 1], 0.5 * (lin[..., 0] + lin[..., 1]) - lin[..., 2],
                     np.zeros_like(lin[..., 0])], axis=-1)


def opponent_field(image: np.ndarray, sigma_px: float):
    """The edge field (``refine.edge``'s E = 1 - |grad| / max) of an sRGB image's opponent channels."""
    from ycbvss.refine.edge import _field_from_magnitude, gradient_magnitude, srgb_to_linear

    return _field_from_magnitude(gradient_magnitude(opponent(srgb_to_linear(image).astype(np.float32)), sigma_px),
                                 sigma_px)


@contextmanager
def prediction_space(transform):
    """Within this block ``refine.contour_match.appearance_offsets`` forms its 1-D profiles in another
    space: its final sRGB encoding of the linear-light profiles is swapped for ``transform`` (e.g.
    :func:`opponent`, or the identity for linear light). A bench-only swap."""
    import ycbvss.refine.contour_match as cm

    orig = cm.linear_to_srgb
    cm.linear_to_srgb = transform
    try:
        yield
    finally:
        cm.linear_to_srgb = orig


def main(argv=None) -> int:
    from ycbvss.refine.edge import edge_field
    from ycbvss.refine.shading import lit_template
    from ycbvss.refine.templates import view_edge_candidates

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_view_args(ap)
    ap.add_argument("--sigma-px", type=float, default=1.0)
    ap.add_argument("--min-samples", type=int, default=40)
    a = ap.parse_args(argv)
    per: dict = {k: {} for k in SPACES}
    names: dict = {}
    for models, _, _, img, vr, oids in gt_views(a):
        lit = lit_template(vr.color, vr.normal, vr.instance, img)
        c_lit = view_edge_candidates(vr, blur_sigma_px=a.sigma_px, normals=True, image=img, appearance_color=lit)
        c_bin = view_edge_candidates(vr, blur_sigma_px=a.sigma_px, normals=True)
        with prediction_space(opponent):
            c_opp = view_edge_candidates(vr, blur_sigma_px=a.sigma_px, normals=True, image=img, appearance_color=lit)
        with prediction_space(lambda p: p):
            c_lin = view_edge_candidates(vr, blur_sigma_px=a.sigma_px, normals=True, image=img, appearance_color=lit)
        opp = opponent_field(img, a.sigma_px)
        spaces = {"A": (edge_field(img, a.sigma_px, colour=True), c_lit),
                  "B": (edge_field(img, a.sigma_px, colour=True, linear=True), c_bin),
                  "C": (opp, c_bin), "D": (opp, c_opp),
                  "E": (edge_field(img, a.sigma_px, colour=True, linear=True), c_lin)}
        for lab0, oid in enumerate(oids):
            names[oid] = getattr(models[oid], "name", None) or str(oid)
            for k, (fld, c) in spaces.items():
                sel = np.flatnonzero((c.l_c == lab0 + 1) & np.any(c.n_c != 0.0, axis=1))
                f = shift_fit(fld, c.uv_c[sel], c.n_c[sel], a.min_samples)
                if f is not None:
                    per[k].setdefault(oid, []).append(f)
    print(f"{a.suite} scenes {a.scenes}, frame positions {a.frames}, sigma {a.sigma_px:g} px")
    print("space: groups, |s| rms, b rms, per-sample rest, k | objects in >= 3 views: rms of their mean shift "
          "(u / v), of the shifts about it (u / v) | mean b (px)")
    for k in SPACES:
        allv = np.array([x for v in per[k].values() for x in v])
        if not len(allv):
            print(k, "no groups")
            continue
        n, mr, ar = mean_and_scatter([np.asarray(v)[:, :2] for v in per[k].values()])
        print(k, " ".join(f"{x:.3f}" for x in shift_stats(allv)), f"| {n} {mr[0]:.3f} / {mr[1]:.3f}",
              f"{ar[0]:.3f} / {ar[1]:.3f} | {allv[:, 2].mean():+.3f}")
    print("per object, the length of its mean shift over its views (px), A / B / C / D / E, and its groups")
    for o in sorted(names):
        cells = []
        for k in SPACES:
            v = np.asarray(per[k].get(o, []))
            cells.append(f"{np.hypot(*v[:, :2].mean(axis=0)):.3f}" if len(v) >= 3 else "-")
        print(f"{o:3d} {names[o][:24]:24s}", " / ".join(cells), [len(per[k].get(o, [])) for k in SPACES])
    return 0


if __name__ == "__main__":
    sys.exit(main())
