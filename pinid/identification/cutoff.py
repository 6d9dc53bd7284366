"""The low-pass cut-off chosen by the data: blocked cross-validation on the training recordings.

A fixed default cut-off (10 Hz) is right for some recordings and wrong for others: a 5 kHz motor-side
recording of a fast wrist wants 50–100 Hz, a slow arm at 100 Hz a few Hz.  ``cutoff="auto"`` tries each
candidate of a grid and keeps the one whose model predicts held-out stretches of the **training**
recordings best (the validation recording is never looked at):

1. every training recording is cut into ``folds`` contiguous blocks of equal duration (the same block
   boundaries, in time, for every candidate);
2. per candidate, the recordings are prepared with that cut-off and the same model class (terms, rest
   rows, fit joints) is fitted by ordinary least squares on all blocks but one;
3. the held-out block is predicted and scored **against the torque as recorded** (not the low-passed copy,
   which moves with the cut-off: docs/identification.md, "The yardstick"), over the samples every candidate
   keeps after its trimming, so all candidates are scored on the same samples;
4. the score of a candidate is the pooled relative RMS over all folds; the choice is the **highest**
   cut-off that is not measurably worse than the lowest-scoring one (its fold-by-fold excess over it at
   most two standard errors of that paired difference).  On the flat bottom of the curve this takes the
   least smoothing: a cut-off lower than needed removes motion that a faster trajectory than the training
   one has.  Measured (``tests/benchmarks/bench_cutoff.py``): the lowest score alone picked 3 Hz on a
   5 kHz twin whose held-out best is 30 Hz (a curve flat to 1 % from 3 to 30 Hz); this rule picks 30 Hz.

Blocks rather than random rows because the residuals of filtered recordings are correlated in time: a
random split scores a sample with its neighbours in the fit and rewards a cut-off that lets noise in.
Cost: one preparation and one regressor per candidate and recording (about the cost of one
identification per candidate with OLS); the fits themselves are small least-squares problems.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from pinid.data.dataset import Dataset
from pinid.data.formats import read_recording
from pinid.errors import DataError, DataWarning, SpecError
from pinid.model.base import BaseParameters
from pinid.model.regressor import TermSelection
from pinid.model.robot import RobotModel
from pinid.problem.problem import (
    IdentificationProblem,
    base_regressor,
    check_dataset,
    free_angles,
    prepare_dataset,
    recorded_torque,
)

#: Candidate cut-offs [Hz] (about three per decade); those the sample rate cannot carry are left out.
GRID_HZ: tuple[float, ...] = (1.0, 1.5, 2.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0, 50.0, 70.0, 100.0, 150.0, 200.0)
#: Highest candidate as a fraction of the Nyquist frequency (the filter refuses above 0.8).
MAX_NYQUIST_FRACTION = 0.4
#: Contiguous blocks per training recording.
FOLDS = 5
#: A higher cut-off is kept while its held-out error exceeds the best one's by at most this many standard
#: errors of the paired fold-by-fold difference (about a one-sided 95 % test: "not measurably worse").
STANDARD_ERRORS = 2.0


@dataclass(frozen=True)
class CutoffChoice:
    """The cut-off [Hz] chosen and the cross-validation curve it was chosen on.

    ``candidates`` [Hz] and ``scores`` (pooled relative RMS [%] of the held-out blocks against the torque
    as recorded; NaN where a candidate could not be used, ``reasons`` says why)."""

    cutoff: float
    candidates: list[float]
    scores: list[float]
    folds: int
    reasons: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {
            "chosen_by": f"{self.folds}-fold blocked cross-validation on the training recordings",
            "cutoff_hz": self.cutoff,
            "candidates_hz": list(self.candidates),
            "cv_rel_rms_percent": [None if not np.isfinite(s) else float(s) for s in self.scores],
            "skipped": dict(self.reasons),
        }

    def text(self) -> str:
        """One line: the choice and its neighbours on the curve."""
        k = self.candidates.index(self.cutoff)
        near = [
            f"{c:g} Hz {s:.3g} %"
            for c, s in zip(self.candidates[max(0, k - 2) : k + 3], self.scores[max(0, k - 2) : k + 3])
            if np.isfinite(s)
        ]
        return (
            f"cut-off {self.cutoff:g} Hz, chosen by {self.folds}-fold blocked cross-validation on the training "
            f"recordings (held-out relative RMS against the torque as recorded: {', '.join(near)})"
        )

    def plot(self, kind: str | None = None, ax=None):
        """The cross-validation curve (score against cut-off, log axis) with the choice marked; the Figure."""
        import matplotlib.pyplot as plt

        if ax is None:
            fig, ax = plt.subplots(figsize=(6, 3.5))
        else:
            fig = ax.figure
        ok = np.isfinite(self.scores)
        ax.semilogx(np.array(self.candidates)[ok], np.array(self.scores)[ok], "o-", color="tab:blue")
        ax.axvline(self.cutoff, color="tab:red", ls="--", label=f"chosen: {self.cutoff:g} Hz")
        ax.set_xlabel("low-pass cut-off [Hz]")
        ax.set_ylabel("held-out rel. RMS [%]")
        ax.set_title("cut-off by blocked cross-validation (training recordings)")
        ax.legend()
        fig.tight_layout()
        return fig


def candidate_cutoffs(sample_rate: float) -> list[float]:
    """The grid's cut-offs [Hz] a recording sampled at ``sample_rate`` [Hz] can carry."""
    top = MAX_NYQUIST_FRACTION * sample_rate / 2
    return [c for c in GRID_HZ if c <= top]


