"""The joint terms chosen by the data: forward selection by blocked cross-validation (``--terms auto``), and
the default terms (``--terms`` not given: Coulomb and viscous friction, and a constant offset when the training
recordings' held-out blocks say it wins).

Which friction and offset terms a real drive needs is not known in advance: on a 7-DOF arm with joint
torque sensors, a constant offset per joint takes the validation error from 25.7 % to 4.2 %, and only a
user who already knew would ask for it.  ``terms="auto"`` starts from Coulomb and viscous friction — with
drives, also the motor-side Coulomb, viscous friction and rotor inertia (:data:`DRIVE_START`), and any term
the user adds (``"auto,motor_offset"``) — and, one step at a time, adds the candidate term that lowers the
held-out error of the training recordings most (:mod:`pinid.identification.crossval`: blocked folds, OLS,
scored against the torque as recorded), as long as it **wins** on the held-out blocks
(:func:`pinid.identification.crossval.better`: by more than the paired t test's margin on their spread, and
by at least 1 % of the score).  A candidate whose held-out blocks score above 100 % (a fit that did not
converge: a Stribeck column nearly collinear with Coulomb's) is rejected as such and listed, not scored.
Of candidates the data cannot tell apart (a constant offset with Coulomb friction spans the directional
Coulomb pair), the one listed first in :data:`STEPS` is taken.  The validation recording is never looked at.

Candidates (joint side): ``offset`` (constant torque), ``armature`` (rotor inertia), ``fs`` (Stribeck
friction with the model's shape, on top of Coulomb) and the directional Coulomb pair ``fc_pos``/``fc_neg``
in place of ``fc``; with drives also ``motor_offset``.

The default (:func:`choose_default_terms`, ``terms="default"``, what ``pinid identify`` uses without
``--terms``) is the first step of that selection with one candidate: ``fc,fv``, and ``offset`` added when it
wins on the held-out blocks.  Measured on real recordings (docs/identification.md, "The default terms"): a
torque-sensing arm keeps it, the double pendulum's current-based torques do not, and a fixed ``fc,fv,offset``
would have lost 4 points there.  Its cost: one cross-validation of two candidates.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError
from pinid.identification.crossval import (
    FOLDS,
    CandidateRows,
    block_edges,
    better,
    candidate_rows,
    common_spans,
    fold_scores,
    fold_sums,
    not_worse,
    unstable,
)
from pinid.model.base import base_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.result_protocol import ResultProtocol, panel

#: Where the selection starts.
START: tuple[str, ...] = ("fc", "fv")
#: The default terms' offset test holds its candidates' rows whole: above this many training samples it runs on
#: every k-th sample (the blocks stay contiguous in time), so that its memory stays bounded whatever the length
#: of the recordings (the identification itself streams its regressor; docs/data.md "Memory").  The shipped
#: real recordings are below it (KUKA Med7 70 %: 7 000 samples; two double-pendulum runs: 10 000).
CV_SAMPLES = 12_000
#: What the selection starts from besides, on a robot with drives: the motor side's friction and rotor inertia.
DRIVE_START: tuple[str, ...] = ("motor_fc", "motor_fv", "motor_armature")
#: The value of ``terms`` that asks for the default terms (:func:`choose_default_terms`).
DEFAULT = "default"
#: Each step's candidate changes: a term added, or (for the directional pair) a term replaced.
STEPS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("offset", ("offset",)),
    ("armature", ("armature",)),
    ("fs", ("fs",)),
    ("fc_pos,fc_neg", ("fc_pos", "fc_neg")),
)
#: Candidates tried besides on a robot with drives.
DRIVE_STEPS: tuple[tuple[str, tuple[str, ...]], ...] = (("motor_offset", ("motor_offset",)),)


def parse_auto(terms) -> list[str] | None:
    """The terms added to ``"auto"`` (``"auto,motor_fc"`` → ``["motor_fc"]``, ``"auto"`` → ``[]``), or None
    when ``terms`` does not ask for the choice; SpecError for an unknown added name."""
    if not isinstance(terms, str):
        return None
    names = [n.strip() for n in terms.split(",") if n.strip()]
    if not names or names[0].lower() != "auto":
        return None
    extra = names[1:]
    if any(n.lower() == "auto" for n in extra):
        raise SpecError(f"terms {terms!r}: 'auto' once, first, then the terms to keep (auto,motor_fc,…)")
    return TermSelection(names=extra).names if extra else []


def is_default(terms) -> bool:
    """True for the text ``"default"`` (any case): the default terms, chosen by :func:`choose_default_terms`."""
    return isinstance(terms, str) and terms.strip().lower() == DEFAULT


def has_drives(model: RobotModel) -> bool:
    """True when ``model`` has motors (a URDF ``<transmission>`` or a drives file) whose names motor terms can
    use (a motor named like a joint, as the double pendulum's URDF does, cannot carry motor terms)."""
    from pinid.model.drives import check_motor_names

    drives = getattr(model, "drives", None)
    if drives is None or not len(getattr(drives, "motor_names", [])):
        return False
    try:
        check_motor_names(list(drives.motor_names), list(model.joint_names), "drives")
    except SpecError:
        return False
    return True


@dataclass(frozen=True)
class TermsChoice(ResultProtocol):
    """The terms chosen and each step's candidates with their held-out relative RMS [%]."""

    terms: list[str]
    steps: list[dict[str, float]] = field(default_factory=list)
    folds: int = FOLDS
    #: Candidates not scored, with why (a fit that did not converge on the held-out blocks).
    rejected: dict[str, str] = field(default_factory=dict)
    #: How the terms were chosen: "auto" (forward selection) or "default" (fc,fv, offset when it wins).
    kind: str = "auto"

    PLOTS = {"steps": True}

    def to_dict(self) -> dict:
        """Plain-JSON form (``identification.json``'s ``data.terms_choice``)."""
        how = "forward selection" if self.kind == "auto" else "default terms (offset kept when it wins)"
        return {
            "chosen_by": f"{how}, {self.folds}-fold blocked cross-validation on the training recordings",
            "terms": list(self.terms),
            "steps": [{k: (None if not np.isfinite(v) else float(v)) for k, v in s.items()} for s in self.steps],
            "rejected": dict(self.rejected),
        }

    def text(self) -> str:
        """One line: the terms and the held-out error of each step's best candidate."""

        def best(s):
            ok = {k: v for k, v in s.items() if np.isfinite(v)}
            return f"{min(ok, key=ok.get)} {min(ok.values()):.3g} %" if ok else "no candidate scored"

        path = " → ".join(best(s) for s in self.steps)
        how = "forward selection" if self.kind == "auto" else "the default rule (offset kept when it wins)"
        line = f"terms {','.join(self.terms)}, chosen by {how} on the training recordings ({path})"
        if self.rejected:
            line += "; not scored: " + "; ".join(f"{k} ({v})" for k, v in self.rejected.items())
        return line

    @classmethod
    def from_dict(cls, d: dict) -> "TermsChoice":
        """Inverse of :meth:`to_dict` (the folds read from ``chosen_by``)."""
        how, rest = str(d["chosen_by"]).split(", ", 1)
        folds = int(rest.split("-", 1)[0])
        steps = [{k: float("nan") if v is None else float(v) for k, v in s.items()} for s in d["steps"]]
        kind = "auto" if how == "forward selection" else "default"
        return cls([str(t) for t in d["terms"]], steps, folds, dict(d.get("rejected") or {}), kind)

    def _plot(self, kind: str, ax):
        """``"steps"``: every candidate's held-out relative RMS [%] per step, the step's best joined."""
        fig, ax = panel(ax)
        for i, step in enumerate(self.steps):
            v = [x for x in step.values() if np.isfinite(x)]
            ax.plot([i] * len(v), v, "o", color="0.6")
        ok = [{k: v for k, v in s.items() if np.isfinite(v)} or {"—": np.nan} for s in self.steps]
        best = [min(s.values()) for s in ok]
        ax.plot(range(len(best)), best, "o-", color="tab:red", label="best of the step")
        labels = [min(s, key=s.get) for s in ok]
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
    keep: Sequence[str] = (),
    steps: Sequence[tuple[str, tuple[str, ...]]] | None = None,
    kind: str = "auto",
) -> TermsChoice:
    """Forward selection of the joint terms on prepared training recordings (module text).
    ``fit_joints``: the joints whose rows are fitted (the base parameters follow); ``problem_options``:
    ``rest_velocity``, ``rest_fraction``, ``fit_joints`` as the identification uses them; ``keep``: terms
    the selection starts from besides :data:`START` (and, with drives, :data:`DRIVE_START`); ``steps``: the
    candidates (default :data:`STEPS`, and :data:`DRIVE_STEPS` with drives); ``kind``: what the result says
    it was ("auto" or "default")."""
    prepared = list(prepared)
    edges = block_edges(prepared, folds)
    drives = has_drives(model)
    if steps is None:
        steps = (*STEPS, *DRIVE_STEPS) if drives else STEPS
    start = [*START, *(DRIVE_START if drives else ()), *keep]
    names = TermSelection(names=start).names

    def sums_of(names: list[str]) -> np.ndarray:
        terms = TermSelection(names=names)
        base = base_parameters(model, terms, joints=None if fit_joints is None else list(fit_joints))
        rows = candidate_rows(model, prepared, terms, base, problem_options)
        return fold_sums(rows, edges, common_spans([rows]))

    scores, per_fold = fold_scores(sums_of(names)[None])
    current, current_score = per_fold[0], float(scores[0])
    history = [{",".join(names): current_score}]
    rejected: dict[str, str] = {}
    while True:
        tried: dict[str, tuple[list[str], float, np.ndarray]] = {}
        step: dict[str, float] = {}
        for label, change in steps:
            after = _apply(names, change)
            if after is None:
                continue
            try:
                s, f = fold_scores(sums_of(TermSelection(names=after).names)[None])
            except DataError:  # a term the data cannot tell from another (rank-deficient): not a candidate
                continue
            if unstable(f[0]):  # a fit that did not converge on the held-out blocks: reported, not scored
                worst = float(np.nanmax(f[0]))
                rejected[f"+{label}"] = f"held-out block at {worst:.3g} %: the fit did not converge"
                step[f"+{label}"] = float("nan")
                continue
            tried[label] = (TermSelection(names=after).names, float(s[0]), f[0])
            step[f"+{label}"] = float(s[0])
        if step:
            history.append(step)
        if not tried:
            break
        lowest = min(tried, key=lambda k: tried[k][1])
        # of candidates the data cannot tell apart (offset + Coulomb spans directional Coulomb), the first listed
        label = next(k for k in tried if k == lowest or not_worse(tried[k][2], tried[lowest][2]))
        after, score, folds_of = tried[label]
        if not better(folds_of, current):
            break
        names, current, current_score = after, folds_of, score
    return TermsChoice(names, history, folds, rejected, kind)


