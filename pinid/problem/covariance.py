"""Time-series-aware covariance of least-squares base parameters (Newey–West / HAC, Bartlett kernel).

The residuals of a filtered, often closed-loop recording are correlated over many samples, so the
white-noise covariance σ²(WᵀW)⁻¹ is several times too optimistic.  The sandwich
``cov = B⁻¹ S B⁻¹`` with ``B = Wᵀ diag(w) W`` and ``S`` the long-run covariance of the per-sample scores
``g_t = Σ_rows(t) w·r·W`` (all joints of a sample summed, so correlation across joints counts) holds for
any stationary residual correlation.  ``S`` uses the Bartlett kernel with Andrews' (1991) AR(1)
bandwidth, per recording; the Bartlett sum is computed exactly as moving-window sums of the scores
(cumulative sums), O(N·nb²) whatever the lag.
"""

from __future__ import annotations

import numpy as np


def andrews_bandwidth(g: np.ndarray) -> int:
    """Andrews' (1991) Bartlett bandwidth [samples] from AR(1) fits of each score column ``g`` (N, p)."""
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
    if lag <= 0:
        return g.T @ g
    p = g.shape[1]
    c = np.zeros((len(g) + 2 * lag + 1, p))
    np.cumsum(np.vstack([np.zeros((lag, p)), g, np.zeros((lag, p))]), axis=0, out=c[1:])
    h = c[lag + 1 :] - c[: -lag - 1]  # every window of lag+1 consecutive samples that meets the data
    return (h.T @ h) / (lag + 1)


def hac_covariance(
    Binv: np.ndarray, scores: np.ndarray, bounds: list[tuple[int, int]], dof_ratio: float = 1.0
) -> tuple[np.ndarray, list[int]]:
    """``(B⁻¹ S B⁻¹ · dof_ratio, lags)``: ``S`` summed over recordings ``bounds`` ([start, stop) sample
    ranges of ``scores``), each with its own Andrews bandwidth."""
    p = scores.shape[1]
    S = np.zeros((p, p))
    lags = []
    for a, b in bounds:
        g = scores[a:b]
        lag = andrews_bandwidth(g)
        lags.append(lag)
        S += bartlett_long_run(g, lag)
    return Binv @ S @ Binv * dof_ratio, lags


#: Scores (samples × nb float64) above this size are never held whole: formed block by block, twice (issue 35);
#: below it they are, and the sums are those of :func:`hac_covariance` to the last digit.
STREAM_SCORES_BYTES = 32 * 2**20


def hac_std(
    problem,
    e: np.ndarray,
    Rinv: np.ndarray,
    scale: np.ndarray,
    dof: int,
    *,
    weights: np.ndarray | None = None,
    full: bool = False,
) -> np.ndarray:
    """HAC standard deviations of the base parameters of ``problem`` (an identification problem) from its
    weighted residuals ``e = w·r`` (rows,), per recording; ``Rinv``, ``scale``: the inverse of the compressed
    ``R`` and its column scale (:meth:`~pinid.problem.problem.IdentificationProblem.compressed`); ``dof``:
    rows − nb; ``weights``: when given, ``e`` is the residual ``r`` and ``w·r`` is formed block by block.
    The scores are summed per sample (all joints); while the problem holds no tall ``W`` they are formed
    block by block, twice (the bandwidths, then the Bartlett sums), and never held whole (issue 35).  ``full``:
    the whole covariance matrix (nb, nb) instead of the standard deviations (for a combination's σ, issue 46)."""
    rows = getattr(problem, "regressor_rows", None)
    Binv = Rinv @ Rinv.T
    blocked = rows is not None and getattr(problem, "blocked", False)
    if blocked and sum(ds.n for ds in rows.datasets) * problem.nb * 8 > STREAM_SCORES_BYTES:
        S = np.zeros((problem.nb, problem.nb))
        lags = _blocked_bandwidths(rows, e, weights, scale, problem.nb)
        for lag, blocks in zip(lags, _recording_scores(rows, e, weights, scale)):
            S += _streamed_long_run(blocks, lag, problem.nb)
        cov = Binv @ S @ Binv * (problem.rows / dof)
        return _unscaled(cov, scale, full)
    sample = np.asarray(problem.sample, dtype=int)
    sizes = [ds.n for ds in rows.datasets] if rows is not None else getattr(problem, "recording_sizes", None)
    if sizes is None:
        sizes = [int(sample.max()) + 1 if len(sample) else 0]
    n = sum(sizes)
    g = np.zeros((n, problem.nb))
    e = e if weights is None else weights * e
    if blocked:
        for r0, Wk in rows.blocks():
            k = slice(r0, r0 + len(Wk))
            np.add.at(g, sample[k], Wk * e[k, None])
    else:
        np.add.at(g, sample, problem.W * e[:, None])
    g /= scale  # scaled coordinates, those of R
    edges = np.cumsum([0, *sizes])
    cov, _ = hac_covariance(Binv, g, list(zip(edges[:-1], edges[1:])), problem.rows / dof)
    return _unscaled(cov, scale, full)


