"""Damped Newton / Levenberg-Marquardt on se(3) increments with sparse normal equations.

The normal matrix is assembled block-wise (6x6 blocks, one per free camera/object) into a
``scipy.sparse`` matrix and solved with a sparse LU. A step that does not lower the total cost
is rejected (the state is restored and the damping raised), so the cost never increases and no
NaN can enter the poses. Uncertainty: covariance = s^2 H^-1 with H the final (undamped) normal
matrix and s^2 = 2 f / max(N_obs - N_params, 1) (the residual variance of a least-squares cost
f = sum r^2 whose Hessian is 2 J^T J); an annotation-confidence indicator, not a calibrated one.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .problem import BundleProblem
from .terms import Linearization


@dataclass
class SolverOptions:
    max_iters: int = 10
    lambda0: float = 1e-3
    lambda_max: float = 1e8
    max_tries: int = 8
    rel_tol: float = 1e-7        # stop when the relative cost decrease is below this
    step_tol: float = 1e-7       # stop when |delta| (mm / rad mix) is below this
    lambda_restart: float = 1e-2  # cap on the damping a new call starts with
    max_extrapolate: int = 3     # after an accepted step, try up to this many doublings of it (cost only)


def assemble(n_blocks: int, lins: list[Linearization]) -> tuple[sp.csr_matrix, np.ndarray]:
    """Sparse normal matrix H (6B x 6B) and gradient g (6B,) from linearisations."""
    blocks: dict[tuple[int, int], np.ndarray] = {}
    g = np.zeros(6 * n_blocks)

    def add(p, q, M):
        if p < 0 or q < 0:
            return
        if (p, q) in blocks:
            blocks[(p, q)] += M
        else:
            blocks[(p, q)] = M.copy()

    for L in lins:
        AJa = L.A @ L.Ja                     # (N, 2, 6)
        AJb = L.A @ L.Jb
        Haa = np.einsum("nki,nkj->ij", L.Ja, AJa)
        Hbb = np.einsum("nki,nkj->ij", L.Jb, AJb)
        Hab = np.einsum("nki,nkj->ij", L.Ja, AJb)
        add(L.a, L.a, Haa)
        add(L.b, L.b, Hbb)
        if L.a >= 0 and L.b >= 0:
            if L.a == L.b:
                add(L.a, L.a, Hab + Hab.T)
            else:
                add(L.a, L.b, Hab)
                add(L.b, L.a, Hab.T)
        if L.a >= 0:
            g[6 * L.a:6 * L.a + 6] += np.einsum("nki,nk->i", L.Ja, L.g)
        if L.b >= 0:
            g[6 * L.b:6 * L.b + 6] += np.einsum("nki,nk->i", L.Jb, L.g)
    rows, cols, vals = [], [], []
    ii, jj = np.meshgrid(np.arange(6), np.arange(6), indexing="ij")
    for (p, q), M in blocks.items():
        rows.append((6 * p + ii).ravel())
        cols.append((6 * q + jj).ravel())
        vals.append(M.ravel())
    N = 6 * n_blocks
    if rows:
        H = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(N, N))
    else:
        H = sp.csr_matrix((N, N))
    return H, g


def damped_solve(H: sp.csr_matrix, g: np.ndarray, lam: float) -> np.ndarray:
    """Solve (H + lam * (diag(H) + eps)) delta = -g; returns zeros if singular."""
    d = H.diagonal()
    eps = 1e-9 * max(float(d.max()) if d.size else 1.0, 1e-12) + 1e-12
    D = sp.diags(lam * (d + eps) + eps)
    try:
        delta = spla.spsolve((H + D).tocsc(), -g)
    except Exception:   # noqa: BLE001 - singular system: no step
        return np.zeros_like(g)
    delta = np.asarray(delta, dtype=np.float64)
    if not np.all(np.isfinite(delta)):
        return np.zeros_like(g)
    return delta


def total_cost(pb: BundleProblem, terms) -> tuple[float, dict]:
    per = {t.name: t.cost(pb) for t in terms}
    return float(sum(per.values())), per


def linearize_all(pb: BundleProblem, terms) -> tuple[float, dict, list[Linearization]]:
    lins, per = [], {}
    for t in terms:
        c, L = t.linearize(pb)
        per[t.name] = c
        lins += L
    return float(sum(per.values())), per, lins


def _extrapolate(pb: BundleProblem, terms, delta: np.ndarray, c0: float, c1: float, per1: dict, n_max: int,
                 min_gain: float = 0.5) -> tuple[float, dict, np.ndarray]:
    """Line search beyond an accepted step (cost c0 -> c1): apply the step again (doubling the
    total each time, up to ``n_max`` times) while each extension lowers the cost by at least
    ``min_gain`` times what the first step gained. The surrogate curvatures of the edge term
    (PSD-projected, floored) and of the IRLS point terms overestimate the true curvature, so
    accepted steps are often a fraction of the way to the minimum; then every extension gains
    about as much as the first step. Along a nearly flat direction (depth in a single view)
    the extensions gain little and are refused, so noise is not amplified into drift. Costs
    cost evaluations only."""
    total = delta.copy()
    step = delta.copy()
    gain0 = c0 - c1
    for _ in range(max(n_max, 0)):
        st = pb.state()
        pb.apply_step(step)
        c2, per2 = total_cost(pb, terms)
        if not (np.isfinite(c2) and c1 - c2 >= min_gain * gain0 and np.all(np.isfinite(pb.T_c))
                and np.all(np.isfinite(pb.T_m))):
            pb.set_state(st)
            break
        total += step
        c1, per1 = c2, per2
        step = 2.0 * step
    return c1, per1, total


def run_lm(pb: BundleProblem, terms, opt: SolverOptions, log: list | None = None, stage: str = "",
           lam: float | None = None) -> tuple[bool, float]:
    """Run damped Newton iterations on ``pb`` in place. Returns (converged, final lambda)."""
    # a damping carried over from an earlier call is capped: the terms were re-sampled since
    lam = opt.lambda0 if lam is None else min(lam, opt.lambda_restart)
    converged = False
    if pb.n_blocks == 0:
        return True, lam
    for it in range(opt.max_iters):
        t0 = time.perf_counter()
        c0, per0, lins = linearize_all(pb, terms)
        H, g = assemble(pb.n_blocks, lins)
        st = pb.state()
        accepted = False
        for _ in range(opt.max_tries):
            delta = damped_solve(H, g, lam)
            pb.apply_step(delta)
            c1, per1 = total_cost(pb, terms)
            if np.isfinite(c1) and c1 < c0 and np.all(np.isfinite(pb.T_c)) and np.all(np.isfinite(pb.T_m)):
                accepted = True
                lam = max(lam / 3.0, 1e-7)
                c1, per1, delta = _extrapolate(pb, terms, delta, c0, c1, per1, opt.max_extrapolate)
                break
            pb.set_state(st)
            lam = min(lam * 4.0, opt.lambda_max)
        step = float(np.linalg.norm(delta)) if accepted else 0.0
        if log is not None:
            log.append({"stage": stage, "iter": it, "cost": c1 if accepted else c0,
                        "cost_terms": per1 if accepted else per0, "cost_before": c0, "step": step,
                        "lambda": lam, "accepted": accepted, "time_s": time.perf_counter() - t0})
        if not accepted:
            converged = lam >= opt.lambda_max or converged
            break
        if (c0 - c1) <= opt.rel_tol * max(abs(c0), 1e-12) or step < opt.step_tol:
            converged = True
            break
    return converged, lam


def covariance(pb: BundleProblem, terms, max_dense: int = 3000) -> np.ndarray | None:
    """Covariance (6B x 6B) of the free blocks at the current state (see module doc), or None."""
    if pb.n_blocks == 0 or pb.n_params > max_dense:
        return None
    f, _, lins = linearize_all(pb, terms)
    H, _ = assemble(pb.n_blocks, lins)
    Hd = H.toarray()
    Hd = 0.5 * (Hd + Hd.T)
    n_obs = sum(t.n_obs() for t in terms)
    s2 = 2.0 * f / max(n_obs - pb.n_params, 1)
    try:
        Hinv = np.linalg.pinv(Hd, rcond=1e-12, hermitian=True)
    except np.linalg.LinAlgError:
        return None
    return s2 * Hinv
