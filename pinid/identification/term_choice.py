"""The joint terms chosen by the data: forward selection by blocked cross-validation (``--terms auto``).

Which friction and offset terms a real drive needs is not known in advance: on a 7-DOF arm with joint
torque sensors, a constant offset per joint takes the validation error from 25.7 % to 4.2 %, and only a
user who already knew would ask for it.  ``terms="auto"`` starts from Coulomb and viscous friction and, one
step at a time, adds the candidate term that lowers the held-out error of the training recordings most
(:mod:`pinid.identification.crossval`: blocked folds, OLS, scored against the torque as recorded), as long
as the improvement is measurable (more than two standard errors of the paired fold-by-fold difference):
a term that only fits noise does not get in.  Of candidates the data cannot tell apart (a constant offset
with Coulomb friction spans the directional Coulomb pair), the one listed first in :data:`STEPS` is taken.  The validation recording is never looked at.

Candidates (joint side): ``offset`` (constant torque), ``armature`` (rotor inertia), ``fs`` (Stribeck
friction with the model's shape, on top of Coulomb) and the directional Coulomb pair ``fc_pos``/``fc_neg``
in place of ``fc``.  Motor-side terms need drives and are not tried.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from pinid.data.dataset import Dataset
from pinid.errors import DataError
from pinid.identification.crossval import (
    FOLDS,
    block_edges,
    better,
    candidate_rows,
    common_spans,
    fold_scores,
    fold_sums,
    not_worse,
)
from pinid.model.base import base_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.result_protocol import ResultProtocol, panel

#: Where the selection starts.
START: tuple[str, ...] = ("fc", "fv")
#: Each step's candidate changes: a term added, or (for the directional pair) a term replaced.
STEPS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("offset", ("offset",)),
    ("armature", ("armature",)),
    ("fs", ("fs",)),
    ("fc_pos,fc_neg", ("fc_pos", "fc_neg")),
)


@dataclass(frozen=True)
class TermsChoice(ResultProtocol):
    """The terms chosen and each step's candidates with their held-out relative RMS [%]."""

    terms: list[str]
    steps: list[dict[str, float]] = field(default_factory=list)
    folds: int = FOLDS

    PLOTS = {"steps": True}

    def to_dict(self) -> dict:
        """Plain-JSON form (``identification.json``'s ``data.terms_choice``)."""
        return {
            "chosen_by": f"forward selection, {self.folds}-fold blocked cross-validation on the training recordings",
            "terms": list(self.terms),
            "steps": [{k: (None if not np.isfinite(v) else float(v)) for k, v in s.items()} for s in self.steps],
        }

    def text(self) -> str:
        """One line: the terms and the held-out error of each step's best candidate."""
        path = " → ".join(f"{min(s, key=s.get)} {min(s.values()):.3g} %" for s in self.steps)
        return f"terms {','.join(self.terms)}, chosen by forward selection on the training recordings ({path})"

    @classmethod
    def from_dict(cls, d: dict) -> "TermsChoice":
        """Inverse of :meth:`to_dict` (the folds read from ``chosen_by``)."""
        folds = int(str(d["chosen_by"]).split(", ", 1)[1].split("-", 1)[0])
        steps = [{k: float("nan") if v is None else float(v) for k, v in s.items()} for s in d["steps"]]
        return cls([str(t) for t in d["terms"]], steps, folds)

    def _plot(self, kind: str, ax):
        """``"steps"``: every candidate's held-out relative RMS [%] per step, the step's best joined."""
        fig, ax = panel(ax)
        for i, step in enumerate(self.steps):
            v = [x for x in step.values() if np.isfinite(x)]
            ax.plot([i] * len(v), v, "o", color="0.6")
        best = [min(s.values()) for s in self.steps]
        ax.plot(range(len(best)), best, "o-", color="tab:red", label="best of the step")
        labels = [min(s, key=s.get) for s in self.steps]
        ax.set_xticks(range(len(labels)), labels, fontsize=8)
        ax.set_ylabel("held-out rel. RMS [%]")
        ax.set_title(f"terms by forward selection: {', '.join(self.terms)}")
        ax.legend()
        fig.tight_layout()
        return fig


def _apply(names: list[str], change: tuple[str, ...]) -> list[str] | None:
    """The term names after one step's change, or None when it does not apply."""
    if any(c in names for c in change):
        return None
    if change == ("fc_pos", "fc_neg"):
        if "fc" not in names:
            return None
        k = names.index("fc")
        return [*names[:k], "fc_pos", "fc_neg", *names[k + 1 :]]
    if change == ("fs",) and "fc" not in names:
        return None
    return [*names, *change]


def choose_terms(
    model: RobotModel,
    prepared: Sequence[Dataset],
    *,
    fit_joints: Sequence[str] | None = None,
    problem_options=None,
    folds: int = FOLDS,
) -> TermsChoice:
    """Forward selection of the joint terms on prepared training recordings (module text).
    ``fit_joints``: the joints whose rows are fitted (the base parameters follow); ``problem_options``:
    ``rest_velocity``, ``rest_fraction``, ``fit_joints`` as the identification uses them."""
    prepared = list(prepared)
    edges = block_edges(prepared, folds)

    def sums_of(names: list[str]) -> np.ndarray:
        terms = TermSelection(names=names)
        base = base_parameters(model, terms, joints=None if fit_joints is None else list(fit_joints))
        rows = candidate_rows(model, prepared, terms, base, problem_options)
        return fold_sums(rows, edges, common_spans([rows]))

    names = list(START)
    scores, per_fold = fold_scores(sums_of(names)[None])
    current, current_score = per_fold[0], float(scores[0])
    steps = [{",".join(names): current_score}]
    while True:
        tried: dict[str, tuple[list[str], float, np.ndarray]] = {}
        for label, change in STEPS:
            after = _apply(names, change)
            if after is None:
                continue
            try:
                s, f = fold_scores(sums_of(after)[None])
            except DataError:  # a term the data cannot tell from another (rank-deficient): not a candidate
                continue
            tried[label] = (after, float(s[0]), f[0])
        if not tried:
            break
        steps.append({f"+{k}": v[1] for k, v in tried.items()})
        lowest = min(tried, key=lambda k: tried[k][1])
        # of candidates the data cannot tell apart (offset + Coulomb spans directional Coulomb), the first listed
        label = next(k for k in tried if k == lowest or not_worse(tried[k][2], tried[lowest][2]))
        after, score, folds_of = tried[label]
        if not better(folds_of, current):
            break
        names, current, current_score = after, folds_of, score
    return TermsChoice(names, steps, folds)
