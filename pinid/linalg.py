"""Least-squares kernels shared by the problem and the estimators, and the rank tolerance.

A tall weighted least-squares problem ``min ‖diag(√w)(W x − τ)‖`` is compressed once into an
``nb × nb`` triangle (:func:`augmented_r`) that every estimator and statistic reuses.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

import numpy as np
import scipy.linalg

from pinid.errors import SolverError
from pinid.checks import array_like, count
from pinid.errors import DataError

#: Relative tolerance on singular values (or pivots, or Gram eigenvalues) below which a matrix counts as
#: rank deficient: used for the regressor's rank check, the choice Cholesky vs QR, and null spaces.
RANK_TOL = 1e-10
#: Relative pivot below which a triangular solve refuses (stricter than :data:`RANK_TOL`: the rank was
#: already checked on the problem; this only guards against a numerically singular triangle).
SOLVE_TOL = 1e-13


#: Rows per block when a tall matrix's Gram sums are accumulated (bounds the weighted copy of a block).
GRAM_BLOCK_ROWS = 100_000


def row_blocks(
    W: np.ndarray, tau: np.ndarray, weights: np.ndarray | None = None, rows: int = GRAM_BLOCK_ROWS
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray | None]]:
    """``(W_k, τ_k, w_k)`` of consecutive blocks of ``rows`` rows of a whole matrix (``w_k`` None without weights)."""
    array_like(W, "W")  # checked when called, not when first iterated
    return (
        (W[s : s + rows], tau[s : s + rows], None if weights is None else weights[s : s + rows])
        for s in range(0, len(W), rows)
    )


def regrouped_blocks(
    blocks: Iterable[np.ndarray], tau: np.ndarray, weights: np.ndarray | None = None, rows: int | None = None
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray | None]]:
    """:func:`row_blocks` of the matrix whose consecutive row blocks are ``blocks`` (e.g. a tall regressor
    built block by block), without that matrix: each block of ``rows`` rows is copied into one reused buffer
    (valid until the next block is asked for), so sums over them are those over the whole matrix's blocks;
    ``rows`` default :data:`GRAM_BLOCK_ROWS`."""
    array_like(tau, "tau")  # checked when called, not when first iterated
    if not isinstance(blocks, Iterable):
        raise DataError(f"blocks: got {type(blocks).__name__}, expected row blocks of a matrix")
    return _regrouped(blocks, tau, weights, GRAM_BLOCK_ROWS if rows is None else count(rows, "rows"))


def _regrouped(blocks, tau, weights, rows):
    buf, fill, start = None, 0, 0
    for Wk in blocks:
        at = 0
        while at < len(Wk):
            if buf is None:
                buf = np.empty((min(rows, len(tau)), Wk.shape[1]))
            take = min(rows - fill, len(Wk) - at)
            buf[fill : fill + take] = Wk[at : at + take]
            fill, at = fill + take, at + take
            if fill == rows:
                yield buf, tau[start : start + rows], None if weights is None else weights[start : start + rows]
                fill, start = 0, start + rows
    if fill:
        stop = start + fill
        yield buf[:fill], tau[start:stop], None if weights is None else weights[start:stop]


def gram_sums(
    blocks: Iterable[tuple[np.ndarray, np.ndarray, np.ndarray | None]], nb: int
) -> tuple[np.ndarray, np.ndarray, float]:
    """``(G, b, yy)`` = (Σ W_kᵀ diag(w_k) W_k, Σ W_kᵀ diag(w_k) τ_k, Σ w_k·τ_k²) over row blocks
    ``(W_k, τ_k, w_k)`` (``w_k`` None: unit weights): the normal equations of a tall weighted least-squares
    problem, accumulated without the tall matrix existing whole."""
    if not isinstance(blocks, Iterable) or isinstance(blocks, (str, bytes)):
        raise DataError(f"blocks: got {type(blocks).__name__}, expected (W, tau, weights) row blocks")
    nb = count(nb, "nb")
    G = np.zeros((nb, nb))
    b = np.zeros(nb)
    yy = 0.0
    for Wk, yk, wk in blocks:
        Wk = np.asarray(Wk, dtype=float)
        yk = np.asarray(yk, dtype=float)
        Ww = Wk if wk is None else Wk * np.asarray(wk, dtype=float)[:, None]
        G += Ww.T @ Wk
        b += Ww.T @ yk
        yy += float(np.dot(yk, yk) if wk is None else np.dot(wk * yk, yk))
    return G, b, yy


def column_scale(G: np.ndarray) -> np.ndarray:
    """Column norms ``√diag(G)`` of the matrix behind a Gram matrix, zeros replaced by 1 (for scaling)."""
    array_like(G, "G")
    scale = np.sqrt(np.maximum(np.diag(G), 0.0))
    scale[scale == 0] = 1.0
    return scale


def cholesky_r(G: np.ndarray, b: np.ndarray, yy: float) -> tuple[np.ndarray, np.ndarray, float, np.ndarray] | None:
    """``(R, c, rho, scale)`` of :func:`augmented_r` from the Gram sums of :func:`gram_sums`, or None when the
    column-scaled Gram matrix is not safely positive definite (condition number above 1/:data:`RANK_TOL`, or
    not finite): then only a QR factorisation of the tall matrix is accurate enough."""
    array_like(G, "G")
    nb = len(G)
    scale = column_scale(G)
    Gs = G / np.outer(scale, scale)
    if not nb or not np.all(np.isfinite(Gs)):
        return None
    ev = np.linalg.eigvalsh(Gs)
    if not ev[0] > RANK_TOL * ev[-1]:
        return None
    try:
        R = scipy.linalg.cholesky(Gs, lower=False)
        c = scipy.linalg.solve_triangular(R, b / scale, trans="T")
    except (np.linalg.LinAlgError, ValueError):
        return None
    rho = float(np.sqrt(max(yy - float(c @ c), 0.0)))
    return R, c, rho, scale


def unit_weights(weights: np.ndarray | None) -> np.ndarray | None:
    """``weights`` as floats, or None when absent or all ones (then rows are not multiplied)."""
    if weights is not None:
        array_like(weights, "weights")
    if weights is None or np.all(weights == 1.0):
        return None
    return np.asarray(weights, dtype=float)


def augmented_r(
    W: np.ndarray, tau: np.ndarray, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Compress a weighted least-squares problem: ``(R, c, rho, scale)``.

    With ``A = diag(√w)·W·diag(1/scale)`` (columns scaled to unit norm) and ``y = √w·τ``,
    ``‖A x − y‖² = ‖R x − c‖² + rho²`` for every ``x``: ``R`` is ``(nb, nb)`` upper triangular, ``rho``
    the least-squares residual norm.  One pass over the tall matrix: the Cholesky factor of the
    column-scaled Gram matrix ``AᵀA`` (:func:`gram_sums` in row blocks, :func:`cholesky_r`) when its
    condition number is below 1e10 (then the normal equations lose at most ~1e-6 relative accuracy, far
    below any noise), else — and for rank deficiency — Householder QR of ``[A | y]`` (:func:`qr_r`).
    """
    array_like(W, "W")
    W = np.asarray(W, dtype=float)
    y = np.asarray(tau, dtype=float)
    w = unit_weights(weights)
    G, b, yy = gram_sums(row_blocks(W, y, w), W.shape[1])
    out = cholesky_r(G, b, yy)
    return out if out is not None else qr_r(W, y, w, column_scale(G))


