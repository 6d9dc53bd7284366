"""Blocked cross-validation on the training recordings: what the data-chosen settings share.

Every training recording is cut into ``folds`` contiguous blocks of equal duration (the same boundaries,
in time, for every candidate compared); the model of a candidate is fitted by ordinary least squares on all
blocks but one and the held-out block is predicted and scored **against the torque as recorded**, on the
samples every candidate keeps.  Blocks rather than random rows: the residuals of filtered recordings are
correlated in time, and a random split scores a sample with its neighbours in the fit.

Candidates are compared fold by fold, on the paired differences of their held-out scores.  A candidate
**wins** (:func:`better`: a term, a ripple, a cut-off is adopted) when its mean improvement exceeds the
one-sided 95 % quantile of Student's t with ``blocks − 1`` degrees of freedom times the standard error of the
differences — honest about how few blocks there are (2.13 for 5 blocks, 2.92 for 3, where the normal
approximation's 2 was too lenient) — **and** lowers the pooled held-out score by at least
:data:`MIN_GAIN` of it: a gain of 0.01 point is not worth a term, however steady.  Fewer than
:data:`MIN_BLOCKS` scored blocks never win, nor anything against a score at round-off (noise-free data).  A fit whose held-out blocks score above :data:`UNSTABLE_PERCENT`
(worse than predicting no torque at all) did not converge to anything usable (an ill-conditioned
column, a Stribeck velocity far from the data's) and is reported as such, not scored (:func:`unstable`).
:mod:`pinid.identification.cutoff` (the low-pass cut-off), :mod:`pinid.identification.term_choice` (the
joint terms) and :mod:`pinid.identification.ripple_choice` (the ripple periods) use it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pinid.data.dataset import Dataset
from pinid.model.base import BaseParameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.problem.problem import IdentificationProblem, base_regressor, check_dataset, recorded_torque

#: Contiguous blocks per training recording.
FOLDS = 5
#: One-sided level of the paired t test of :func:`better` and :func:`not_worse`.
LEVEL = 0.05
#: A candidate must lower the held-out score by at least this fraction of it to win (:func:`better`).
MIN_GAIN = 0.01
#: A reference scoring below this [%] is at round-off (noise-free data): nothing can win against it.
ROUND_OFF_PERCENT = 1e-6
#: Fewest scored blocks a comparison needs.
MIN_BLOCKS = 3
#: A held-out relative RMS [%] above this (worse than predicting zero torque) marks a fit that did not converge.
UNSTABLE_PERCENT = 100.0


@dataclass
class CandidateRows:
    """One candidate's fitted rows (W, tau, weights, each row's recording and time) and, per recording,
    every sample's regressor, recorded torque and time (for scoring)."""

    W: np.ndarray
    tau: np.ndarray
    weights: np.ndarray
    row_recording: np.ndarray
    row_time: np.ndarray
    full: list[np.ndarray]  # per recording (N·nv, nb)
    recorded: list[np.ndarray]  # per recording (N, nv)
    times: list[np.ndarray]  # per recording (N,)


def block_edges(recordings: Sequence[Dataset], folds: int = FOLDS) -> list[np.ndarray]:
    """Each recording's block boundaries [s] (``folds + 1`` times from its first to its last sample)."""
    return [np.linspace(ds.t[0], ds.t[-1], folds + 1) for ds in recordings]


def candidate_rows(
    model: RobotModel,
    prepared: Sequence[Dataset],
    terms: TermSelection,
    base: BaseParameters,
    problem_options: Mapping | None = None,
) -> CandidateRows:
    """The rows of prepared recordings as the identification fits them (``problem_options``:
    ``rest_velocity``, ``rest_fraction``, ``fit_joints``), with what scoring needs."""
    problem = IdentificationProblem.from_datasets(
        model, list(prepared), terms=terms, base=base, **(problem_options or {})
    )
    checked = [check_dataset(ds, model) for ds in prepared]
    times = [ds.t for ds in checked]
    sample_recording = np.concatenate([np.full(ds.n, i) for i, ds in enumerate(checked)])
    sample_time = np.concatenate(times)
    return CandidateRows(
        problem.W,
        problem.tau,
        problem.weights,
        sample_recording[problem.sample],
        sample_time[problem.sample],
        [base_regressor(model, terms, base, ds) for ds in checked],
        [recorded_torque(ds) for ds in checked],
        times,
    )


def common_spans(candidates: Sequence[CandidateRows]) -> list[tuple[float, float]]:
    """Per recording, the time span [s] every candidate keeps (the latest start, the earliest end)."""
    n = len(candidates[0].times)
    return [(max(c.times[i][0] for c in candidates), min(c.times[i][-1] for c in candidates)) for i in range(n)]


