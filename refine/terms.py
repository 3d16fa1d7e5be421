"""Cost terms of the bundle refinement, each linearised to per-point pixel-space quantities.

Every term produces, for groups of points sharing the same two parameter blocks (a, b), the pixel
Jacobians Ja, Jb (N, 2, 6), the pixel-space Hessian A (N, 2, 2) and gradient g (N, 2) of its cost
w.r.t. the projected pixel; :mod:`ycbvss.refine.solver` turns them into normal equations. Costs are
evaluated with the same samples (model points, matches) for step acceptance.

- :class:`EdgeTerm`: f_edge = sum_X E_i(pi(P_ij X)) (E the edge field). Newton-type: gradient
  grad E, Hessian = Hessian of E projected to positive semi-definite (the Gauss-Newton J^T J of a
  residual E would vanish at the edge, where dE/du = 0).
- :class:`PointTerm`: f_point = sum ||x - pi(P_ij X)||^rho (rho = 0.25), IRLS weights
  w = rho * max(s, s_floor)^(rho - 2) (s the pixel error); matches beyond ``cap_px`` are outliers.
- :class:`TemporalTerm`: f_t = sum ||x - pi(T_c_i T_c_k^-1 Y_k)||^rho for camera-k points Y_k
  (back-projected through the rendered depth) matched to pixels x of view i; cameras only.
- :class:`DepthTerm`: sum min((z - z_obs)^2, cap^2) over model points' camera depths (mm), the
  scene-consistent initialisation's anchor for the depth the reprojection cost hardly sees. Its
  scalar residual takes row 0 of the two-row form (row 1 is zero).
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field

import numpy as np

from ..geometry.se3 import inv_T
from .contour_slide import apply_slide
from .cubic_kernel import anchored_edge_values, edge_cost_sum
from .normal_kernel import as_f64
from .edge import EdgeField, across_edge_directions, sample_E, sample_field
from .jacobians import MIN_Z_MM, _se3_jac, object_point_jacobians, project_jac, project_points, transfer_point_jacobians
from .problem import BundleProblem


@dataclass
class Linearization:
    a: int
    b: int
    Ja: np.ndarray
    Jb: np.ndarray
    A: np.ndarray
    g: np.ndarray


def psd2(H: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """Project symmetric 2x2 matrices (N, 2, 2) to PSD (eigenvalues clamped at ``floor``)."""
    if len(H) == 0:
        return H
    a, b, c = H[:, 0, 0], 0.5 * (H[:, 0, 1] + H[:, 1, 0]), H[:, 1, 1]
    m, r = 0.5 * (a + c), np.sqrt(0.25 * (a - c) ** 2 + b * b)
    l1, l2 = m + r, m - r                              # eigenvalues, l1 >= l2
    th = 0.5 * np.arctan2(2 * b, a - c)                # eigenvector of l1: (cos th, sin th), of l2: (-sin th, cos th)
    co, si = np.cos(th), np.sin(th)
    l1, l2 = np.maximum(l1, floor), np.maximum(l2, floor)
    # l1 e1 e1^T + l2 e2 e2^T entry by entry (the same products in the same order as the outer-product form)
    u1, u2, ns = l1 * co, l2 * -si, -si
    v1, v2 = l1 * si, l2 * co
    out = np.empty((len(H), 2, 2))
    out[:, 0, 0] = u1 * co + u2 * ns
    out[:, 0, 1] = u1 * si + u2 * co
    out[:, 1, 0] = v1 * co + v2 * ns
    out[:, 1, 1] = v1 * si + v2 * co
    return out


@dataclass
class EdgeGroup:
    i: int          # view index
    j: int          # object index
    X: np.ndarray   # (N, 3) model points (mm)
    N: np.ndarray | None = None   # (N, 2) outward image normals of the contour samples, zero rows for interior ones
    # (model-frame unit axis (3,), (N, 3) mm/rad) or None: the turn about that symmetry axis moves the
    # contour samples by less than rigidly (refine.contour_slide.slide_delta, applied to the Jacobians)
    slide: tuple | None = None


@dataclass
class EdgeTerm:
    """Edge alignment cost over groups of model edge points; one field per view."""

    fields: list[EdgeField]
    groups: list[EdgeGroup] = field(default_factory=list)
    weight: float = 1.0
    curv_floor: float = 0.0       # per-point curvature floor = curv_floor * |grad E| (bounds a point's step to ~1/curv_floor px)
    name: str = "edge"
    # contour-dilation nuisance (> 0: on): every group with normals N gets a shared outward offset b
    # (px) of its contour samples, minimised out of the cost with a quadratic prior whose curvature
    # is ``dilation_k`` times the mean curvature of one contour sample along its normal, i.e. the
    # contour's overall size is worth ``dilation_k`` samples, not all of them (see _best_dilation)
    dilation_k: float = 0.0
    # contour-shift nuisance (> 0: on): every group with normals N also gets a shared 2-D image shift s
    # (px) of its contour samples (those with a nonzero normal), minimised out the same way with a
    # prior worth ``shift_k`` samples (2 x 2: ``shift_k`` times the mean of one contour sample's pixel
    # Hessian). Why: at the exact GT the image edges of one (view, object)'s contour lie a shared shift
    # off the template's (rms 0.19 px, ycbv21 long-1 and long-2) besides a per-sample scatter of
    # 0.22 px: the lit side and the shadow side of an object lean differently. Counted as independent
    # per-sample errors, 280 samples would fix the contour's position to 0.013 px.
    shift_k: float = 0.0
    # True: each sample moves in E only across its edge. At every linearisation the sample's
    # direction n of E's largest curvature (across the edge) and its position uv0 are fixed; until
    # the next one its cost is E(uv0 + ((uv - uv0) . n) n), so its slope along the edge (where the
    # edge is stronger or weaker) exerts no pull: along an edge a sample's position is not observed
    # (the aperture problem), the edge's strength varies with the image's contrast there
    across_only: bool = False
    # (view index, object index) -> that object's own field in that view, instead of ``fields``'s
    # (the linear-light field of a black object, RefineOptions.edge_linear_dark)
    obj_fields: dict = field(default_factory=dict)
    _priors: dict = field(default_factory=dict, repr=False)
    _anchors: dict = field(default_factory=dict, repr=False)

    def n_obs(self) -> int:
        return int(sum(len(gr.X) for gr in self.groups))

    def field_of(self, gr: EdgeGroup) -> EdgeField:
        """The edge field group ``gr``'s samples are read in."""
        f = self.obj_fields.get((gr.i, gr.j))
        return self.fields[gr.i] if f is None else f

    def _eval(self, pb: BundleProblem, gr: EdgeGroup, jac: bool):
        K = pb.views[gr.i].K
        uv, Jc, Jo, valid = object_point_jacobians(K, pb.T_c[gr.i], pb.T_m[gr.j], gr.X)
        uv = np.where(valid[:, None], uv, -1e9)
        E, grad, H, inside = sample_field(self.field_of(gr), uv)
        ok = valid & inside
        E = np.where(ok, E, 1.0)
        return E, grad, H, ok, Jc, Jo, uv

    def _dilated(self, gr: EdgeGroup) -> bool:
        """The group has a contour nuisance (dilation and / or shift) to marginalise."""
        return (self.dilation_k > 0.0 or self.shift_k > 0.0) and gr.N is not None

    def _basis(self, N: np.ndarray) -> np.ndarray:
        """(n, 2, m) how each sample moves (px) per nuisance parameter: the dilation b along its
        outward normal N (n, 2) and / or the shift s = (s_u, s_v); interior samples (zero normal) do
        not move."""
        cols = []
        if self.dilation_k > 0.0:
            cols.append(N[:, :, None])
        if self.shift_k > 0.0:
            c = np.any(N != 0.0, axis=1).astype(float)
            cols.append(c[:, None, None] * np.eye(2)[None])
        return np.concatenate(cols, axis=2)

    def _surrogate(self, grad: np.ndarray, H: np.ndarray, scale: float) -> np.ndarray:
        """The per-point pixel Hessians (N, 2, 2) of the Newton step: Hessian of E projected to
        PSD plus the curvature floor, times ``scale``."""
        gn = np.sqrt(grad[:, 0] * grad[:, 0] + grad[:, 1] * grad[:, 1])
        A = psd2(H)
        fl = self.curv_floor * gn
        A[:, 0, 0] += fl
        A[:, 1, 1] += fl
        return A * scale

    def _dilation_prior(self, gi: int, grad: np.ndarray, H: np.ndarray, M: np.ndarray) -> np.ndarray:
        """Prior curvature (m, m) on the nuisance (unweighted cost units), block-diagonal: for the
        dilation ``dilation_k`` times the mean curvature of one contour sample along its normal, for
        the shift ``shift_k`` times the mean of one contour sample's pixel Hessian, at zero nuisance;
        fixed per group by :meth:`linearize` (the cost between two linearisations uses the same one)."""
        prior = self._priors.get(gi)
        if prior is None:
            A = self._surrogate(grad, H, 1.0)
            m = max(int(np.count_nonzero(np.any(M != 0.0, axis=(1, 2)))), 1)
            C = np.einsum("nia,nij,njb->ab", M, A, M) / m          # mean per-sample curvature of the nuisance
            prior = np.zeros_like(C)
            if self.dilation_k > 0.0:                                # the first column (see _basis)
                prior[0, 0] = self.dilation_k * C[0, 0]
            if self.shift_k > 0.0:
                prior[-2:, -2:] = self.shift_k * C[-2:, -2:]
            self._priors[gi] = prior
        return prior

    def _best_dilation(self, pb: BundleProblem, gi: int, gr: EdgeGroup, n_newton: int = 2, jac: bool = True):
        """The nuisance theta (m,) (px) minimising sum_k E(uv_k + M_k theta) + theta' P theta / 2 by
        ``n_newton`` Newton steps from 0 (a fraction of a pixel; E is smooth at its blur), and the
        field sampled at the moved samples: (theta, P, E, grad, H, ok, Jc, Jo) with ok the samples in
        the image at zero nuisance (``jac=False``: Jc, Jo are None)."""
        K = pb.views[gr.i].K
        if jac:
            uv, Jc, Jo, valid = object_point_jacobians(K, pb.T_c[gr.i], pb.T_m[gr.j], gr.X)
        else:
            (uv, valid), Jc, Jo = project_points(K, pb.T_c[gr.i] @ pb.T_m[gr.j], gr.X), None, None
        uv = np.where(valid[:, None], uv, -1e9)
        fld = self.field_of(gr)
        E, grad, H, inside = sample_field(fld, uv)
        ok = valid & inside
        M = self._basis(np.where(ok[:, None], gr.N, 0.0))
        prior = self._dilation_prior(gi, grad[ok], H[ok], M[ok])
        th = np.zeros(M.shape[2])
        if M.shape[2] == 1:
            for it in range(n_newton):
                A = self._surrogate(grad[ok], H[ok], 1.0)
                h = np.einsum("nia,nij,njb->ab", M[ok], A, M[ok]) + prior
                g = np.einsum("nia,ni->a", M[ok], grad[ok]) + prior @ th
                if h[0, 0] <= 1e-12:
                    break
                th = np.clip(th - g / h[0, 0], -2.0, 2.0)
                at = np.where(ok[:, None], uv + M[:, :, 0] * th[0], -1e9)
                if jac or it < n_newton - 1:
                    E, grad, H, _ = sample_field(fld, at)
                else:                        # the cost's last evaluation needs E only
                    E = sample_E(fld, at)
            E = np.where(ok, E, 1.0)
            return th, prior, E, grad, H, ok, Jc, Jo
        # several parameters (the shift): the surrogate's coupled steps can overshoot, so each step is
        # halved until the cost falls (at most 4 times), and the steps go on (at most 8 n_newton of
        # them) until one moves the nuisance by less than 1e-6 px
        c0 = float(np.where(ok, E, 1.0).sum())
        for it in range(8 * n_newton):
            A = self._surrogate(grad[ok], H[ok], 1.0)
            h = np.einsum("nia,nij,njb->ab", M[ok], A, M[ok]) + prior
            g = np.einsum("nia,ni->a", M[ok], grad[ok]) + prior @ th
            if np.linalg.eigvalsh(h)[0] <= 1e-12:
                break
            step = -np.linalg.solve(h, g)
            for _ in range(5):
                cand = np.clip(th + step, -2.0, 2.0)
                at = np.where(ok[:, None], uv + np.einsum("nia,a->ni", M, cand), -1e9)
                Ec = sample_E(fld, at)
                c = float(np.where(ok, Ec, 1.0).sum()) + 0.5 * float(cand @ prior @ cand)
                if c < c0:
                    break
                step = 0.5 * step
            else:
                break                      # no step lowers the cost: th stays
            moved = float(np.max(np.abs(cand - th)))
            th, c0 = cand, c
            if moved < 1e-6:
                break
            E, grad, H, _ = sample_field(fld, at)
        at = np.where(ok[:, None], uv + np.einsum("nia,a->ni", M, th), -1e9)
        E, grad, H, _ = sample_field(fld, at)
        E = np.where(ok, E, 1.0)
        return th, prior, E, grad, H, ok, Jc, Jo

    def _dilation_cost(self, pb: BundleProblem, gi: int, gr: EdgeGroup) -> float:
        """min over theta of sum_k E(uv_k + M_k theta) + theta' P theta / 2 (unweighted)."""
        th, prior, E, *_ = self._best_dilation(pb, gi, gr, jac=False)
        return float(E.sum()) + 0.5 * float(th @ prior @ th)

    def cost(self, pb: BundleProblem) -> float:
        tot = 0.0
        for gi, gr in enumerate(self.groups):
            f = self.field_of(gr)
            if self._dilated(gr):
                tot += self._dilation_cost(pb, gi, gr)
                continue
            if gi in self._anchors and f.interp == "cubic":     # compiled, the same values and sum
                uv0, n, ok0 = self._anchors[gi]
                T = pb.T_c[gr.i] @ pb.T_m[gr.j]
                Y = np.asarray(gr.X, dtype=np.float64) @ T[:3, :3].T + T[:3, 3]   # project_points' product
                H, W = f.shape
                tot += float(anchored_edge_values(f.E_padded, H, W, as_f64(pb.views[gr.i].K), Y, uv0, n, ok0,
                                                  MIN_Z_MM).sum())
                continue
            if gi in self._anchors:
                uv0, n, ok0 = self._anchors[gi]
                uv, valid = project_points(pb.views[gr.i].K, pb.T_c[gr.i] @ pb.T_m[gr.j], gr.X)
                at = uv0 + np.einsum("ni,ni->n", uv - uv0, n)[:, None] * n
                E = sample_E(f, np.where((valid & ok0)[:, None], at, -1e9))
                tot += float(np.where(valid & ok0, E, 1.0).sum())
                continue
            if f.interp != "cubic":
                uv, valid = project_points(pb.views[gr.i].K, pb.T_c[gr.i] @ pb.T_m[gr.j], gr.X)
                E = sample_E(f, np.where(valid[:, None], uv, -1e9))
                tot += float(np.where(valid, E, 1.0).sum())
                continue
            H, W = f.shape
            tot += edge_cost_sum(f.E_padded, H, W, as_f64(pb.views[gr.i].K),
                                 pb.T_c[gr.i] @ pb.T_m[gr.j], as_f64(gr.X), MIN_Z_MM)
        return self.weight * tot

    def linearize(self, pb: BundleProblem) -> tuple[float, list[Linearization]]:
        total, out = 0.0, []
        self._priors = {}          # re-measured at this linearisation point (b = 0)
        self._anchors = {}
        for gi, gr in enumerate(self.groups):
            across = None
            if self._dilated(gr):      # linearised where the nuisance rests (theta*), theta marginalised below
                bst, prior, E, grad, H, ok, Jc, Jo = self._best_dilation(pb, gi, gr)
                total += float(E.sum()) + 0.5 * float(bst @ prior @ bst)
            else:
                E, grad, H, ok, Jc, Jo, uv0 = self._eval(pb, gr, True)
                total += float(E.sum())
                if self.across_only:
                    across = across_edge_directions(H)
                    self._anchors[gi] = (uv0, across, ok)
            if not ok.any():
                continue
            nk = self._basis(gr.N[ok]) if self._dilated(gr) else None
            if not ok.all():       # (all valid is the common case: no copies then)
                grad, H, Jc, Jo = grad[ok], H[ok], Jc[ok], Jo[ok]
                across = across[ok] if across is not None else None
            if gr.slide is not None:
                axis, delta = gr.slide
                apply_slide(Jc, Jo, delta[ok], pb.T_c[gr.i][:3, :3], pb.T_m[gr.j][:3, :3], axis)
            if across is not None:     # the slope and curvature across the edge only: n^T surrogate n, along n
                gn = np.einsum("ni,ni->n", grad, across)
                grad = gn[:, None] * across
                curv = np.maximum(np.einsum("ni,nij,nj->n", across, H, across), 0.0) + self.curv_floor * np.abs(gn)
                A = (self.weight * curv)[:, None, None] * np.einsum("ni,nj->nij", across, across)
            else:
                A = self._surrogate(grad, H, self.weight)
            a, b = int(pb.cam_block[gr.i]), int(pb.obj_block[gr.j])
            out.append(Linearization(a, b, Jc, Jo, A, grad * self.weight))
            if nk is not None:
                out.extend(self._dilation_schur(gi, a, b, Jc, Jo, A, grad * self.weight, nk, bst))
        return self.weight * total, out

    def _dilation_schur(self, gi: int, a: int, b: int, Jc: np.ndarray, Jo: np.ndarray, A: np.ndarray,
                        g: np.ndarray, M: np.ndarray, theta: np.ndarray) -> list[Linearization]:
        """The contour nuisance theta (m,) marginalised out of one group's normal equations: with
        U = sum_k J_k^T A_k M_k (12, m), h = sum_k M_k^T A_k M_k + P and g_t = sum_k M_k^T g_k + P theta,
        the Schur complement adds -U h^-1 U^T to H and -U h^-1 g_t to the gradient. With h^-1 = L L^T
        (Cholesky) that is the sum over the columns l of L of rank-one terms, written as pseudo-points
        (two rows each) whose Jacobian rows are (U l)^T, pixel Hessian -1 and gradient -l . g_t (the
        total stays positive semi-definite: it is the Schur complement of a PSD system)."""
        if not np.any(M != 0.0):
            return []
        AM = np.einsum("nij,njb->nib", A, M)
        h = np.einsum("nia,nib->ab", M, AM) + self.weight * self._priors[gi]
        if np.linalg.eigvalsh(h)[0] <= 1e-12:
            return []
        L = np.linalg.cholesky(np.linalg.inv(h))
        U_c = np.einsum("nik,nib->kb", Jc, AM)
        U_o = np.einsum("nik,nib->kb", Jo, AM)
        g_t = np.einsum("nia,ni->a", M, g) + self.weight * self._priors[gi] @ theta
        m = M.shape[2]
        rows_c, rows_o, gp = (U_c @ L).T, (U_o @ L).T, -(L.T @ g_t)      # (m, 6), (m, 6), (m,)
        n_pts = (m + 1) // 2
        Ja, Jb = np.zeros((n_pts, 2, 6)), np.zeros((n_pts, 2, 6))
        Ap, gpp = np.zeros((n_pts, 2, 2)), np.zeros((n_pts, 2))
        for r in range(m):
            p, q = divmod(r, 2)
            Ja[p, q], Jb[p, q], Ap[p, q, q], gpp[p, q] = rows_c[r], rows_o[r], -1.0, gp[r]
        return [Linearization(a, b, Ja, Jb, Ap, gpp)]

    def mean_cost(self, pb: BundleProblem) -> float:
        n = self.n_obs()
        return self.cost(pb) / self.weight / n if n else float("nan")