def qr_r(
    W: np.ndarray, tau: np.ndarray, weights: np.ndarray | None, scale: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """``(R, c, rho, scale)`` of :func:`augmented_r` by Householder QR of the scaled, weighted ``[A | y]``
    (for ill-conditioned or rank-deficient problems; needs the whole tall matrix)."""
    array_like(W, "W")
    nb = W.shape[1]
    aug = np.empty((W.shape[0], nb + 1))
    if weights is not None:
        sw = np.sqrt(weights)
        np.multiply(W, (sw[:, None] / scale), out=aug[:, :nb])
        aug[:, nb] = tau * sw
    else:
        np.divide(W, scale, out=aug[:, :nb])
        aug[:, nb] = tau
    R_aug = np.linalg.qr(aug, mode="r")
    k = min(R_aug.shape[0], nb + 1)
    R_full = np.zeros((nb + 1, nb + 1))
    R_full[:k] = R_aug[:k]
    return R_full[:nb, :nb], R_full[:nb, nb], float(abs(R_full[nb, nb])), scale


def solve_r(R: np.ndarray, c: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """The least-squares solution ``x`` of the compressed problem of :func:`augmented_r`."""
    array_like(R, "R")
    d = np.abs(np.diag(R))
    if d.size and (not np.all(np.isfinite(R)) or d.min() <= SOLVE_TOL * d.max()):
        raise SolverError("least squares: the (weighted) base regressor is rank deficient")
    return scipy.linalg.solve_triangular(R, c) / scale


def weighted_lstsq(W: np.ndarray, tau: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """``argmin ‖diag(√w)(W x − τ)‖²`` through a column-scaled QR factorisation."""
    array_like(W, "W")
    R, c, _, scale = augmented_r(W, tau, weights)
    return solve_r(R, c, scale)


def andrews_bandwidth(g: np.ndarray) -> int:
    """Andrews' (1991) Bartlett bandwidth [samples] from AR(1) fits of each score column ``g`` (N, p)."""
    g = np.asarray(array_like(g, "g"), dtype=float)
    n = len(g)
    if n < 4:
        return 0
    x, y = g[:-1], g[1:]
    den = np.einsum("ij,ij->j", x, x)
    ok = den > 0
    if not ok.any():
        return 0
    rho = np.clip(np.einsum("ij,ij->j", x[:, ok], y[:, ok]) / den[ok], -0.97, 0.97)
    s2 = np.mean((y[:, ok] - rho * x[:, ok]) ** 2, axis=0)
    num = np.sum(4 * rho**2 * s2**2 / ((1 - rho) ** 6 * (1 + rho) ** 2))
    dd = np.sum(s2**2 / (1 - rho) ** 4)
    if dd <= 0:
        return 0
    return int(min(np.ceil(1.1447 * (num / dd * n) ** (1 / 3)), n // 2))


def bartlett_long_run(g: np.ndarray, lag: int) -> np.ndarray:
    """``Σ_{t,s} (1 − |t−s|/(lag+1))₊ g_t g_sᵀ`` (p, p) of scores ``g`` (N, p), via moving window sums."""
    g, lag = np.asarray(array_like(g, "g"), dtype=float), count(lag, "lag")
    if lag <= 0:
        return g.T @ g
    p = g.shape[1]
    c = np.zeros((len(g) + 2 * lag + 1, p))
    np.cumsum(np.vstack([np.zeros((lag, p)), g, np.zeros((lag, p))]), axis=0, out=c[1:])
    h = c[lag + 1 :] - c[: -lag - 1]  # every window of lag+1 consecutive samples that meets the data
    return (h.T @ h) / (lag + 1)