def fold_sums(rows: CandidateRows, edges: Sequence[np.ndarray], spans: Sequence[tuple[float, float]]) -> np.ndarray:
    """``(folds, 2)``: each fold's squared error and squared recorded torque summed over its held-out block
    (inside ``spans``), the model fitted by OLS on the other blocks; NaN where too few rows are left to fit.

    The rows are compressed once: each group of rows held out by the same folds (a block; a row on a boundary
    belongs to two) is reduced to its triangular factor ``R`` and ``Qᵀy`` of the column-scaled weighted rows, and
    each fold solves the small stack of the groups it trains on — the least-squares solution of its rows, at
    a fraction of the cost of one tall least-squares problem per fold (issue 44)."""
    folds = len(edges[0]) - 1
    out = np.full((folds, 2), np.nan)
    held = np.zeros((folds, len(rows.tau)), dtype=bool)
    for k in range(folds):
        for i, e in enumerate(edges):
            held[k] |= (rows.row_recording == i) & (rows.row_time >= e[k]) & (rows.row_time <= e[k + 1])
    used = rows.weights > 0
    sw = np.sqrt(np.where(used, rows.weights, 0.0))
    scale = np.sqrt(np.einsum("ij,ij->j", rows.W, rows.W * (sw**2)[:, None]))
    scale[scale == 0] = 1.0
    pattern = (held.T.astype(np.int64) << np.arange(folds)).sum(axis=1)  # which folds hold each row out
    groups = {}  # pattern -> (R, Qᵀy, rows)
    for p in np.unique(pattern[used]):
        k = np.flatnonzero(used & (pattern == p))
        A = rows.W[k] * sw[k][:, None] / scale
        Q, R = np.linalg.qr(A)
        groups[int(p)] = (R, Q.T @ (rows.tau[k] * sw[k]), len(k))
    for k in range(folds):
        train = [g for p, g in groups.items() if not p >> k & 1]
        if sum(g[2] for g in train) <= rows.W.shape[1]:
            continue
        R = np.vstack([g[0] for g in train])
        c = np.concatenate([g[1] for g in train])
        theta = np.linalg.lstsq(R, c, rcond=None)[0] / scale
        err2 = ref2 = 0.0
        for i, e in enumerate(edges):
            t = rows.times[i]
            lo, hi = max(e[k], spans[i][0]), min(e[k + 1], spans[i][1])
            pick = np.flatnonzero((t >= lo) & (t <= hi))
            if pick.size == 0:
                continue
            W = rows.full[i].reshape(len(t), rows.recorded[i].shape[1], -1)[pick]
            err2 += float(np.sum((W @ theta - rows.recorded[i][pick]) ** 2))
            ref2 += float(np.sum(rows.recorded[i][pick] ** 2))
        out[k] = err2, ref2
    return out


def fold_scores(sums: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """From ``(candidates, folds, 2)`` sums: each candidate's pooled relative RMS [%] over all folds, and
    each fold's ``(candidates, folds)``."""
    with np.errstate(invalid="ignore", divide="ignore"):
        pooled = 100.0 * np.sqrt(sums[:, :, 0].sum(axis=1) / sums[:, :, 1].sum(axis=1))
        per_fold = 100.0 * np.sqrt(sums[:, :, 0] / sums[:, :, 1])
    return pooled, per_fold


#: One-sided 95 % quantiles of Student's t by degrees of freedom (1 … 30); beyond, the normal's 1.645 plus its
#: first Cornish–Fisher term.  A table, not scipy.stats: importing that costs more than the choice it serves.
_T95 = (6.314, 2.920, 2.353, 2.132, 2.015, 1.943, 1.895, 1.860, 1.833, 1.812, 1.796, 1.782, 1.771, 1.761, 1.753)
_T95 += (1.746, 1.740, 1.734, 1.729, 1.725, 1.721, 1.717, 1.714, 1.711, 1.708, 1.706, 1.703, 1.701, 1.699, 1.697)


def t_quantile(blocks: int, level: float = LEVEL) -> float:
    """The one-sided ``1 − level`` quantile of Student's t with ``blocks − 1`` degrees of freedom (``level``
    0.05: a table; another level: scipy.stats)."""
    df = max(int(blocks) - 1, 1)
    if level != 0.05:
        from scipy.stats import t  # loaded on use

        return float(t.ppf(1.0 - level, df))
    if df <= len(_T95):
        return _T95[df - 1]
    z = 1.6448536269514722
    return z + (z**3 + z) / (4 * df)


def _paired(a: np.ndarray, b: np.ndarray) -> tuple[float, float, int] | None:
    d = np.asarray(a) - np.asarray(b)
    d = d[np.isfinite(d)]
    if len(d) < MIN_BLOCKS:
        return None
    return float(np.mean(d)), float(np.std(d, ddof=1) / np.sqrt(len(d))), len(d)


def not_worse(candidate: np.ndarray, reference: np.ndarray) -> bool:
    """True when ``candidate``'s fold scores exceed ``reference``'s by at most the paired t test's margin
    (:func:`t_quantile` standard errors of the paired difference)."""
    d = _paired(candidate, reference)
    return d is not None and d[0] <= t_quantile(d[2]) * d[1]


def better(candidate: np.ndarray, reference: np.ndarray) -> bool:
    """True when ``candidate`` wins on the held-out blocks (module text): its fold scores below
    ``reference``'s by more than the paired t test's margin, and by at least :data:`MIN_GAIN` of the
    reference's mean score, on at least :data:`MIN_BLOCKS` blocks both scored."""
    d = _paired(reference, candidate)
    if d is None:
        return False
    both = np.isfinite(candidate) & np.isfinite(reference)
    level = float(np.mean(np.asarray(reference)[both]))
    gain = level > ROUND_OFF_PERCENT and d[0] >= MIN_GAIN * level
    return gain and d[0] > t_quantile(d[2]) * d[1]


def unstable(per_fold: np.ndarray) -> bool:
    """True when a candidate's held-out blocks score above :data:`UNSTABLE_PERCENT` (module text)."""
    f = np.asarray(per_fold, dtype=float)
    return bool(np.any(f[np.isfinite(f)] > UNSTABLE_PERCENT))
