"""Time-series-aware covariance of least-squares base parameters (Newey–West / HAC, Bartlett kernel).

The residuals of a filtered, often closed-loop recording are correlated over many samples, so the
white-noise covariance σ²(WᵀW)⁻¹ is several times too optimistic.  The sandwich
``cov = B⁻¹ S B⁻¹`` with ``B = Wᵀ diag(w) W`` and ``S`` the long-run covariance of the per-sample scores
``g_t = Σ_rows(t) w·r·W`` (all joints of a sample summed, so correlation across joints counts) holds for
any stationary residual correlation.  ``S`` uses the Bartlett kernel, per recording; the Bartlett sum is
computed exactly as moving-window sums of the scores (cumulative sums), O(N·nb²) whatever the lag.

The lag (bandwidth) ``L`` of a recording (:func:`choose_lag`, issue 47) is the larger of

* Andrews' (1991) AR(1) rule (:func:`andrews_bandwidth`), MSE-optimal when the scores are AR(1), and
* the lag at which the Bartlett kernel's own bias is at most :data:`KERNEL_BIAS` (5 %) of ``S``
  (:func:`bias_bandwidth`): the kernel drops ``Σ_k |k|/(L+1)·Γ(k)``, so ``L + 1 = ŝ₁/(KERNEL_BIAS·ŝ₀)`` with
  ``ŝ₀ = Σ_k ρ(k)`` and ``ŝ₁ = Σ_k |k|·ρ(k)`` from the scores' own autocorrelation ``ρ`` (averaged over the
  parameters, summed up to its first zero crossing).  Noise that is slow against the sample rate (a drive
  error low-passed at 1 Hz, inside the excitation band) is correlated over a thousand samples and more,
  far beyond what an AR(1) fit of neighbouring samples sees;

capped at ``N − 1``.  A long lag is a sizeable share ``b = (L+1)/N`` of the recording, and since the
least-squares scores sum to zero, the Bartlett sum then shrinks by ``1 − b + b²/3`` on average (Kiefer &
Vogelsang 2005, fixed-b); ``S`` is divided by that factor.  When the recordings hold fewer independent
stretches ``Σ N/(L+1)`` than :data:`MIN_BLOCKS` (2: the lag spans more than half the recording), σ cannot
be estimated (the scores of a 0.1 s recording sum to zero over nearly every window, which gave σ = 0 before
issue 47): :func:`hac_std` then gives no σ (NaN, printed "—") and a one-line DataWarning naming why
(:func:`short_recording`).
"""

from __future__ import annotations

import numpy as np

import warnings

from pinid.errors import DataWarning
from pinid.linalg import andrews_bandwidth, bartlett_long_run

#: Largest share of the long-run covariance the Bartlett kernel may drop (:func:`bias_bandwidth`).
KERNEL_BIAS = 0.05
#: The autocorrelation for :func:`bias_bandwidth` is computed on at most this many bins of summed scores.
ACF_BINS = 65536
#: Fewest independent stretches ``Σ N/(L+1)`` of the recordings for a σ (:func:`short_recording`): with fewer,
#: the lag spans more than half a recording, and the Bartlett sum of scores that sum to zero is mostly noise.
MIN_BLOCKS = 2.0