def choose_default_terms(
    model: RobotModel,
    prepared: Sequence[Dataset],
    *,
    fit_joints: Sequence[str] | None = None,
    problem_options=None,
    folds: int = FOLDS,
) -> TermsChoice:
    """The default terms (module text): ``fc,fv``, and ``offset`` when it wins on the held-out blocks of the
    prepared training recordings (joint side, with drives or without: motor terms are never added by default), on
    at most :data:`CV_SAMPLES` of their samples."""
    prepared = list(prepared)
    step = -(-sum(len(ds.t) for ds in prepared) // CV_SAMPLES)  # ceil
    if step > 1:
        prepared = [ds.select(slice(None, None, step)) for ds in prepared]
    try:
        return _default_terms(model, prepared, fit_joints, problem_options, folds)
    except DataError as exc:  # too few rows, a rank-deficient candidate: fc,fv, and the identification says why
        return TermsChoice(list(START), [], folds, {"+offset": f"not tried: {exc}"}, "default")


def _default_terms(model, prepared, fit_joints, problem_options, folds) -> TermsChoice:
    """:func:`choose_default_terms`' test (DataError from the rows of a candidate as they come)."""
    joints = None if fit_joints is None else list(fit_joints)
    with_offset = TermSelection(names=[*START, "offset"])
    base, plain = (
        base_parameters(model, with_offset, joints=joints),
        base_parameters(model, TermSelection(), joints=joints),
    )
    keep = [k for k, n in enumerate(base.names) if not n.endswith(".offset")]
    if [base.names[k] for k in keep] != list(plain.names):  # the offset merged with another column: fit both
        return choose_terms(
            model,
            prepared,
            fit_joints=fit_joints,
            problem_options=problem_options,
            folds=folds,
            steps=(("offset", ("offset",)),),
            kind="default",
        )
    # one regressor for both candidates: fc,fv's base columns are fc,fv,offset's without the offset columns (and
    # the rows fitted are the same: Coulomb friction decides which rows at rest are left out, in both)
    rows = candidate_rows(model, prepared, with_offset, base, problem_options)
    without = CandidateRows(
        rows.W[:, keep],
        rows.tau,
        rows.weights,
        rows.row_recording,
        rows.row_time,
        [f[:, keep] for f in rows.full],
        rows.recorded,
        rows.times,
    )
    edges, spans = block_edges(prepared, folds), common_spans([rows])
    scores, per_fold = fold_scores(np.array([fold_sums(without, edges, spans), fold_sums(rows, edges, spans)]))
    names, history, rejected = list(START), [{",".join(START): float(scores[0])}], {}
    if unstable(per_fold[1]):
        rejected["+offset"] = f"held-out block at {float(np.nanmax(per_fold[1])):.3g} %: the fit did not converge"
        history.append({"+offset": float("nan")})
    else:
        history.append({"+offset": float(scores[1])})
        if better(per_fold[1], per_fold[0]):
            names = with_offset.names
    return TermsChoice(names, history, folds, rejected, "default")
