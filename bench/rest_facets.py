"""How well does an object's resting face fix its tilt? The distinctness of the YCB-V models'
convex-hull rest facets.

An object standing on the table rests on a facet of its convex hull. A "resting-face" prior would
hold that facet's normal to the measured table normal (two rotation degrees of freedom per object
on top of ``table_contact``'s height). It can only be as sharp as the rest facet is distinct: if
other hull facets have normals within a fraction of a degree of it, the prior pulls to whichever
is nearest at the current estimate, and the short clips' targets are 0.3 deg (0.2 deg on long
clips). For each resting pose the suite's scene generator draws from (trimesh's quasi-static stable
poses of the convex hull, probability >= ``--min-prob``, at most ``--max-n``), this bench writes the number of hull faces that form the rest facet (normals
within 0.2 deg of the downward direction), the next distinct facet normal's angle (deg), the
rest facet's narrowest width (mm) and the number of hull faces within 5 deg, as Markdown and CSV.

    python bench/rest_facets.py --models ../shared/data/ycbv --out bench/results/ycbv21/rest_facets
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np
import trimesh

from ycbvss.io.atomic import atomic_path, write_text_atomic
from ycbvss.io.ycbv import load_ycbv_models
from ycbvss.procedural.ycbv_scene import rest_poses


def min_width_mm(points_mm: np.ndarray, normal: np.ndarray, n_dirs: int = 180) -> float:
    """Narrowest extent (mm) of ``points_mm`` (N, 3) projected on the plane of unit ``normal``,
    over ``n_dirs`` in-plane directions."""
    u = np.cross(normal, [1.0, 0.0, 0.0])
    if np.linalg.norm(u) < 0.1:
        u = np.cross(normal, [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    xy = np.c_[points_mm @ u, points_mm @ v]
    a = np.linspace(0.0, np.pi, n_dirs, endpoint=False)
    return float(np.min(np.ptp(xy @ np.stack([np.cos(a), np.sin(a)]), axis=0)))


def rest_facets(mesh: trimesh.Trimesh, min_prob: float, max_n: int, same_deg: float = 0.2) -> list[dict]:
    """One record per resting pose of ``mesh`` (mm) that the suite's scene generator draws from
    (:func:`ycbvss.procedural.ycbv_scene.rest_poses`)."""
    hull = mesh.convex_hull
    out = []
    for Ti, pi in rest_poses(mesh, min_prob=min_prob, max_n=max_n):
        down = Ti[:3, :3].T @ np.array([0.0, 0.0, -1.0])       # model frame
        ang = np.degrees(np.arccos(np.clip(hull.face_normals @ down, -1.0, 1.0)))
        rest = ang < same_deg
        verts = hull.vertices[np.unique(hull.faces[rest])] if rest.any() else hull.vertices[:0]
        out.append({"prob": round(float(pi), 3), "rest_faces": int(rest.sum()),
                    "next_facet_deg": round(float(ang[~rest].min()), 2),
                    "rest_width_mm": round(min_width_mm(verts, down), 1) if len(verts) else 0.0,
                    "faces_within_5deg": int(np.sum(ang < 5.0))})
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models", required=True, help="YCB-V root (original layout) with models/")
    ap.add_argument("--min-prob", type=float, default=0.08, help="as the suite's generator (rest_poses)")
    ap.add_argument("--max-n", type=int, default=3, help="poses per object, as the suite's generator")
    ap.add_argument("--out", required=True, help="output stem (writes .md and .csv)")
    a = ap.parse_args(argv)
    rows = []
    for oid, m in sorted(load_ycbv_models(a.models).items()):
        mesh = trimesh.Trimesh(np.asarray(m.vertices_mm, float), process=True)
        for r in rest_facets(mesh, a.min_prob, a.max_n):
            rows.append({"obj_id": oid, "object": m.name, **r})
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    keys = list(rows[0])
    md = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    md += ["| " + " | ".join(str(r[k]) for k in keys) + " |" for r in rows]
    nxt = np.array([r["next_facet_deg"] for r in rows])
    md += ["", f"{len(rows)} stable poses of {len({r['obj_id'] for r in rows})} objects; next distinct facet "
           f"normal: median {np.median(nxt):.2f} deg, {np.mean(nxt < 0.5):.0%} under 0.5 deg, "
           f"{np.mean(nxt < 1.0):.0%} under 1 deg"]
    write_text_atomic(out.with_suffix(".md"), "\n".join(md) + "\n")
    with atomic_path(out.with_suffix(".csv")) as tmp, open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, keys)
        w.writeheader()
        w.writerows(rows)
    print(md[-1])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
