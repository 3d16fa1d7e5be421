"""The static table under the objects as a cue to the cameras' relative rotations
(``RefineOptions.table_flow``).

With free cameras and a 20-degree viewing baseline the objects alone fix the turn of the camera
path only weakly: a path turned a little less with a deeper scene (the bas-relief ambiguity)
explains their images almost as well, and the objects' small apparent-size biases pick a point
along it (suite medium-1 from the exact GT: every object recedes, up to 2.3 mm). YCB-V's objects
stand on a table that fills the rest of the image. Its texture moves between two views by the
homography of a plane, H = R + t n^T in normalised coordinates, which gives the relative rotation R
whatever the scene's scale and depth relief.

- :func:`support_plane`: the plane the objects rest on, from their current poses (the face of the
  convex hull of all their points with every camera above it and the most objects touching it);
  it picks among the homography's decompositions.
- :func:`plane_depth_mm`: z-depth of pixels' rays on a plane in one view.
- :func:`table_matches`: Lucas-Kanade matches (OpenCV) of table corners clear of the objects,
  guided by the plane's homography under the current estimate (:func:`predicted_homography`).
- :func:`span_pairs`: long-range pairs (each view with the earliest view within a turn).
- :func:`table_rotation`: the homography's rotation with its covariance (RANSAC, decomposition,
  Gauss-Newton on (R, t, n)).
- :class:`TableRotationTerm`: the cameras' relative rotations held to those measurements, each by
  its own covariance (a chi-square cost, cameras only).

Lifting the table's corners onto a plane as extra f_t points (the plane from the objects' support,
or fitted to the matches) was tried first: it ties the cameras' translation to the plane's
distance, so the alternation freezes the world scale where it starts (session 44: from the paper's
initial error, medium-1's depth error 1.39 -> 2.95 mm). The rotation alone carries no scale.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.spatial import ConvexHull, QhullError

from ..geometry.so3 import exp_so3, hat, log_so3, rotation_angle_deg

TOUCH_MM = 2.0          # an object touches a plane when its lowest point lies within this (mm)
ABOVE_MM = 50.0         # every camera centre at least this far above the plane (mm)


def support_plane(points_w: list[np.ndarray], cam_centres_w: np.ndarray, touch_mm: float = TOUCH_MM,
                  above_mm: float = ABOVE_MM) -> tuple[np.ndarray, float, int] | None:
    """The plane the objects rest on, from their points in world coordinates (mm).

    ``points_w``: one (N_j, 3) array per object; ``cam_centres_w`` (M, 3): camera centres. Among
    the faces of the convex hull of all points, those with every camera at least ``above_mm``
    above them (the table is seen from above) are candidates; the one with the most objects
    within ``touch_mm`` of it wins (ties: the larger face). Returns (unit normal n pointing to the
    cameras, offset d, objects touching) with the plane n . X = d, or None (no candidate, or the
    hull is degenerate)."""
    pts = np.concatenate([np.asarray(p, np.float64) for p in points_w])
    owner = np.concatenate([np.full(len(p), j) for j, p in enumerate(points_w)])
    try:
        hull = ConvexHull(pts)
    except (QhullError, ValueError):
        return None
    C = np.asarray(cam_centres_w, np.float64).reshape(-1, 3)
    planes: dict = {}                         # coplanar facets share one plane: their areas add up
    for eq, simplex in zip(hull.equations, hull.simplices):
        key = tuple(np.round(eq, 6))
        tri = pts[simplex]
        area = 0.5 * float(np.linalg.norm(np.cross(tri[1] - tri[0], tri[2] - tri[0])))
        planes[key] = (eq, planes.get(key, (eq, 0.0))[1] + area)
    best = None
    for eq, area in planes.values():
        # inside the hull n_out . x + off <= 0, i.e. n . x >= d with n = -n_out, d = off
        n, d = -eq[:3], float(eq[3])
        if np.any(C @ n - d < above_mm):
            continue
        h = pts @ n - d                        # heights above the plane (>= 0 up to rounding)
        lowest = np.full(len(points_w), np.inf)
        np.minimum.at(lowest, owner, h)
        touching = int(np.sum(lowest <= touch_mm))
        score = (touching, area)
        if best is None or score > best[0]:
            best = (score, n.copy(), d, touching)
    if best is None:
        return None
    return best[1], best[2], best[3]


def plane_in_camera(n_w: np.ndarray, d_w: float, T_w2c: np.ndarray) -> tuple[np.ndarray, float]:
    """The plane n . X = d (world) in a camera's frame: (n_c, d_c) with n_c . X_c = d_c."""
    R, t = T_w2c[:3, :3], T_w2c[:3, 3]
    n_c = R @ n_w
    return n_c, float(d_w + n_c @ t)


