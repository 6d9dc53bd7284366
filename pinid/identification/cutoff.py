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
   keeps after its trimming, so all candidates are scored on the same samples.  The blocks divide that
   common span (not the raw recording), so every block is scored; a candidate whose trimming (the filter's
   settling, longer at low cut-offs) leaves less than :data:`MIN_KEPT` of a recording is skipped with that
   reason — before issue 44 the 1 Hz candidate's 3 s at each end emptied the first and last of five blocks
   of a 10 s recording for every candidate;
4. the score of a candidate is the pooled relative RMS over all folds; the choice is the **highest**
   cut-off that is not measurably worse than the lowest-scoring one: its fold-by-fold excess over it within
   the paired t test's margin (:func:`pinid.identification.crossval.not_worse`, Student's t for the number
   of blocks) **and** its pooled score within :data:`TOLERANCE` of the lowest.  The second condition is what
   keeps the rule honest with few blocks, where a t test cannot tell much apart (three blocks let 30 Hz at
   8.1 % pass for 7 Hz at 2.7 %).  On the flat bottom of the curve this takes the least smoothing: a cut-off
   lower than needed removes motion that a faster trajectory than the training one has.  Measured
   (``tests/benchmarks/bench_cutoff.py``): the lowest score alone picked 3 Hz on a 5 kHz twin whose
   held-out best is 30 Hz (a curve flat to 1 % from 3 to 30 Hz).

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
from pinid.data.preprocess import Preprocessing
from pinid.errors import DataError, DataWarning, SpecError
from pinid.model.base import BaseParameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.identification.crossval import (
    FOLDS,
    candidate_rows,
    common_spans,
    fold_scores,
    fold_sums,
    not_worse,
)
from pinid.problem.recordings import free_angles, prepare_dataset
from pinid.result_protocol import ResultProtocol, panel

#: Candidate cut-offs [Hz] (about three per decade); those the sample rate cannot carry are left out.
GRID_HZ: tuple[float, ...] = (1.0, 1.5, 2.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0, 50.0, 70.0, 100.0, 150.0, 200.0)
#: Highest candidate as a fraction of the Nyquist frequency (the filter refuses above 0.8).
MAX_NYQUIST_FRACTION = 0.4
#: A candidate must keep at least this fraction of every recording after its trimming to be scored.
MIN_KEPT = 0.6
#: A higher cut-off is taken only when its pooled held-out score is within this fraction of the lowest.
TOLERANCE = 0.02


@dataclass(frozen=True)
class CutoffChoice(ResultProtocol):
    """The cut-off [Hz] chosen and the cross-validation curve it was chosen on.

    ``candidates`` [Hz] and ``scores`` (pooled relative RMS [%] of the held-out blocks against the torque
    as recorded; NaN where a candidate could not be used, ``reasons`` says why)."""

    cutoff: float
    candidates: list[float]
    scores: list[float]
    folds: int
    reasons: dict[str, str] = field(default_factory=dict)

    PLOTS = {"curve": True}

    def to_dict(self) -> dict:
        """Plain-JSON form (``identification.json``'s ``data.cutoff``)."""
        return {
            "chosen_by": f"{self.folds}-fold blocked cross-validation on the training recordings",
            "cutoff_hz": self.cutoff,
            "candidates_hz": list(self.candidates),
            "cv_rel_rms_percent": [None if not np.isfinite(s) else float(s) for s in self.scores],
            "skipped": dict(self.reasons),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "CutoffChoice":
        """Inverse of :meth:`to_dict` (the folds read from ``chosen_by``)."""
        folds = int(str(d["chosen_by"]).split("-", 1)[0])
        scores = [float("nan") if s is None else float(s) for s in d["cv_rel_rms_percent"]]
        return cls(
            float(d["cutoff_hz"]), [float(c) for c in d["candidates_hz"]], scores, int(folds), dict(d["skipped"])
        )

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

    def _plot(self, kind: str, ax):
        """``"curve"``: the cross-validation curve (score against cut-off, log axis), the choice marked."""
        fig, ax = panel(ax)
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
    preprocess: "Preprocessing | Mapping | None" = None,
    problem_options: Mapping | None = None,
    candidates: Sequence[float] | None = None,
    folds: int = FOLDS,
) -> CutoffChoice:
    """The cut-off [Hz] the training ``recordings`` (paths or Datasets) choose by blocked cross-validation
    (module text).  ``preprocess``: the other preprocessing options (a Preprocessing or its dict form); ``problem_options``: ``rest_velocity``,
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
    given = Preprocessing.normalize(preprocess)
    options = {k: v for k, v in (given if isinstance(given, dict) else {}).items() if k != "cutoff"}
    fits, reasons, unwrap = {}, {}, free_angles(model)
    for c in candidates:
        try:
            with warnings.catch_warnings():  # a candidate's own warnings ("content above the cut-off") are its score's
                warnings.simplefilter("ignore", DataWarning)
                prepared = [prepare_dataset(ds, {**options, "cutoff": c}, unwrap=unwrap) for ds in raw]
            kept = min((p.t[-1] - p.t[0]) / max(r.t[-1] - r.t[0], 1e-300) for p, r in zip(prepared, raw))
            if kept < MIN_KEPT:
                reasons[f"{c:g}"] = (
                    f"its trimming keeps {100 * kept:.0f} % of a recording, expected at least {100 * MIN_KEPT:.0f} %"
                    " (a longer recording)"
                )
                continue
            fits[c] = candidate_rows(model, prepared, terms, base, problem_options)
        except (DataError, SpecError) as exc:
            reasons[f"{c:g}"] = str(exc)
    if not fits:
        raise DataError(f"cut-off auto: no candidate cut-off could be used ({next(iter(reasons.values()))})")
    spans = common_spans(list(fits.values()))
    edges = [np.linspace(lo, hi, folds + 1) for lo, hi in spans]  # the blocks of what every candidate keeps
    nan = np.full((folds, 2), np.nan)
    sums = np.array([fold_sums(fits[c], edges, spans) if c in fits else nan for c in candidates])
    scores, per_fold = fold_scores(sums)
    if not np.any(np.isfinite(scores)):
        raise DataError("cut-off auto: no candidate left a held-out block to score (recordings too short)")
    best = int(np.nanargmin(scores))
    kept = [best] + [
        c
        for c in range(len(candidates))
        if scores[c] <= (1 + TOLERANCE) * scores[best] and not_worse(per_fold[c], per_fold[best])
    ]
    return CutoffChoice(candidates[max(kept)], candidates, [float(x) for x in scores], folds, reasons)
