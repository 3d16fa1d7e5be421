"""Appearance matching of a render to the real object: an affine colour transform in linear RGB
(3x3 matrix + offset, which also absorbs white balance / chromatic adaptation), fitted by
robust least squares, and CIEDE2000 between sRGB images (colour-science).
"""
from __future__ import annotations

import numpy as np


def srgb_to_linear(rgb01: np.ndarray) -> np.ndarray:
    """sRGB-encoded values in [0, 1] -> linear RGB (IEC 61966-2-1)."""
    # lazy: colour-science takes ~1.4 s to import
    import colour
    return np.asarray(colour.cctf_decoding(np.clip(rgb01, 0.0, 1.0), function="sRGB"), np.float32)


_U8_LUT = None


def srgb_u8_to_linear(rgb_u8: np.ndarray) -> np.ndarray:
    """uint8 sRGB -> linear float32 through a 256-entry table (same values as :func:`srgb_to_linear`)."""
    global _U8_LUT
    if _U8_LUT is None:
        _U8_LUT = srgb_to_linear(np.arange(256, dtype=np.float32) / 255.0).astype(np.float32)
    return _U8_LUT[np.asarray(rgb_u8, np.uint8)]


def linear_to_srgb(lin: np.ndarray) -> np.ndarray:
    """Linear RGB -> sRGB-encoded values in [0, 1] (clipped)."""
    # lazy: colour-science takes ~1.4 s to import
    import colour
    return np.asarray(colour.cctf_encoding(np.clip(lin, 0.0, 1.0), function="sRGB"), np.float32)


