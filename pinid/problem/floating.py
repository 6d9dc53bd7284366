"""The identification problem of a floating-base robot with contacts (docs/floating-base.md).

Per sample the free-flyer equations of motion, linear in the standard parameters θ (base link first):

    W(q, v, a) θ = [0₆; τ] + Σ_c J_cᵀ f_c

* **base rows** (6: force, then moment on the base link, base frame): no joint torque in them, only the
  contact wrenches ``f_c`` and the motion (Ayusawa, Venture & Nakamura 2014).  What a wearer's exoskeleton
  without joint torque sensors, or a walking robot with force plates, gives.
* **joint rows** (n): the joint torques with the wrenches' ``J_cᵀ f_c`` moved to the right-hand side.

``rows`` picks ``"all"`` (both), ``"base"`` or ``"joints"``; the base parameters are those of the rows used
(:func:`pinid.model.base.base_parameters` with ``rows``).  Weighting: every joint row has weight 1 and every
base row ``base_weight`` (default 1: plain least squares in SI units, N and N·m alike); WLS
(``weighting="joint"``) re-weights per body, the 6 base rows together counting as the body ``base``.

The result is an ordinary :class:`~pinid.problem.problem.IdentificationProblem` whose ``model`` is the
robot's body view (:func:`pinid.model.floating.body_view`: ``base`` then the joints), so every estimator,
the SDP with its pseudo-inertia LMI on every body (the base link included) among them, takes it unchanged.
Its rows are rebuilt block by block (:class:`FloatingRows`); joint rows at rest are kept unless
``rest_velocity`` says otherwise.

Legs without force sensing (contact phases, no wrench: :func:`swing_rows`): while such a foot is in contact
its unknown wrench enters the base rows and the rows of its leg's joints; those rows are left out at those
samples, so the leg's joint rows come from its swing phases and the base rows from the samples where every
foot in contact is measured.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pinid.data.contacts import FloatingSamples
from pinid.errors import DataError
from pinid.problem.problem import IdentificationProblem
from pinid.problem.rows import rest_thresholds
from pinid.model.base import BaseParameters, base_parameters
from pinid.model.floating import BASE_NV, FloatingRobotModel, as_floating, contact_forces, row_mask
from pinid.model.regressor import regressor, standard_parameters
from pinid.model.terms import TermSelection, as_terms

_CHUNK = 2000  # samples per regressor block (2000 × (6 + n) rows × p columns of the standard regressor)


@dataclass
class FloatingRows:
    """What rebuilds the rows of a floating problem's base regressor (duck-types
    :class:`~pinid.problem.problem.RegressorRows`)."""

    model: FloatingRobotModel
    terms: TermSelection
    base: BaseParameters
    samples: list[FloatingSamples]
    keeps: list[np.ndarray]  # per recording (N, 6 + n) booleans: the rows used
    chunk: ClassVar[int] = _CHUNK  # samples per block of blocks()

    @property
    def datasets(self) -> list:
        """The recordings' joint data (their lengths bound the HAC windows, :mod:`pinid.problem.covariance`)."""
        return [s.data for s in self.samples]

    @property
    def count(self) -> int:
        return sum(int(k.sum()) for k in self.keeps)

    def blocks(self, *, bar=None) -> Iterator[tuple[int, np.ndarray]]:
        row = 0
        for s, keep in zip(self.samples, self.keeps):
            for start in range(0, s.n, _CHUNK):
                sl = slice(start, min(s.n, start + _CHUNK))
                state = (s.base_q[sl], s.base_v[sl], s.base_a[sl], s.data.q[sl], s.data.dq[sl], s.data.ddq[sl])
                W = regressor(self.model, *self.model.full_state(*state), self.terms)
                k = sl.stop - sl.start
                rows = keep[sl].reshape(-1)
                if rows.all():
                    Wk = np.take(W, self.base.independent, axis=1)
                else:  # rows and columns picked in one copy
                    Wk = W[np.ix_(np.flatnonzero(rows), self.base.independent)]
                yield row, Wk
                row += len(Wk)
                if bar is not None:
                    bar.update(k)

    def build(self) -> np.ndarray:
        W = np.empty((self.count, self.base.count))
        for row, Wk in self.blocks():
            W[row : row + len(Wk)] = Wk
        return W


#: The weights of the base rows accepted [-]: the Gram matrix squares them, and beyond 1e6 (or below 1e-6)
#: the joint rows' columns (friction) fall below the rank tolerance and read as "not excited".
BASE_WEIGHT_RANGE = (1e-6, 1e6)


def floating_targets(model: FloatingRobotModel, s: FloatingSamples) -> np.ndarray:
    """``[0₆; τ] + Σ J_cᵀ f_c`` ``(N, 6 + n)``: the right-hand side of every row (τ taken as 0 when not measured)."""
    y = np.zeros((s.n, BASE_NV + model.nv))
    if s.data.tau is not None:
        y[:, BASE_NV:] = s.data.tau
    if s.wrenches:
        y += contact_forces(model, s.base_q, s.data.q, s.wrenches)
    return y