def plane_depth_mm(K: np.ndarray, T_w2c: np.ndarray, n_w: np.ndarray, d_w: float,
                   uv: np.ndarray) -> np.ndarray:
    """z-depth (mm) where the rays of pixels ``uv`` (N, 2; integer coordinates at pixel centres)
    meet the plane n . X = d (world); 0 where they do not (parallel, or behind the camera)."""
    n_c, d_c = plane_in_camera(np.asarray(n_w, np.float64), d_w, T_w2c)
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    fx, fy, s, cx, cy = K[0, 0], K[1, 1], K[0, 1], K[0, 2], K[1, 2]
    y = (uv[:, 1] - cy) / fy
    x = (uv[:, 0] - cx - s * y) / fx
    den = n_c[0] * x + n_c[1] * y + n_c[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(np.abs(den) > 1e-12, d_c / den, 0.0)
    return np.where(np.isfinite(z) & (z > 0), z, 0.0)


def _gray(img: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(img, cv2.COLOR_RGB2GRAY) if img.ndim == 3 else img


def predicted_homography(K_k: np.ndarray, K_i: np.ndarray, T_k: np.ndarray, T_i: np.ndarray,
                         n_w: np.ndarray, d_w: float) -> np.ndarray:
    """Pixel homography (3, 3) that carries the plane n . X = d (world, mm) from view k into view i
    under the world-to-camera poses ``T_k``, ``T_i`` (4x4, mm): K_i (R_ik + t_ik n_k^T / d_k) K_k^-1
    with (n_k, d_k) the plane in camera k."""
    n_k, d_k = plane_in_camera(np.asarray(n_w, np.float64), d_w, T_k)
    R_ik = T_i[:3, :3] @ T_k[:3, :3].T
    t_ik = T_i[:3, 3] - R_ik @ T_k[:3, 3]
    return K_i @ (R_ik + np.outer(t_ik, n_k) / d_k) @ np.linalg.inv(K_k)


def table_matches(img_a: np.ndarray, img_b: np.ndarray, objects_a: np.ndarray, objects_b: np.ndarray | None,
                  n_points: int = 1000, clear_px: int = 10, border_px: int = 16, fb_px: float = 0.2,
                  H_pred: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Matches (xa (N, 2), xb (N, 2); pixel coordinates, integer at pixel centres) of corners of
    image a's background into image b: Shi-Tomasi corners at least ``clear_px`` from every object
    of ``objects_a`` (bool mask) and ``border_px`` from the border, tracked by pyramidal
    Lucas-Kanade (21 px window, 4 levels) and kept when the backward track returns within
    ``fb_px`` and, with ``objects_b``, the match lies ``clear_px`` clear of image b's objects.

    ``H_pred`` (3, 3; pixels of a to pixels of b, e.g. :func:`predicted_homography` of the current
    estimate): guided matching. Image b is first warped into a's frame by it (bicubic), so
    Lucas-Kanade tracks only what the prediction missed, without the plane's perspective change
    inside its window; the matches are carried back into b by ``H_pred``. Measured on the suite's
    medium-1 and -3 (exact-GT pairs with the prediction ~0.3 deg, 2 % in translation and 3 % in the
    plane's distance off): median residual 0.13-0.37 px -> 0.05 px; pairs 17 deg apart still match
    300-450 corners, where unguided Lucas-Kanade keeps 43-62 at 12 deg and 7-22 at 14-17 deg."""
    if H_pred is not None:
        a = _gray(img_a)
        Hh, Ww = a.shape
        Hp = np.asarray(H_pred, np.float64)
        inv = cv2.WARP_INVERSE_MAP
        b_w = cv2.warpPerspective(_gray(img_b), Hp, (Ww, Hh), flags=cv2.INTER_CUBIC | inv)
        outside = cv2.warpPerspective(np.ones((Hh, Ww), np.uint8), Hp, (Ww, Hh), flags=cv2.INTER_NEAREST | inv,
                                      borderValue=0) == 0
        ob_w = outside if objects_b is None else outside | (cv2.warpPerspective(
            objects_b.astype(np.uint8), Hp, (Ww, Hh), flags=cv2.INTER_NEAREST | inv, borderValue=1) > 0)
        xa, xw = table_matches(a, b_w, objects_a, ob_w, n_points, clear_px, border_px, fb_px)
        y = np.c_[xw, np.ones(len(xw))] @ Hp.T
        with np.errstate(divide="ignore", invalid="ignore"):
            xb = y[:, :2] / y[:, 2:]
        ok = np.all(np.isfinite(xb), axis=1) & (xb[:, 0] >= border_px) & (xb[:, 0] < Ww - border_px) \
            & (xb[:, 1] >= border_px) & (xb[:, 1] < Hh - border_px)
        return xa[ok], xb[ok]
    a, b = _gray(img_a), _gray(img_b)
    H, W = a.shape
    k = np.ones((2 * clear_px + 1, 2 * clear_px + 1), np.uint8)
    mask = (cv2.dilate(objects_a.astype(np.uint8), k) == 0).astype(np.uint8) * 255
    mask[:border_px], mask[-border_px:], mask[:, :border_px], mask[:, -border_px:] = 0, 0, 0, 0
    p = cv2.goodFeaturesToTrack(a, n_points, 0.01, 8, mask=mask, blockSize=7)
    if p is None:
        return np.zeros((0, 2)), np.zeros((0, 2))
    p = p.reshape(-1, 1, 2).astype(np.float32)
    lk = dict(winSize=(21, 21), maxLevel=3, criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 50, 1e-3))
    q, st, _ = cv2.calcOpticalFlowPyrLK(a, b, p, None, **lk)
    back, st2, _ = cv2.calcOpticalFlowPyrLK(b, a, q, None, **lk)
    ok = (st[:, 0] == 1) & (st2[:, 0] == 1) & (np.linalg.norm((back - p)[:, 0], axis=1) < fb_px)
    xa, xb = p[ok, 0].astype(np.float64), q[ok, 0].astype(np.float64)
    inside = (xb[:, 0] >= border_px) & (xb[:, 0] < W - border_px) & (xb[:, 1] >= border_px) & (xb[:, 1] < H - border_px)
    xa, xb = xa[inside], xb[inside]
    if objects_b is not None and len(xb):
        clear_b = cv2.dilate(objects_b.astype(np.uint8), k) == 0
        keep = clear_b[xb[:, 1].round().astype(int), xb[:, 0].round().astype(int)]
        xa, xb = xa[keep], xb[keep]
    return xa, xb


def span_pairs(R_w2c: np.ndarray, temporal: list[tuple[int, int]], max_deg: float) -> list[tuple[int, int]]:
    """Long-range pairs (k, i), k < i, for the table's rotation: each view i with the earliest view
    k whose camera is turned from i's by at most ``max_deg`` (``R_w2c`` (M, 3, 3), the current
    estimate), unless (k, i) or (i, k) is among the ``temporal`` pairs or k = i - 1. A rotation
    error of the homography is about the same whatever the pair's turn, so the far pair fixes the
    path's turn to a smaller fraction of it (the depth relief's share of the bas-relief ambiguity)."""
    have = {tuple(p) for p in temporal} | {(i, k) for (k, i) in temporal}
    out = []
    for i in range(len(R_w2c)):
        for k in range(i - 1):
            if rotation_angle_deg(R_w2c[i] @ R_w2c[k].T) <= max_deg:
                if (k, i) not in have:
                    out.append((k, i))
                break
    return out


def _orthobasis(n: np.ndarray) -> np.ndarray:
    """(3, 2): two unit vectors orthogonal to ``n`` and to each other."""
    a = np.array([1.0, 0, 0]) if abs(n[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(n, a)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(n, u)], axis=1)


def _homography_residuals(p: np.ndarray, R0: np.ndarray, n0: np.ndarray, B: np.ndarray,
                          a: np.ndarray, xd: np.ndarray, K_i: np.ndarray) -> np.ndarray:
    R = exp_so3(p[:3]) @ R0
    n = n0 + B @ p[6:8]
    n = n / np.linalg.norm(n)
    H = R + np.outer(p[3:6], n)
    y = a @ (K_i @ H).T
    return (xd - y[:, :2] / y[:, 2:]).ravel()


def table_rotation(xs: np.ndarray, xd: np.ndarray, K_k: np.ndarray, K_i: np.ndarray, R_guess: np.ndarray,
                   n_guess: np.ndarray | None = None, ransac_px: float = 1.0, min_inliers: int = 50,
                   iters: int = 5, with_normal: bool = False) -> tuple | None:
    """The relative rotation R_ik (camera k to camera i) that the table's homography between two
    views shows, with its covariance: a plane's homography in normalised coordinates is
    H = R + t n^T (t: the translation over the plane's distance), so R is measured without the
    scene's scale or depth relief.

    ``xs`` (N, 2) pixels of view k, ``xd`` their matches in view i. RANSAC (OpenCV,
    ``ransac_px``) keeps the matches of the dominant plane; of the decompositions of H the one
    nearest ``R_guess`` (and ``n_guess``, the plane normal in camera k, when given) is refined by
    Gauss-Newton on (rotation, t, n) against the inliers' pixel residuals. Returns (R (3, 3),
    covariance of its left rotation error (3, 3; rad^2, from the residuals' variance), inliers,
    median inlier residual px), or None when fewer than ``min_inliers`` matches fit a plane.
    ``with_normal``: also the plane's unit normal in camera k (sign as the decomposition gives it)
    and its covariance (3, 3; rank 2, in the plane's tangent), appended to the tuple."""
    if len(xs) < min_inliers:
        return None
    Hp, mask = cv2.findHomography(xs.astype(np.float32), xd.astype(np.float32), cv2.RANSAC, ransac_px)
    if Hp is None or mask is None or int(mask.sum()) < min_inliers:
        return None
    # the inliers again under the final (refined) homography: RANSAC's own set is that of its best
    # minimal sample, which misses good matches far from the sample's points
    y = np.c_[xs, np.ones(len(xs))] @ Hp.T
    with np.errstate(divide="ignore", invalid="ignore"):
        inl = np.linalg.norm(y[:, :2] / y[:, 2:] - xd, axis=1) < ransac_px
    if int(inl.sum()) < min_inliers:
        return None
    Hn = np.linalg.inv(K_i) @ Hp @ K_k
    if np.linalg.det(Hn) < 0:
        return None
    Hn /= np.linalg.svd(Hn, compute_uv=False)[1]
    _, Rs, ts, ns = cv2.decomposeHomographyMat(Hn, np.eye(3))

    def score(r, nn):
        s = np.radians(float(rotation_angle_deg(r @ R_guess.T)))
        if n_guess is not None:
            s += np.arccos(np.clip(abs(float(nn.ravel() @ n_guess)), -1.0, 1.0))
        return s
    best = min(range(len(Rs)), key=lambda j: score(Rs[j], ns[j]))
    R0, n0 = np.asarray(Rs[best], np.float64), np.asarray(ns[best], np.float64).ravel()
    t0 = np.asarray(ts[best], np.float64).ravel()
    if not (np.all(np.isfinite(n0)) and np.linalg.norm(n0) > 0.5):
        # no translation between the views: the homography is a pure rotation and OpenCV gives a zero
        # normal; the plane's parallax that the refinement below fits is not there (it would run on NaNs)
        return None
    B = _orthobasis(n0)
    a = np.c_[xs[inl], np.ones(int(inl.sum()))] @ np.linalg.inv(K_k).T
    b = xd[inl]
    p = np.r_[np.zeros(3), t0, np.zeros(2)]
    r = _homography_residuals(p, R0, n0, B, a, b, K_i)
    J = None
    for _ in range(iters):
        J = np.stack([(_homography_residuals(p + h, R0, n0, B, a, b, K_i) - r) / 1e-7
                      for h in 1e-7 * np.eye(8)], axis=1)
        try:
            step = -np.linalg.lstsq(J, r, rcond=None)[0]
        except np.linalg.LinAlgError:
            return None
        r_new = _homography_residuals(p + step, R0, n0, B, a, b, K_i)
        if r_new @ r_new >= r @ r:
            break
        p, r = p + step, r_new
    JtJ = J.T @ J
    dof = max(len(r) - 8, 1)
    try:
        cov = np.linalg.inv(JtJ) * float(r @ r) / dof
    except np.linalg.LinAlgError:
        return None
    R = exp_so3(p[:3]) @ R0
    med = float(np.median(np.hypot(r[0::2], r[1::2])))
    if not with_normal:
        return R, cov[:3, :3], int(inl.sum()), med
    n = n0 + B @ p[6:8]
    n /= np.linalg.norm(n)
    return R, cov[:3, :3], int(inl.sum()), med, n, B @ cov[6:8, 6:8] @ B.T


@dataclass
class TableRotation:
    """One measured relative rotation: cameras i and k (view indices), R_ik measured, and the
    whitening W (3, 3) with W^T W the inverse covariance of its left rotation error."""

    i: int
    k: int
    R_ik: np.ndarray
    W: np.ndarray


@dataclass
class TableRotationTerm:
    """weight * sum over pairs of |W log(R_i R_k^T R_meas^T)|^2: the cameras' relative rotations
    held to what the table's homographies measured (:func:`table_rotation`), each weighted by
    its own covariance. Cameras only; scale-free (a homography's rotation does not see the
    scene's scale)."""

    groups: list = field(default_factory=list)     # TableRotation per measured pair
    weight: float = 1.0
    name: str = "table"

    def n_obs(self) -> int:
        return 3 * len(self.groups)

    def _residual(self, pb, p: TableRotation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(whitened residual W phi, phi = log(R R_meas^T), R = R_i R_k^T) of one pair."""
        R = pb.T_c[p.i][:3, :3] @ pb.T_c[p.k][:3, :3].T
        phi = log_so3(R @ p.R_ik.T)
        return p.W @ phi, phi, R

    def cost(self, pb) -> float:
        return self.weight * float(sum(float(e @ e) for e in (self._residual(pb, p)[0] for p in self.groups)))

    def linearize(self, pb) -> tuple[float, list]:
        from .terms import Linearization
        total, out = 0.0, []
        for p in self.groups:
            e, phi, R = self._residual(pb, p)
            total += float(e @ e)
            Ji, Jk = np.zeros((3, 6)), np.zeros((3, 6))
            # left increments (v, w): R_i <- exp(w_i) R_i moves e by J_l^-1(e) w_i, R_k's by -J_l^-1(e) R w_k
            Jl = p.W @ _inv_left_jacobian(phi)
            Ji[:, 3:] = Jl
            Jk[:, 3:] = -Jl @ R
            pack = lambda J: np.stack([J[0:2], np.stack([J[2], np.zeros(6)])])   # 3 residuals as two 2-rows
            A = np.zeros((2, 2, 2))
            A[:, 0, 0] = A[:, 1, 1] = 2.0 * self.weight
            g = 2.0 * self.weight * np.array([[e[0], e[1]], [e[2], 0.0]])
            out.append(Linearization(int(pb.cam_block[p.i]), int(pb.cam_block[p.k]), pack(Ji), pack(Jk), A, g))
        return self.weight * total, out


def _inv_left_jacobian(phi: np.ndarray) -> np.ndarray:
    """Inverse left Jacobian of SO(3) at the rotation vector ``phi``: log(exp(d) exp(phi)) ~ phi + J^-1 d."""
    th = float(np.linalg.norm(phi))
    P = hat(phi)
    if th < 1e-8:
        return np.eye(3) - 0.5 * P
    return np.eye(3) - 0.5 * P + (1.0 / th ** 2 - (1 + np.cos(th)) / (2 * th * np.sin(th))) * (P @ P)


def whitening(cov: np.ndarray) -> np.ndarray | None:
    """W with W^T W = cov^-1 (Cholesky of the inverse), None when ``cov`` is not positive definite."""
    try:
        return np.linalg.cholesky(np.linalg.inv(cov)).T
    except np.linalg.LinAlgError:
        return None
