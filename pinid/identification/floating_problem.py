"""The identification problem of a floating-base robot with contacts (docs/floating-base.md).

Per sample the free-flyer equations of motion, linear in the standard parameters θ (base link first):

    W(q, v, a) θ = [0₆; τ] + Σ_c J_cᵀ f_c

* **base rows** (6: force, then moment on the base link, base frame): no joint torque in them, only the
  contact wrenches ``f_c`` and the motion (Ayusawa, Venture & Nakamura 2014).  What a wearer's exoskeleton
  without joint torque sensors, or a walking robot with force plates, gives.
* **joint rows** (n): the joint torques with the wrenches' ``J_cᵀ f_c`` moved to the right-hand side.

``rows`` picks ``"all"`` (both), ``"base"`` or ``"joints"``; the base parameters are those of the rows used
(:func:`pinid.model.floating.floating_base_parameters`).  Weighting: every joint row has weight 1 and every
base row ``base_weight`` (default 1: plain least squares in SI units, N and N·m alike); WLS
(``weighting="joint"``) re-weights per body, the 6 base rows together counting as the body ``base``.

The result is an ordinary :class:`~pinid.identification.problem.IdentificationProblem` whose ``model`` is the
robot's body view (:func:`pinid.model.floating.body_view`: ``base`` then the joints), so every estimator,
the SDP with its pseudo-inertia LMI on every body (the base link included) among them, takes it unchanged.
Its rows are rebuilt block by block (:class:`FloatingRows`); Coulomb rows at rest are not dropped.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from pinid.data.contacts import FloatingSamples
from pinid.errors import DataError
from pinid.identification.problem import IdentificationProblem
from pinid.model.base import BaseParameters
from pinid.model.floating import (
    BASE_NV,
    FloatingRobotModel,
    as_floating,
    contact_forces,
    floating_base_parameters,
    floating_regressor,
    floating_standard_parameters,
    row_mask,
)
from pinid.model.terms import JointTerms, as_terms

_CHUNK = 2000  # samples per regressor block (2000 × (6 + n) rows × p columns of the standard regressor)


@dataclass
class FloatingRows:
    """What rebuilds the rows of a floating problem's base regressor (duck-types
    :class:`~pinid.identification.problem.RegressorRows`)."""

    model: FloatingRobotModel
    terms: JointTerms
    base: BaseParameters
    samples: list[FloatingSamples]
    mask: np.ndarray

    @property
    def count(self) -> int:
        return sum(s.n for s in self.samples) * int(self.mask.sum())

    def blocks(self, *, bar=None) -> Iterator[tuple[int, np.ndarray]]:
        row, per = 0, int(self.mask.sum())
        for s in self.samples:
            for start in range(0, s.n, _CHUNK):
                sl = slice(start, min(s.n, start + _CHUNK))
                W = floating_regressor(
                    self.model,
                    s.base_q[sl],
                    s.base_v[sl],
                    s.base_a[sl],
                    s.data.q[sl],
                    s.data.dq[sl],
                    s.data.ddq[sl],
                    self.terms,
                )
                k = sl.stop - sl.start
                if per == len(self.mask):
                    Wk = np.take(W, self.base.independent, axis=1)
                else:  # rows and columns picked in one copy
                    picked = (np.arange(k)[:, None] * len(self.mask) + np.flatnonzero(self.mask)).reshape(-1)
                    Wk = W[np.ix_(picked, self.base.independent)]
                yield row, Wk
                row += len(Wk)
                if bar is not None:
                    bar.update(k)

    def build(self) -> np.ndarray:
        W = np.empty((self.count, self.base.count))
        for row, Wk in self.blocks():
            W[row : row + len(Wk)] = Wk
        return W


def floating_targets(model: FloatingRobotModel, s: FloatingSamples) -> np.ndarray:
    """``[0₆; τ] + Σ J_cᵀ f_c`` ``(N, 6 + n)``: the right-hand side of every row (τ taken as 0 when not measured)."""
    y = np.zeros((s.n, BASE_NV + model.nv))
    if s.data.tau is not None:
        y[:, BASE_NV:] = s.data.tau
    if s.wrenches:
        y += contact_forces(model, s.base_q, s.data.q, s.wrenches)
    return y


def floating_problem(
    model: FloatingRobotModel,
    samples: FloatingSamples | Sequence[FloatingSamples],
    *,
    terms: JointTerms = JointTerms(),
    rows: str = "all",
    base_weight: float = 1.0,
    base: BaseParameters | None = None,
) -> IdentificationProblem:
    """Stack prepared floating recordings into an identification problem (see the module text).

    DataError when joint rows are asked for and a recording has no joint torque, or when the data do not
    excite every base parameter (:meth:`IdentificationProblem.check`)."""
    model = as_floating(model)
    terms = as_terms(terms)
    if isinstance(samples, FloatingSamples):
        samples = [samples]
    samples = list(samples)
    if not samples:
        raise DataError("no recording given, expected at least one floating recording")
    mask = row_mask(model.nv, rows)
    if rows == "base":
        terms = JointTerms.from_names("none")  # no joint term enters the base rows
    if not (np.isfinite(base_weight) and base_weight > 0):
        raise DataError(f"base_weight={base_weight!r}, expected a number > 0")
    for s in samples:
        if rows != "base" and s.data.tau is None:
            raise DataError(
                f"{s.source}: no joint torque (tau_<joint> columns); without it only the base rows can be used "
                "(rows='base', --rows base: contact wrenches and motion)"
            )
    base = base if base is not None else floating_base_parameters(model, terms, rows=rows)
    per = int(mask.sum())
    body = np.r_[np.zeros(BASE_NV, int), np.arange(1, model.nv + 1)][mask]
    weight_row = np.r_[np.full(BASE_NV, float(base_weight)), np.ones(model.nv)][mask]
    ys, joints, sample_idx = [], [], []
    offset = 0
    for s in samples:
        ys.append(floating_targets(model, s)[:, mask].reshape(-1))
        joints.append(np.tile(body, s.n))
        sample_idx.append(offset + np.repeat(np.arange(s.n), per))
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
        np.tile(weight_row, offset),
        floating_standard_parameters(model, terms),
        samples=offset,
        sources=[s.source for s in samples],
        sample_rates=[s.data.sample_rate for s in samples],
        peak_velocity=peak,
        regressor_rows=FloatingRows(model, terms, base, samples, mask),
    )
    problem.check()
    return problem