def robust_cost_weights(r: np.ndarray, rho: float, floor_px: float, cap_px: float
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-match cost, IRLS weight and inlier mask for residual vectors r (N, 2), s = ||r||.

    Cost s^rho for floor <= s < cap, cap^rho beyond (outliers), and below the floor the quadratic
    that continues s^rho with the same value and slope at s = floor:
    floor^rho (1 - rho/2) + (rho/2) floor^(rho-2) s^2. So the cost is C1 everywhere (s^rho alone
    has a cusp at 0 where every step raises the cost of the matches that are already exact) and
    the IRLS weight w = rho max(s, floor)^(rho-2) gives its exact gradient -w r."""
    s = np.sqrt(r[:, 0] * r[:, 0] + r[:, 1] * r[:, 1])      # = np.linalg.norm(r, axis=1), bit for bit
    inl = s < cap_px
    c = np.minimum(s, cap_px) ** rho
    if floor_px > 0:
        lo = s < floor_px
        c = np.where(lo, floor_px ** rho * (1.0 - 0.5 * rho) + 0.5 * rho * floor_px ** (rho - 2.0) * s * s, c)
    with np.errstate(divide="ignore"):
        w = np.where(inl, rho * np.maximum(s, floor_px) ** (rho - 2.0), 0.0)
    return c, w, inl


@dataclass
class PointGroup:
    i: int
    j: int
    X: np.ndarray    # (N, 3) model points
    x: np.ndarray    # (N, 2) matched pixels in view i


@dataclass
class _RobustReprojectionTerm(ABC):
    """Shared robust (||r||^rho, IRLS) reprojection cost of matched pixels; subclasses say how a
    group's points project (``_project``) and which parameter blocks the Jacobians belong to
    (``_linear``). ``groups``: the subclass's group type; ``rho``, ``floor_px``, ``cap_px``: see
    :func:`robust_cost_weights`."""

    groups: list = field(default_factory=list)
    weight: float = 1.0
    rho: float = 0.25
    floor_px: float = 0.5
    cap_px: float = 30.0

    @abstractmethod
    def _project(self, pb: BundleProblem, gr) -> tuple[np.ndarray, np.ndarray]:
        """(uv (N, 2), valid (N,)) of the group's points at the current poses."""

    @abstractmethod
    def _linear(self, pb: BundleProblem, gr) -> tuple[np.ndarray, int, int, np.ndarray, np.ndarray, np.ndarray]:
        """(uv, block_a, block_b, J_a (N, 2, 6), J_b (N, 2, 6), valid) of the group."""

    def n_obs(self) -> int:
        """Number of scalar residuals (two per matched pixel ``gr.x``)."""
        return int(2 * sum(len(gr.x) for gr in self.groups))

    def cost(self, pb: BundleProblem) -> float:
        tot = 0.0
        for gr in self.groups:
            uv, valid = self._project(pb, gr)
            r = np.where(valid[:, None], gr.x - uv, 1e6)
            tot += robust_cost_weights(r, self.rho, self.floor_px, self.cap_px)[0].sum()
        return self.weight * float(tot)

    def _robust_linearization(self, x: np.ndarray, uv: np.ndarray, a: int, b: int, Ja: np.ndarray,
                              Jb: np.ndarray, valid: np.ndarray) -> tuple[float, Linearization | None, np.ndarray]:
        """One group's (unweighted cost, Linearization of its inlier rows or None, the rows kept) for
        matched pixels x projected to uv with Jacobians Ja, Jb of blocks a, b."""
        r = np.where(valid[:, None], x - uv, 1e6)
        c, w, inl = robust_cost_weights(r, self.rho, self.floor_px, self.cap_px)
        ok = inl & valid
        if not ok.any():
            return float(c.sum()), None, ok
        if not ok.all():
            w, r, Ja, Jb = w[ok], r[ok], Ja[ok], Jb[ok]
        ww = w * self.weight
        A = np.zeros((len(ww), 2, 2))
        A[:, 0, 0] = A[:, 1, 1] = ww
        return float(c.sum()), Linearization(a, b, Ja, Jb, A, -ww[:, None] * r), ok

    def linearize(self, pb: BundleProblem) -> tuple[float, list[Linearization]]:
        total, out = 0.0, []
        for gr in self.groups:
            uv, ba, bb, Ja, Jb, valid = self._linear(pb, gr)
            c, lin, _ = self._robust_linearization(gr.x, uv, ba, bb, Ja, Jb, valid)
            total += c
            if lin is not None:
                out.append(lin)
        return self.weight * total, out


@dataclass
class PointTerm(_RobustReprojectionTerm):
    """Robust 3D-2D reprojection cost (||.||^rho) of flow matches; ``groups``: PointGroups."""

    name: str = "point"

    def _project(self, pb: BundleProblem, gr: PointGroup):
        return project_points(pb.views[gr.i].K, pb.T_c[gr.i] @ pb.T_m[gr.j], gr.X)

    def _linear(self, pb: BundleProblem, gr: PointGroup):
        uv, Jc, Jo, valid = object_point_jacobians(pb.views[gr.i].K, pb.T_c[gr.i], pb.T_m[gr.j], gr.X)
        return uv, int(pb.cam_block[gr.i]), int(pb.obj_block[gr.j]), Jc, Jo, valid


@dataclass
class TemporalGroup:
    i: int           # view where x is observed
    k: int           # view whose camera frame holds Y_k
    Y_k: np.ndarray  # (N, 3) points in camera k (mm)
    x: np.ndarray    # (N, 2) matched pixels in view i


@dataclass
class TemporalTerm(_RobustReprojectionTerm):
    """Robust two-view transfer cost between neighbouring views (cameras only); ``groups``:
    TemporalGroups.

    ``scale_free``: each pair's points Y_k get a shared scale (1 + s) that is marginalised out (s at
    its best value in the cost, its Schur complement in the normal equations), so the pair holds the
    cameras' relative rotation and the direction of their translation but not the baseline's length
    against the points' depth. Why: Y_k is fixed at the depth the templates had when the matches were
    made, so a pair whose flow reads the parallax a little short (at the exact GT of held-out long-3 on
    the refiner's own images the residual flow's matches read the inter-frame displacement 0.03 %
    short) pulls the cameras together at every new set of matches, and the objects follow them nearer:
    the scene's scale creeps, held back only by the objects' apparent sizes."""

    name: str = "temporal"
    scale_free: bool = False

    def _scale_basis(self, pb: BundleProblem, gr: TemporalGroup, s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(uv (N, 2), d uv / d s (N, 2), valid (N,)) of the group's points scaled by (1 + s)."""
        T = pb.T_c[gr.i] @ inv_T(pb.T_c[gr.k])
        RY = gr.Y_k @ T[:3, :3].T
        uv, Ju, valid = project_jac(pb.views[gr.i].K, (1.0 + s) * RY + T[:3, 3])
        return uv, np.einsum("nij,nj->ni", Ju, RY), valid

    def _best_scale(self, pb: BundleProblem, gr: TemporalGroup) -> float:
        """The group's scale nuisance s minimising its robust cost (IRLS Gauss-Newton, at most 6 steps;
        0 where the pair has no parallax to fix it)."""
        s = 0.0
        for _ in range(6):
            uv, M, valid = self._scale_basis(pb, gr, s)
            r = np.where(valid[:, None], gr.x - uv, 1e6)
            _, w, inl = robust_cost_weights(r, self.rho, self.floor_px, self.cap_px)
            ok = inl & valid
            h = float((w[ok, None] * M[ok] * M[ok]).sum())
            if h <= 1e-12:
                return s
            ds = float((w[ok, None] * M[ok] * r[ok]).sum()) / h
            s += ds
            if abs(ds) < 1e-9:
                break
        return s

    def _project(self, pb: BundleProblem, gr: TemporalGroup):
        return project_points(pb.views[gr.i].K, pb.T_c[gr.i] @ inv_T(pb.T_c[gr.k]), gr.Y_k)

    def _linear(self, pb: BundleProblem, gr: TemporalGroup):
        uv, Ji, Jk, valid = transfer_point_jacobians(pb.views[gr.i].K, pb.T_c[gr.i], pb.T_c[gr.k], gr.Y_k)
        return uv, int(pb.cam_block[gr.i]), int(pb.cam_block[gr.k]), Ji, Jk, valid

    def cost(self, pb: BundleProblem) -> float:
        if not self.scale_free:
            return super().cost(pb)
        tot = 0.0
        for gr in self.groups:
            uv, _, valid = self._scale_basis(pb, gr, self._best_scale(pb, gr))
            r = np.where(valid[:, None], gr.x - uv, 1e6)
            tot += robust_cost_weights(r, self.rho, self.floor_px, self.cap_px)[0].sum()
        return self.weight * float(tot)

    def linearize(self, pb: BundleProblem) -> tuple[float, list[Linearization]]:
        if not self.scale_free:
            return super().linearize(pb)
        total, out = 0.0, []
        for gr in self.groups:
            s = self._best_scale(pb, gr)
            uv, Ja, Jb, valid = transfer_point_jacobians(pb.views[gr.i].K, pb.T_c[gr.i], pb.T_c[gr.k],
                                                         gr.Y_k * (1.0 + s))
            a, b = int(pb.cam_block[gr.i]), int(pb.cam_block[gr.k])
            c, lin, ok = self._robust_linearization(gr.x, uv, a, b, Ja, Jb, valid)
            total += c
            if lin is None:
                continue
            out.append(lin)
            # d uv / d s: camera i's translation columns of Ja (d uv / d Y_i) times R_ik Y_k
            R = (pb.T_c[gr.i] @ inv_T(pb.T_c[gr.k]))[:3, :3]
            M = np.einsum("nij,nj->ni", lin.Ja[:, :, :3], gr.Y_k[ok] @ R.T)
            ww, g = lin.A[:, 0, 0], lin.g
            h = float((ww[:, None] * M * M).sum())
            if h <= 1e-12:
                continue
            # s marginalised: the Schur complement -U h^-1 U^T, -U h^-1 g_s as one pseudo-point (one row
            # used) whose Jacobian row is U / sqrt(h), pixel Hessian -1 and gradient -g_s / sqrt(h)
            AM = ww[:, None] * M
            l = 1.0 / np.sqrt(h)
            Jpa, Jpb = np.zeros((1, 2, 6)), np.zeros((1, 2, 6))
            Jpa[0, 0] = np.einsum("nik,ni->k", lin.Ja, AM) * l
            Jpb[0, 0] = np.einsum("nik,ni->k", lin.Jb, AM) * l
            Ap = np.zeros((1, 2, 2))
            Ap[0, 0, 0] = -1.0
            gp = np.zeros((1, 2))
            gp[0, 0] = -float((M * g).sum()) * l
            out.append(Linearization(a, b, Jpa, Jpb, Ap, gp))
        return self.weight * total, out


@dataclass
class DepthGroup:
    i: int               # view index
    j: int               # object index
    X: np.ndarray        # (N, 3) model points (mm)
    z_mm: np.ndarray     # (N,) their observed depth in camera i (mm)


@dataclass
class DepthTerm:
    """Truncated quadratic on the camera-frame depth of model points: f = weight * sum
    min((z_obs - z)^2, cap_mm^2), z the depth of P_ij X (mm). Points off by more than ``cap_mm``
    are outliers (constant cost, no gradient)."""

    groups: list[DepthGroup] = field(default_factory=list)
    weight: float = 1.0
    cap_mm: float = 50.0
    name: str = "depth"

    def n_obs(self) -> int:
        return int(sum(len(gr.X) for gr in self.groups))

    def _residual(self, pb: BundleProblem, gr: DepthGroup) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(z_obs - z (N,), world points W (N, 3), camera points Y (N, 3))."""
        T_m, T_c = pb.T_m[gr.j], pb.T_c[gr.i]
        W = gr.X @ T_m[:3, :3].T + T_m[:3, 3]
        Y = W @ T_c[:3, :3].T + T_c[:3, 3]
        return gr.z_mm - Y[:, 2], W, Y

    def cost(self, pb: BundleProblem) -> float:
        tot = 0.0
        for gr in self.groups:
            r = self._residual(pb, gr)[0]
            tot += float(np.minimum(r * r, self.cap_mm ** 2).sum())
        return self.weight * tot

    def linearize(self, pb: BundleProblem) -> tuple[float, list[Linearization]]:
        total, out = 0.0, []
        for gr in self.groups:
            r, W, Y = self._residual(pb, gr)
            total += float(np.minimum(r * r, self.cap_mm ** 2).sum())
            ok = np.abs(r) < self.cap_mm
            if not ok.any():
                continue
            r, W, Y = r[ok], W[ok], Y[ok]
            n = len(r)
            Mc = np.zeros((n, 2, 3))
            Mc[:, 0, 2] = 1.0                                  # d z / d Y
            Mo = np.zeros((n, 2, 3))
            Mo[:, 0, :] = pb.T_c[gr.i][2, :3]                  # d z / d W = row 2 of R_c
            Jc = _se3_jac(Mc, Y, np.empty((n, 2, 6)))
            Jo = _se3_jac(Mo, W, np.empty((n, 2, 6)))
            A = np.zeros((n, 2, 2))
            A[:, 0, 0] = 2.0 * self.weight
            g = np.zeros((n, 2))
            g[:, 0] = -2.0 * self.weight * r                   # d f / d z
            out.append(Linearization(int(pb.cam_block[gr.i]), int(pb.obj_block[gr.j]), Jc, Jo, A, g))
        return self.weight * total, out