def acf_bin(n: int) -> int:
    """Samples per bin of the scores' autocorrelation for a recording of ``n`` samples (1 up to :data:`ACF_BINS`)."""
    return max(1, -(-n // ACF_BINS))


def bias_bandwidth(binned: np.ndarray, m: int = 1) -> int:
    """The Bartlett lag [samples] whose kernel bias is at most :data:`KERNEL_BIAS` of the long-run
    covariance, from the scores ``binned`` (bins × p: sums of ``m`` consecutive samples' scores; see the
    module text).  0 when the scores show no positive correlation."""
    n, p = binned.shape
    if n < 8:
        return 0
    F = np.fft.rfft(binned, n=2 * n, axis=0)
    ac = np.fft.irfft(np.abs(F) ** 2, n=2 * n, axis=0)[:n]
    ok = ac[0] > 0
    if not ok.any():
        return 0
    rho = np.mean(ac[:, ok] / ac[0, ok], axis=1)
    neg = np.flatnonzero(rho[1:] <= 0)
    stop = int(neg[0]) + 1 if neg.size else n // 2
    k = np.arange(stop)
    s0 = 1.0 + 2.0 * float(np.sum(rho[1:stop]))
    s1 = 2.0 * float(np.sum(k * rho[:stop]))
    if s0 <= 0 or s1 <= 0:
        return 0
    return int(np.ceil(m * s1 / (KERNEL_BIAS * s0)))


def binned_scores(g: np.ndarray) -> tuple[np.ndarray, int]:
    """``(bins, m)``: the scores ``g`` (N, p) summed over bins of ``m = acf_bin(N)`` samples (a last partial
    bin dropped)."""
    m = acf_bin(len(g))
    nb = len(g) // m
    return (g[: nb * m].reshape(nb, m, -1).sum(axis=1) if m > 1 else g), m


def choose_lag(g: np.ndarray) -> int:
    """The Bartlett lag [samples] of one recording's scores ``g`` (N, p): the larger of Andrews' and the
    kernel-bias lag, at most ``N − 1`` (module text)."""
    return min(max(andrews_bandwidth(g), bias_bandwidth(*binned_scores(g))), max(len(g) - 1, 0))


def fixed_b_factor(lag: int, n: int) -> float:
    """``1 − b + b²/3``, ``b = (lag+1)/n``: the mean shrinkage of a Bartlett sum of least-squares scores."""
    if lag <= 0 or n <= 0:
        return 1.0
    b = min((lag + 1) / n, 1.0)
    return 1.0 - b + b * b / 3.0


def short_recording(sizes, lags, nb: int) -> str | None:
    """The one-line reason when the recordings (``sizes`` samples, residuals correlated over ``lags``) hold fewer
    than :data:`MIN_BLOCKS` independent stretches ``Σ N/(L+1)`` for the ``nb`` base parameters' σ; else None."""
    blocks = sum(n / (lag + 1) for n, lag in zip(sizes, lags))
    if blocks >= MIN_BLOCKS:
        return None
    return (
        f"recording too short for the standard deviations of {nb} base parameters: {sum(sizes)} samples (after "
        f"trimming) whose residuals stay correlated over {max(lags)} samples hold {blocks:.1f} independent "
        f"stretches, expected at least {MIN_BLOCKS:g}; no σ given (—), record longer"
    )


def _exact(problem, e: np.ndarray) -> bool:
    """Whether the residual ``e`` is round-off (a noise-free recording fitted exactly): σ ≈ 0 is then right."""
    tau = getattr(problem, "tau", None)
    return tau is not None and float(np.linalg.norm(e)) <= 1e-9 * float(np.linalg.norm(tau))


def _no_sigma(why: str, nb: int, full: bool = False) -> np.ndarray:
    """NaN standard deviations (or with ``full`` a NaN covariance) and the warning ``why``."""
    warnings.warn(why, DataWarning, stacklevel=3)
    return np.full((nb, nb) if full else nb, np.nan)


def hac_covariance(
    Binv: np.ndarray, scores: np.ndarray, bounds: list[tuple[int, int]], dof_ratio: float = 1.0
) -> tuple[np.ndarray, list[int]]:
    """``(B⁻¹ S B⁻¹ · dof_ratio, lags)``: ``S`` summed over recordings ``bounds`` ([start, stop) sample
    ranges of ``scores``), each with its own lag (:func:`choose_lag`) and fixed-b factor."""
    p = scores.shape[1]
    S = np.zeros((p, p))
    lags = []
    for a, b in bounds:
        g = scores[a:b]
        lag = choose_lag(g)
        lags.append(lag)
        S += bartlett_long_run(g, lag) / fixed_b_factor(lag, len(g))
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
        sizes = [ds.n for ds in rows.datasets]
        why = None if _exact(problem, e) else short_recording(sizes, lags, problem.nb)
        if why:
            return _no_sigma(why, problem.nb, full)
        for lag, n, blocks in zip(lags, sizes, _recording_scores(rows, e, weights, scale)):
            S += _streamed_long_run(blocks, lag, problem.nb) / fixed_b_factor(lag, n)
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
    cov, lags = hac_covariance(Binv, g, list(zip(edges[:-1], edges[1:])), problem.rows / dof)
    why = None if _exact(problem, e) else short_recording(sizes, lags, problem.nb)
    if why:
        return _no_sigma(why, problem.nb, full)
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
    """The lag of each recording (:func:`choose_lag`) from sums over its score blocks: the AR(1) fit's sums
    ``Σx², Σxy, Σy²`` accumulated block by block (``x = g[:-1]``, ``y = g[1:]``) for Andrews' bandwidth, and
    the scores summed into :func:`acf_bin` bins for the kernel-bias one."""
    lags = []
    for ds, blocks in zip(rows.datasets, _recording_scores(rows, e, weights, scale)):
        sxx, sxy, syy = np.zeros(p), np.zeros(p), np.zeros(p)
        m = acf_bin(ds.n)
        binned = np.zeros((ds.n // m + 1, p))
        n, last = 0, None
        for g in blocks:
            np.add.at(binned, (n + np.arange(len(g))) // m, g)
            x = g[:-1] if last is None else np.vstack([last, g[:-1]])
            y = g[1:] if last is None else g
            sxx += np.einsum("ij,ij->j", x, x)
            sxy += np.einsum("ij,ij->j", x, y)
            syy += np.einsum("ij,ij->j", y, y)
            n += len(g)
            last = g[-1:]
        own = bias_bandwidth(binned[: n // m], m)
        lags.append(min(max(_bandwidth(n, sxx, sxy, syy), own), max(n - 1, 0)))
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
