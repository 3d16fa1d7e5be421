"""Does each refined object rest on something? (a status check, :mod:`ycbvss.refine.confidence`)

The objects of YCB-V (and of YCBV-SS, and of the suite) are at rest under gravity: each one stands
on the table or lies on, or leans against, another object. A refined pose in which an object floats
-- its lowest point clear of the table and its whole surface clear of every other object -- is
therefore wrong, however well its visible part fits the images. This matters where little of the
object is seen: on the sealed ``ycbv21-long3`` medium-65 (seed 1, session 83) the potted meat can,
3-19 % visible behind the master chef can, ended 10.2 mm too near -- lifted 5.6 mm off the table
(``unsupported_mm`` 6.3 mm) and 7.2 mm from every other object -- in all 30 views, its visible slivers fitting the image edges to
0.14 px, its covariance sigma_add 1.8 mm, and was reported ``converged``.

Measured here, per object, at the final poses (world frame, mm):

- ``height_mm``: the height of its lowest convex-hull vertex above the table plane of the objects'
  poses (:func:`table_plane`: the hull facet seen from above by every camera that the most hull
  vertices touch; :func:`ycbvss.refine.table.support_plane`, which counts objects touching faces
  of the union's hull, can take a facet tilted between a lifted object's corner and two others'
  for the table, and one object refined into the table tilts every facet of that hull);
- ``gap_mm``: the smallest distance from its surface samples to another object's nearest surface
  sample (Euclidean, so it reads up to half the sample spacing, about 1 mm, above the true gap);
- ``unsupported_mm`` = min(height, gap): how far it is from touching anything. NaN when the plane is
  not defined (fewer than ``MIN_OBJECTS`` objects, fewer than two touching it, a degenerate hull).
"""
from __future__ import annotations

import numpy as np

from scipy.spatial import ConvexHull, QhullError

from .table import ABOVE_MM, TOUCH_MM

# The table plane needs at least MIN_TOUCHING objects touching it: with fewer, one of them lifted, a
# facet tilted between their bottoms can touch as many vertices as the table's face.
MIN_TOUCHING = 3
MIN_OBJECTS = MIN_TOUCHING


def _hull_planes(P: np.ndarray) -> np.ndarray:
    """(F, 4) the distinct facet planes (outward n_out, off: n_out . x + off = 0) of the convex hull of
    the points ``P`` (N, 3); empty when the hull is degenerate."""
    try:
        eq = ConvexHull(P).equations
    except (QhullError, ValueError):
        return np.zeros((0, 4))
    return np.unique(np.round(eq, 6), axis=0)


def table_plane(points_w: list[np.ndarray], cam_centres_w: np.ndarray, touch_mm: float = TOUCH_MM,
                above_mm: float = ABOVE_MM, chunk: int = 512) -> tuple[np.ndarray, float, int] | None:
    """The plane the objects (hull vertices ``points_w``, one (N_j, 3) array each, world, mm) rest
    on. Candidates: the facets of each object's convex hull and of the hull of all their points with
    every camera (``cam_centres_w`` (M, 3)) at least ``above_mm`` above; the one with the most
    vertices within ``touch_mm`` of it, on either side, wins. Vertices, not objects: an object
    standing on the table touches it with a face, an edge or a rim (many vertices), while a facet
    tilted between single corners of three objects touches each with one. Either side, and each
    object's own facets: an object refined a few mm into the table is no longer above the table's
    plane, which is then not a facet of the union's hull (the facets left tilt towards it), but it
    is still a facet of each object standing on it. The plane is then set to the median of the
    lowest points of the objects touching it. Returns (unit normal n towards the cameras, offset d
    with n . X = d, objects touching) or None."""
    pts = np.concatenate([np.asarray(p, np.float64) for p in points_w])
    owner = np.concatenate([np.full(len(p), j) for j, p in enumerate(points_w)])
    planes = np.concatenate([_hull_planes(np.asarray(p, np.float64)) for p in points_w] + [_hull_planes(pts)])
    if not len(planes):
        return None
    n, d = -planes[:, :3], planes[:, 3]                 # n . x = d, n pointing out of the facet's solid's far side
    C = np.asarray(cam_centres_w, np.float64).reshape(-1, 3)
    up = np.all(C @ n.T - d >= above_mm, axis=0)
    n, d = n[up], d[up]
    if not len(n):
        return None
    counts = np.empty(len(n), int)
    for s0 in range(0, len(n), chunk):
        H = pts @ n[s0:s0 + chunk].T - d[s0:s0 + chunk]
        counts[s0:s0 + chunk] = (np.abs(H) <= touch_mm).sum(axis=0)
    k = int(np.argmax(counts))
    nk = n[k] / np.linalg.norm(n[k])
    h = pts @ nk - d[k] / np.linalg.norm(n[k])
    touching = np.unique(owner[np.abs(h) <= touch_mm])
    # every plane within the band counts the same vertices: the table lies at the median of the
    # touching objects' lowest points (one object lifted or sunk does not move it)
    lowest = np.array([h[owner == j].min() for j in touching])
    return nk, float(d[k] / np.linalg.norm(n[k]) + np.median(lowest)), len(touching)


