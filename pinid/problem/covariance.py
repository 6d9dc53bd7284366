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


def sample_scores(W: np.ndarray, e: np.ndarray, sample: np.ndarray, samples: int) -> np.ndarray:
    """Per-sample scores ``Σ_rows(t) e·W`` (samples, p) of rows with sample index ``sample``."""
    g = np.zeros((samples, W.shape[1]))
    np.add.at(g, sample, W * e[:, None])
    return g


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


def hac_std(problem, e: np.ndarray, Rinv: np.ndarray, scale: np.ndarray, dof: int) -> np.ndarray:
    """HAC standard deviations of the base parameters of ``problem`` (an identification problem) from its
    weighted residuals ``e = w·r`` (rows,), per recording; ``Rinv``, ``scale``: the inverse of the compressed
    ``R`` and its column scale (:meth:`~pinid.problem.problem.IdentificationProblem.compressed`); ``dof``:
    rows − nb.  The scores are summed per sample (all joints), the W rows built block by block when the
    problem holds no tall ``W``."""
    sample = np.asarray(problem.sample, dtype=int)
    rows = getattr(problem, "regressor_rows", None)
    sizes = [ds.n for ds in rows.datasets] if rows is not None else getattr(problem, "recording_sizes", None)
    if sizes is None:
        sizes = [int(sample.max()) + 1 if len(sample) else 0]
    n = sum(sizes)
    g = np.zeros((n, problem.nb))
    if rows is not None and getattr(problem, "blocked", False):
        for r0, Wk in rows.blocks():
            k = slice(r0, r0 + len(Wk))
            np.add.at(g, sample[k], Wk * e[k, None])
    else:
        np.add.at(g, sample, problem.W * e[:, None])
    g /= scale  # scaled coordinates, those of R
    edges = np.cumsum([0, *sizes])
    Binv = Rinv @ Rinv.T
    cov, _ = hac_covariance(Binv, g, list(zip(edges[:-1], edges[1:])), problem.rows / dof)
    return np.sqrt(np.clip(np.diag(cov), 0.0, None)) / scale