def choose_cutoff(
    model: RobotModel,
    recordings,
    *,
    terms: TermSelection,
    base: BaseParameters,
    mapping=None,
    preprocess: Mapping | None = None,
    problem_options: Mapping | None = None,
    candidates: Sequence[float] | None = None,
    folds: int = FOLDS,
) -> CutoffChoice:
    """The cut-off [Hz] the training ``recordings`` (paths or Datasets) choose by blocked cross-validation
    (module text).  ``preprocess``: the other preprocessing options; ``problem_options``: ``rest_velocity``,
    ``rest_fraction``, ``fit_joints`` as the identification uses them; ``candidates`` [Hz]: default the
    grid the slowest recording's sample rate carries.  DataError when no candidate can be used."""
    if isinstance(folds, bool) or not isinstance(folds, (int, np.integer)) or folds < 2:
        raise SpecError(f"cut-off cross-validation folds {folds!r}, expected an integer ≥ 2")
    if isinstance(recordings, (Dataset, str)) or not isinstance(recordings, Sequence):
        recordings = [recordings]
    raw = [r if isinstance(r, Dataset) else read_recording(r, mapping=mapping, model=model) for r in recordings]
    if candidates is None:
        candidates = candidate_cutoffs(min(ds.sample_rate for ds in raw))
    candidates = sorted(float(c) for c in candidates)
    if not candidates:
        raise DataError("cut-off auto: the sample rate carries no candidate cut-off (at least 1 Hz)")
    edges = [np.linspace(ds.t[0], ds.t[-1], folds + 1) for ds in raw]
    options = {k: v for k, v in dict(preprocess or {}).items() if k != "cutoff"}
    fits, reasons = {}, {}
    for c in candidates:
        try:
            with warnings.catch_warnings():  # a candidate's own warnings ("content above the cut-off") are its score's
                warnings.simplefilter("ignore", DataWarning)
                fits[c] = _rows(model, raw, terms, base, {**options, "cutoff": c}, dict(problem_options or {}))
        except (DataError, SpecError) as exc:
            reasons[f"{c:g}"] = str(exc)
    if not fits:
        raise DataError(f"cut-off auto: no candidate cut-off could be used ({next(iter(reasons.values()))})")
    # the samples every candidate keeps: the latest start and the earliest end of each recording
    spans = [
        (max(f.times[i][0] for f in fits.values()), min(f.times[i][-1] for f in fits.values())) for i in range(len(raw))
    ]
    sums = np.array(
        [_score(fits[c], edges, spans, folds) if c in fits else np.full((folds, 2), np.nan) for c in candidates]
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        scores = 100.0 * np.sqrt(sums[:, :, 0].sum(axis=1) / sums[:, :, 1].sum(axis=1))
        per_fold = 100.0 * np.sqrt(sums[:, :, 0] / sums[:, :, 1])
    if not np.any(np.isfinite(scores)):
        raise DataError("cut-off auto: no candidate left a held-out block to score (recordings too short)")
    best = candidates[_pick(scores, per_fold)]
    return CutoffChoice(best, candidates, [float(x) for x in scores], folds, reasons)


def _pick(scores: np.ndarray, per_fold: np.ndarray) -> int:
    """The highest candidate whose fold scores are not worse than the lowest-scoring candidate's by more
    than :data:`STANDARD_ERRORS` standard errors of their paired fold-by-fold difference."""
    best = int(np.nanargmin(scores))
    kept = [best]
    for c in range(len(scores)):
        d = per_fold[c] - per_fold[best]
        d = d[np.isfinite(d)]
        if len(d) > 1 and np.mean(d) <= STANDARD_ERRORS * np.std(d, ddof=1) / np.sqrt(len(d)):
            kept.append(c)
    return max(kept)


@dataclass
class _Rows:
    """One candidate's fitted rows (W, tau, weights, each row's recording and time) and every sample's
    full regressor and recorded torque for scoring."""

    W: np.ndarray
    tau: np.ndarray
    weights: np.ndarray
    row_recording: np.ndarray
    row_time: np.ndarray
    full: list[np.ndarray]  # per recording (N·nv, nb)
    recorded: list[np.ndarray]  # per recording (N, nv)
    times: list[np.ndarray]  # per recording (N,)


def _rows(model, raw, terms, base, preprocess, problem_options) -> _Rows:
    prepared = [prepare_dataset(ds, preprocess, unwrap=free_angles(model)) for ds in raw]
    problem = IdentificationProblem.from_datasets(model, prepared, terms=terms, base=base, **problem_options)
    checked = [check_dataset(ds, model) for ds in prepared]
    times = [ds.t for ds in checked]
    sample_recording = np.concatenate([np.full(ds.n, i) for i, ds in enumerate(checked)])
    sample_time = np.concatenate(times)
    return _Rows(
        problem.W,
        problem.tau,
        problem.weights,
        sample_recording[problem.sample],
        sample_time[problem.sample],
        [base_regressor(model, terms, base, ds) for ds in checked],
        [recorded_torque(ds) for ds in checked],
        times,
    )


def _score(rows: _Rows, edges, spans, folds: int) -> np.ndarray:
    """Each fold's ``(squared error, squared recorded torque)`` sums of its held-out block's prediction
    against the torque as recorded, ``(folds, 2)``; NaN rows when a fold leaves too few rows to fit."""
    out = np.full((folds, 2), np.nan)
    for k in range(folds):
        held = np.zeros(len(rows.tau), dtype=bool)
        for i, e in enumerate(edges):
            held |= (rows.row_recording == i) & (rows.row_time >= e[k]) & (rows.row_time <= e[k + 1])
        train = ~held & (rows.weights > 0)
        if np.count_nonzero(train) <= rows.W.shape[1]:
            continue
        sw = np.sqrt(rows.weights[train])
        A = rows.W[train] * sw[:, None]
        s = np.linalg.norm(A, axis=0)
        s[s == 0] = 1.0
        theta = np.linalg.lstsq(A / s, rows.tau[train] * sw, rcond=None)[0] / s
        err2 = ref2 = 0.0
        for i, e in enumerate(edges):
            t = rows.times[i]
            lo, hi = max(e[k], spans[i][0]), min(e[k + 1], spans[i][1])
            pick = np.flatnonzero((t >= lo) & (t <= hi))
            if pick.size == 0:
                continue
            nv = rows.recorded[i].shape[1]
            W = rows.full[i].reshape(len(t), nv, -1)[pick]
            err2 += float(np.sum((W @ theta - rows.recorded[i][pick]) ** 2))
            ref2 += float(np.sum(rows.recorded[i][pick] ** 2))
        out[k] = err2, ref2
    return out
