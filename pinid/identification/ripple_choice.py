"""The ripple periods per joint revolution chosen by the training recordings (``--ripple-periods auto``).

A position ripple ``s·sin(k·r·q) + c·cos(k·r·q)`` (:mod:`pinid.model.terms_ripple`) needs ``r``: the motor's
pole or gear-tooth count times the reduction, which a user often does not know.  Each candidate of
:data:`CANDIDATES` (and the drives' ratio, when the robot has drives) is scored by the blocked
cross-validation of :mod:`pinid.identification.crossval` (held-out blocks of the training recordings, against
the torque as recorded); the best pooled score wins, one ``r`` for every joint.  The validation recordings
play no part.  The model without ripple is scored too: the choice says whether the ripple helps measurably
(wins on the held-out blocks, :func:`pinid.identification.crossval.better`), and ``identify`` leaves the ripple
terms out when it does not (issue 44: a choice is adopted only when it wins).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError
from pinid.identification.crossval import (
    FOLDS,
    better,
    block_edges,
    candidate_rows,
    common_spans,
    fold_scores,
    fold_sums,
)
from pinid.model.base import base_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.result_protocol import ResultProtocol, panel

#: Ripple periods per joint revolution tried (one for every joint): low orders (a position-periodic error of
#: the model or the sensors) and common reductions (one period per motor revolution).
CANDIDATES = (1, 2, 3, 4, 6, 8, 10, 12, 16, 20, 30, 50, 80, 100, 120, 160, 200)
#: The value of the model setting ``ripple_periods`` that asks for the choice.
AUTO = "auto"
#: The terms of the ripple family (:mod:`pinid.model.terms_ripple`).
RIPPLE_PREFIX = "ripple_"


@dataclass(frozen=True)
class RippleChoice(ResultProtocol):
    """The ripple periods chosen and the curve: ``candidates`` (periods per revolution), ``scores`` (pooled
    held-out relative RMS [%]); ``without``: the score without the ripple terms; ``helps``: the chosen one
    measurably better than none (:func:`pinid.identification.crossval.better`)."""

    periods: float
    candidates: list[float]
    scores: list[float]
    without: float
    helps: bool
    folds: int = FOLDS
    reasons: dict[str, str] = field(default_factory=dict)

    PLOTS = {"curve": True}

    def to_dict(self) -> dict:
        """Plain-JSON form (``identification.json``'s ``data.ripple_choice``)."""
        return {
            "chosen_by": f"{self.folds}-fold blocked cross-validation on the training recordings",
            "periods": self.periods,
            "candidates": list(self.candidates),
            "cv_rel_rms_percent": [None if not np.isfinite(s) else float(s) for s in self.scores],
            "without_ripple_percent": float(self.without),
            "measurably_better": bool(self.helps),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "RippleChoice":
        """Inverse of :meth:`to_dict` (the folds read from ``chosen_by``)."""
        scores = [float("nan") if s is None else float(s) for s in d["cv_rel_rms_percent"]]
        return cls(
            float(d["periods"]),
            [float(c) for c in d["candidates"]],
            scores,
            float(d["without_ripple_percent"]),
            bool(d["measurably_better"]),
            int(str(d["chosen_by"]).split("-", 1)[0]),
        )

    def text(self) -> str:
        """One line: the choice, its score and the score without ripple."""
        k = self.candidates.index(self.periods)
        verdict = "measurably better than" if self.helps else "not measurably better than"
        return (
            f"ripple periods per revolution {self.periods:g}, chosen by {self.folds}-fold blocked cross-validation "
            f"on the training recordings (held-out relative RMS {self.scores[k]:.3g} %, {verdict} "
            f"{self.without:.3g} % without ripple)"
        )

    def _plot(self, kind: str, ax):
        """``"curve"``: the held-out relative RMS [%] against the periods per revolution, the choice marked,
        the score without ripple dotted."""
        fig, ax = panel(ax)
        ok = np.isfinite(self.scores)
        ax.semilogx(np.array(self.candidates)[ok], np.array(self.scores)[ok], "o-", color="tab:blue")
        ax.axvline(self.periods, color="tab:red", ls="--", label=f"chosen: {self.periods:g}")
        ax.axhline(self.without, color="0.3", ls=":", label="without ripple")
        ax.set_xlabel("ripple periods per revolution")
        ax.set_ylabel("held-out rel. RMS [%]")
        ax.set_title("ripple periods by blocked cross-validation")
        ax.legend()
        fig.tight_layout()
        return fig


def is_auto(model: RobotModel) -> bool:
    """True when ``model`` asks for its ripple periods to be chosen (its setting ``ripple_periods`` is "auto")."""
    value = model.setting("ripple_periods")
    return isinstance(value, str) and value.strip().lower() == AUTO


def _ripple_terms(terms: TermSelection) -> list[str]:
    """The ripple terms among ``terms``' names."""
    return [n for n in terms.names if n.startswith(RIPPLE_PREFIX)]


def choose_ripple_periods(
    model: RobotModel,
    prepared: Sequence[Dataset],
    terms: TermSelection,
    *,
    fit_joints: Sequence[str] | None = None,
    problem_options: Mapping | None = None,
    candidates: Sequence[float] | None = None,
) -> RippleChoice:
    """Choose the ripple periods of ``terms``' ripple terms on the ``prepared`` training recordings (see the
    module text); SpecError when ``terms`` has no ripple term."""
    if not isinstance(model, RobotModel) or not isinstance(terms, TermSelection):
        raise SpecError("choose_ripple_periods: expected a RobotModel and a TermSelection")
    if not _ripple_terms(terms):
        raise SpecError("ripple periods 'auto' without a ripple term; expected --terms …,ripple (or ripple2, ripple3)")
    tried = list(candidates if candidates is not None else CANDIDATES)
    drives = getattr(model, "drives", None)
    if candidates is None and drives is not None:
        G = np.abs(np.asarray(drives.matrix, dtype=float))
        tried += [float(r) for r in np.unique(np.round(G.max(axis=0), 6)) if r > 0 and r not in tried]
    plain = TermSelection(names=[n for n in terms.names if not n.startswith(RIPPLE_PREFIX)])
    base_model = model.with_setting("ripple_periods", None)
    rows = [
        candidate_rows(
            base_model, prepared, plain, base_parameters(base_model, plain, joints=fit_joints), problem_options
        )
    ]
    usable, refused = [], []  # a period whose ripple columns these recordings cannot tell from the rest: no score
    for r in tried:
        m = model.with_setting("ripple_periods", float(r))
        try:
            rows.append(
                candidate_rows(m, prepared, terms, base_parameters(m, terms, joints=fit_joints), problem_options)
            )
            usable.append(r)
        except DataError as exc:
            if "rank-deficient" not in str(exc):
                raise
            refused.append((r, str(exc)))
    if not usable:
        r, why = refused[0]
        raise DataError(
            f"--ripple-periods auto: the training recordings cannot tell the ripple terms ({', '.join(_ripple_terms(terms))}) "
            f"from the other parameters at any candidate period (at {r:g}: {why}); record longer or with more motion, "
            "give --ripple-periods R, or leave the ripple terms out"
        )
    edges = block_edges(prepared)
    spans = common_spans(rows)
    sums = np.array([fold_sums(c, edges, spans) for c in rows])
    pooled, per_fold = fold_scores(sums)
    scores = dict(zip(usable, pooled[1:]))
    k = int(np.nanargmin(pooled[1:])) + 1
    return RippleChoice(
        periods=float(usable[k - 1]),
        candidates=[float(r) for r in tried],
        scores=[float(scores.get(r, np.nan)) for r in tried],
        without=float(pooled[0]),
        helps=better(per_fold[k], per_fold[0]),
    )