def nearest_gap_mm(T_m: np.ndarray, surfaces: list, j: int, others: list[int], points: np.ndarray | None = None,
                   reach_mm: float = float("inf")) -> float:
    """Smallest Euclidean distance (mm) from object j's surface points (``points``, model frame; default
    ``surfaces[j].points``) placed by ``T_m[j]`` (model to world) to the nearest surface sample of
    any object in ``others`` (:class:`ycbvss.refine.contact.ContactSurface` ``surfaces[k]``); inf
    when none is nearer than ``reach_mm``. Exact below ``reach_mm``: the objects are visited nearest
    bounding sphere first, and an object, a point or a KD-tree branch that cannot beat the distance
    found so far is skipped."""
    R, t = T_m[j][:3, :3], T_m[j][:3, 3]
    W = (surfaces[j].points if points is None else points) @ R.T + t
    cj = R @ surfaces[j].centre + t
    cands = []
    for k in others:
        if k == j:
            continue
        ck = T_m[k][:3, :3] @ surfaces[k].centre + T_m[k][:3, 3]
        cands.append((float(np.linalg.norm(cj - ck)) - surfaces[j].radius_mm - surfaces[k].radius_mm, k, ck))
    cands.sort(key=lambda c: c[0])
    best = float(reach_mm)
    if cands and len(W) > 256:
        # an upper bound first, from every 16th point against the nearest sphere's object: the full
        # queries below then stop at it in the KD-tree (the result is the same)
        _, k, _ = cands[0]
        d, _ = surfaces[k].tree.query((W[::16] - T_m[k][:3, 3]) @ T_m[k][:3, :3], k=1, distance_upper_bound=best)
        best = min(best, float(np.min(d)))
    for centre_gap, k, ck in cands:
        if centre_gap >= best:
            break
        near = W[np.linalg.norm(W - ck, axis=1) < surfaces[k].radius_mm + best]
        if not len(near):
            continue
        d, _ = surfaces[k].tree.query((near - T_m[k][:3, 3]) @ T_m[k][:3, :3], k=1, distance_upper_bound=best)
        best = min(best, float(np.min(d)))
    return best if best < reach_mm else float("inf")


def unsupported_mm(T_m: np.ndarray, hull_points: list, surfaces: list, cam_centres_w: np.ndarray,
                   objects: list[int]) -> dict[int, dict]:
    """Per object index in ``objects`` (poses ``T_m`` (J, 4, 4), model to world, mm; hull vertices
    ``hull_points[j]`` and :class:`ycbvss.refine.contact.ContactSurface` ``surfaces[j]`` in the model
    frame; camera centres (M, 3) in the world): {"height_mm", "gap_mm", "unsupported_mm"} (module
    docstring); NaN where the support plane is not defined."""
    nan = {"height_mm": float("nan"), "gap_mm": float("nan"), "unsupported_mm": float("nan")}
    out = {j: dict(nan) for j in objects}
    objs = [j for j in objects if np.all(np.isfinite(T_m[j]))]
    if len(objs) < MIN_OBJECTS:
        return out
    pts = [hull_points[j] @ T_m[j][:3, :3].T + T_m[j][:3, 3] for j in objs]
    plane = table_plane(pts, cam_centres_w)
    if plane is None or plane[2] < MIN_TOUCHING:
        return out
    n, d, _ = plane
    for j, P in zip(objs, pts):
        h = float(np.min(P @ n) - d)
        g = nearest_gap_mm(T_m, surfaces, j, objs)
        out[j] = {"height_mm": h, "gap_mm": g, "unsupported_mm": float(min(h, g))}
    return out