def swing_rows(model: FloatingRobotModel, s: FloatingSamples, mask: np.ndarray) -> np.ndarray:
    """(N, 6 + n) booleans: the rows of ``mask`` (one sample's row set) that no unknown wrench enters.  A link
    in contact without a measured wrench (``s.unsensed``: a leg without force sensing) takes out, at those
    samples, the 6 base rows and the rows of the joints that support it; its leg's rows stay in swing.  So does a
    measured wrench where its link's contact phase is uncertain (``s.uncertain``: neither clearly 0 nor 1)."""
    keep = np.broadcast_to(mask, (s.n, len(mask))).copy()
    m = model.ff_model
    for link, contact in [*s.unsensed.items(), *getattr(s, "uncertain", {}).items()]:
        rows = np.zeros(len(mask), bool)
        for jid in m.supports[m.frames[model.frame_id(link)].parentJoint]:
            if jid > 0:
                j = m.joints[jid]
                rows[j.idx_v : j.idx_v + j.nv] = True
        keep[np.ix_(contact, rows)] = False
    return keep


def floating_problem(
    model: FloatingRobotModel,
    samples: FloatingSamples | Sequence[FloatingSamples],
    *,
    terms: TermSelection = TermSelection(),
    rows: str = "all",
    base_weight: float = 1.0,
    base: BaseParameters | None = None,
    rest_velocity: float | Sequence[float] | str | None = None,
) -> IdentificationProblem:
    """Stack prepared floating recordings into an identification problem (see the module text).

    DataError when joint rows are asked for and a recording has no joint torque, or when the data do not
    excite every base parameter (:meth:`IdentificationProblem.check`).  ``rest_velocity``: None (default) keeps
    every row; "auto", a number or one per joint [rad/s] leaves out, with Coulomb friction in the model, a joint's row where
    its speed is below max(2 % of its peak, 3 σ of its velocity noise) or that number, as for a fixed base (the
    base rows never).  On the twin, whose Coulomb friction switches exactly at zero speed, "auto" validated
    worse (1.07 × the noise floor instead of 1.00), so it is not the default here."""
    model = as_floating(model)
    terms = as_terms(terms)
    if isinstance(samples, FloatingSamples):
        samples = [samples]
    samples = list(samples)
    if not samples:
        raise DataError("no recording given, expected at least one floating recording")
    mask = row_mask(model.nv, rows)
    if rows == "base":
        terms = TermSelection.from_names("none")  # no joint term enters the base rows
    if not (np.isfinite(base_weight) and BASE_WEIGHT_RANGE[0] <= base_weight <= BASE_WEIGHT_RANGE[1]):
        raise DataError(
            f"base_weight={base_weight!r} is out of range, expected a number in [{BASE_WEIGHT_RANGE[0]:g}, "
            f"{BASE_WEIGHT_RANGE[1]:g}] (a weight beyond it drowns the joint rows in rounding)"
        )
    for s in samples:
        if rows != "base" and s.data.tau is None:
            raise DataError(
                f"{s.source}: no joint torque (tau_<joint> columns); without it only the base rows can be used "
                "(rows='base', --rows base: contact wrenches and motion)"
            )
    base = base if base is not None else base_parameters(model, terms, rows=rows)
    width = BASE_NV + model.nv
    body = np.r_[np.zeros(BASE_NV, int), np.arange(1, model.nv + 1)]
    weight_row = np.r_[np.full(BASE_NV, float(base_weight)), np.ones(model.nv)]
    ys, joints, sample_idx, weights, keeps = [], [], [], [], []
    offset = 0
    for s in samples:
        always = [link for link, contact in s.unsensed.items() if len(contact) and np.all(contact)]
        if always:
            raise DataError(
                f"{s.source}: {', '.join(always)} in contact in every sample without a measured wrench "
                "(--swing-rows): the base rows and that leg's joint rows are all left out (in contact, not at "
                "rest); expected a recording where the leg swings, or its wrench"
            )
        keep = swing_rows(model, s, mask)
        if terms.coulomb and rest_velocity is not None and rest_velocity != 0:
            if isinstance(rest_velocity, str):
                v = rest_thresholds(s.data.dq)
            else:
                v = np.broadcast_to(np.asarray(rest_velocity, dtype=float), (model.nv,))
            keep[:, BASE_NV:] &= np.abs(s.data.dq) >= v
        ys.append(floating_targets(model, s)[keep])
        joints.append(np.broadcast_to(body, (s.n, width))[keep])
        sample_idx.append(offset + np.broadcast_to(np.arange(s.n)[:, None], (s.n, width))[keep])
        weights.append(np.broadcast_to(weight_row, (s.n, width))[keep])
        keeps.append(keep)
        offset += s.n
    y = np.concatenate(ys)
    peak = np.r_[
        max(float(np.abs(s.base_v[:, 3:]).max()) for s in samples),
        np.max([np.abs(s.data.dq).max(axis=0) for s in samples], axis=0),
    ]
    problem = IdentificationProblem(
        model.bodies,
        terms,
        base,
        None,
        y,
        np.concatenate(joints),
        np.concatenate(sample_idx),
        np.concatenate(weights),
        standard_parameters(model, terms),
        samples=offset,
        sources=[s.source for s in samples],
        sample_rates=[s.data.sample_rate for s in samples],
        peak_velocity=peak,
        regressor_rows=FloatingRows(model, terms, base, samples, keeps),
    )
    problem.check()
    return problem