def fit_colour_transform(src_lin: np.ndarray, dst_lin: np.ndarray, iters: int = 2,
                         clip_sigma: float = 2.5, ridge: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    """Fit ``dst ~ M @ src + b`` on (N, 3) linear RGB samples; returns (M (3, 3), b (3,)).

    Least squares with a small ridge towards the identity, then ``iters`` re-fits without samples whose
    residual norm exceeds ``clip_sigma`` times the RMS (specularities, misaligned texture, label errors).
    Fewer than 12 samples: the identity.
    """
    src = np.asarray(src_lin, np.float64).reshape(-1, 3)
    dst = np.asarray(dst_lin, np.float64).reshape(-1, 3)
    if len(src) < 12:
        return np.eye(3), np.zeros(3)
    keep = np.ones(len(src), bool)
    A_full = np.concatenate([src, np.ones((len(src), 1))], axis=1)
    prior = np.vstack([np.eye(3), np.zeros((1, 3))])          # (4, 3): identity, zero offset
    X = prior
    for _ in range(iters + 1):
        A, Y = A_full[keep], dst[keep]
        lam = ridge * len(A)
        X = np.linalg.solve(A.T @ A + lam * np.eye(4), A.T @ Y + lam * prior)
        r = np.linalg.norm(A_full @ X - dst, axis=1)
        rms = np.sqrt(np.mean(r[keep] ** 2)) + 1e-12
        new_keep = r <= clip_sigma * rms
        if new_keep.sum() < 12 or np.array_equal(new_keep, keep):
            break
        keep = new_keep
    return X[:3].T.copy(), X[3].copy()


def fit_colour_gain_prior(src_lin: np.ndarray, dst_lin: np.ndarray, lam_rel: float
                          ) -> tuple[np.ndarray, np.ndarray]:
    """Ridge least squares of ``dst ~ M src + b`` pulled towards the per-channel gain
    ``diag(mean dst / mean src)`` with weight ``lam_rel * N * mean(src^2)``: large ``lam_rel`` gives a
    white-balance-like diagonal map, 0 gives the full affine least-squares fit."""
    src = np.asarray(src_lin, np.float64).reshape(-1, 3)
    dst = np.asarray(dst_lin, np.float64).reshape(-1, 3)
    if len(src) < 12:
        return np.eye(3), np.zeros(3)
    A = np.concatenate([src, np.ones((len(src), 1))], axis=1)
    gain = dst.mean(0) / np.maximum(src.mean(0), 1e-6)
    prior = np.vstack([np.diag(gain), np.zeros((1, 3))])
    lam = max(float(lam_rel) * len(A) * float(np.mean(src ** 2)), 1e-9 * len(A))
    X = np.linalg.solve(A.T @ A + lam * np.eye(4), A.T @ dst + lam * prior)
    return X[:3].T.copy(), X[3].copy()


RIDGE_LADDER = (1.0, 0.3, 0.1, 0.03, 0.01, 0.0)


def fit_colour_adaptive(src_lin: np.ndarray, dst_lin: np.ndarray, dst_srgb01: np.ndarray,
                        share: float = 0.5) -> tuple[np.ndarray, np.ndarray, float, float, float]:
    """The most regularised fit on :data:`RIDGE_LADDER` that achieves at least ``share`` of the dE reduction of
    the unregularised fit (plausible, near-diagonal maps unless cross-talk really helps).
    Returns (M, b, lam_rel, dE_before, dE_after) with mean CIEDE2000 against ``dst_srgb01``."""
    de0 = float(delta_e2000(dst_srgb01, linear_to_srgb(src_lin)).mean())
    fits = []
    for lam in RIDGE_LADDER:
        M, b = fit_colour_gain_prior(src_lin, dst_lin, lam)
        de = float(delta_e2000(dst_srgb01, linear_to_srgb(apply_colour_transform(src_lin, M, b))).mean())
        fits.append((lam, M, b, de))
    de_full = fits[-1][3]
    goal = de0 - share * (de0 - de_full)
    for lam, M, b, de in fits:
        if de <= goal and de < de0:
            return M, b, lam, de0, de
    lam, M, b, de = min(fits, key=lambda f: f[3])
    if de >= de0:
        return np.eye(3), np.zeros(3), float("nan"), de0, de0
    return M, b, lam, de0, de


def apply_colour_transform(rgb_lin: np.ndarray, M: np.ndarray, b: np.ndarray,
                           alpha: np.ndarray | None = None) -> np.ndarray:
    """``M @ c + b`` per pixel; with ``alpha`` the input is premultiplied and the offset is scaled by alpha."""
    c = np.asarray(rgb_lin, np.float32)
    out = c @ np.asarray(M, np.float32).T
    off = np.asarray(b, np.float32)
    out += off if alpha is None else alpha[..., None].astype(np.float32) * off
    return out


def delta_e2000(srgb_a01: np.ndarray, srgb_b01: np.ndarray) -> np.ndarray:
    """CIEDE2000 between two sRGB (D65) colour arrays (..., 3) in [0, 1]."""
    # lazy: colour-science takes ~1.4 s to import
    import colour
    cs = colour.RGB_COLOURSPACES["sRGB"]

    def lab(x):
        xyz = colour.RGB_to_XYZ(np.asarray(x, np.float64), cs, apply_cctf_decoding=True)
        return colour.XYZ_to_Lab(xyz, cs.whitepoint)

    return np.asarray(colour.delta_E(lab(srgb_a01), lab(srgb_b01), method="CIE 2000"), np.float64)


def _sqrtm_psd(S: np.ndarray) -> np.ndarray:
    w, V = np.linalg.eigh((S + S.T) / 2)
    return (V * np.sqrt(np.clip(w, 0, None))) @ V.T


def fit_colour_transfer_mk(src_lin: np.ndarray, dst_lin: np.ndarray, eps: float = 1e-6
                           ) -> tuple[np.ndarray, np.ndarray]:
    """Linear (Monge-Kantorovich) colour transfer: the affine map ``M x + b`` that carries the mean and
    covariance of the render's colours onto those of the real object's colours. Matches distributions,
    not pixel pairs, so it is insensitive to small texture misalignment (which biases least squares
    towards flat, desaturated colours). Returns (M (3, 3), b (3,))."""
    src = np.asarray(src_lin, np.float64).reshape(-1, 3)
    dst = np.asarray(dst_lin, np.float64).reshape(-1, 3)
    if len(src) < 12:
        return np.eye(3), np.zeros(3)
    mu_s, mu_d = src.mean(0), dst.mean(0)
    Ss = np.cov(src.T) + eps * np.eye(3)
    Sd = np.cov(dst.T) + eps * np.eye(3)
    Ss_h = _sqrtm_psd(Ss)
    Ss_ih = np.linalg.inv(Ss_h)
    M = Ss_ih @ _sqrtm_psd(Ss_h @ Sd @ Ss_h) @ Ss_ih
    return M, mu_d - M @ mu_s