def _unscaled(cov: np.ndarray, scale: np.ndarray, full: bool) -> np.ndarray:
    """The standard deviations (or with ``full`` the covariance) in the parameters' units from the scaled ``cov``."""
    if full:
        return cov / np.outer(scale, scale)
    return np.sqrt(np.clip(np.diag(cov), 0.0, None)) / scale


def _recording_scores(rows, e, weights, scale):
    """Per recording, an iterator of its per-sample scores ``Σ_rows(t) w·r·W / scale`` in blocks of samples,
    in time order (the blocks of ``rows.blocks()``, one per chunk of samples)."""
    blocks = rows.blocks()

    def scores(ds, keep):
        nv, keep = keep.size // max(ds.n, 1), keep.reshape(-1)  # rows per sample: nv, or 6 + nv (floating base)
        for start in range(0, ds.n, rows.chunk):
            stop = min(ds.n, start + rows.chunk)
            r0, Wk = next(blocks)
            k = slice(r0, r0 + len(Wk))
            ek = e[k] if weights is None else weights[k] * e[k]
            g = np.zeros((stop - start, Wk.shape[1]))
            np.add.at(g, np.flatnonzero(keep[start * nv : stop * nv]) // nv, Wk * ek[:, None])
            g /= scale
            yield g

    for ds, keep in zip(rows.datasets, rows.keeps):
        yield scores(ds, keep)
    next(blocks, None)  # to the end: the rows keep small blocks for the passes to come (RegressorRows.blocks)


def _blocked_bandwidths(rows, e, weights, scale, p: int) -> list[int]:
    """Andrews' bandwidth of each recording (:func:`andrews_bandwidth`) from sums over its score blocks: the
    AR(1) fit's sums ``Σx², Σxy, Σy²`` accumulated block by block (``x = g[:-1]``, ``y = g[1:]``)."""
    lags = []
    for blocks in _recording_scores(rows, e, weights, scale):
        sxx, sxy, syy = np.zeros(p), np.zeros(p), np.zeros(p)
        n, last = 0, None
        for g in blocks:
            x = g[:-1] if last is None else np.vstack([last, g[:-1]])
            y = g[1:] if last is None else g
            sxx += np.einsum("ij,ij->j", x, x)
            sxy += np.einsum("ij,ij->j", x, y)
            syy += np.einsum("ij,ij->j", y, y)
            n += len(g)
            last = g[-1:]
        lags.append(_bandwidth(n, sxx, sxy, syy))
    return lags


def _bandwidth(n: int, sxx: np.ndarray, sxy: np.ndarray, syy: np.ndarray) -> int:
    """:func:`andrews_bandwidth` from the sums of its AR(1) fits (``n`` samples): the residual variance
    ``mean((y − ρx)²)`` expanded as ``(Σy² − 2ρΣxy + ρ²Σx²)/(n − 1)``."""
    if n < 4:
        return 0
    ok = sxx > 0
    if not ok.any():
        return 0
    rho = np.clip(sxy[ok] / sxx[ok], -0.97, 0.97)
    s2 = np.maximum(syy[ok] - 2 * rho * sxy[ok] + rho**2 * sxx[ok], 0.0) / (n - 1)
    num = np.sum(4 * rho**2 * s2**2 / ((1 - rho) ** 6 * (1 + rho) ** 2))
    dd = np.sum(s2**2 / (1 - rho) ** 4)
    if dd <= 0:
        return 0
    return int(min(np.ceil(1.1447 * (num / dd * n) ** (1 / 3)), n // 2))


def _streamed_long_run(blocks, lag: int, p: int) -> np.ndarray:
    """:func:`bartlett_long_run` of the scores given in consecutive blocks: the window sums
    ``h_t = C_{t+1} − C_{t−lag}`` of the cumulative sums ``C`` (carried from block to block, the last
    ``lag + 1`` of them kept), ``Σ hᵀh`` accumulated per block; the same sums as the whole-array form."""
    S = np.zeros((p, p))
    if lag <= 0:
        for g in blocks:
            S += g.T @ g
        return S
    prev = np.zeros((lag + 1, p))  # C_{a−lag} … C_a before the block starting at a (zeros before the data)
    for g in _with_tail(blocks, lag, p):
        full = np.empty((lag + 1 + len(g), p))
        full[: lag + 1] = prev
        np.cumsum(np.vstack([prev[-1:], g]), axis=0, out=full[lag:])
        h = full[lag + 1 :] - full[: len(g)]
        S += h.T @ h
        prev = full[-(lag + 1) :].copy()
    return S / (lag + 1)


def _with_tail(blocks, lag: int, p: int):
    """The score blocks, then ``lag`` rows of zeros (the windows that reach past the last sample)."""
    yield from blocks
    yield np.zeros((lag, p))
