"""The shape of the sigmoid friction ``fsig`` (:mod:`pinid.model.terms_sigmoid`) fitted around the linear fit.

For given shapes (steepness φ2 [s/rad], offset φ3 [rad/s] per joint) the model is linear in every parameter;
only the shapes enter nonlinearly.  :func:`fit_sigmoid` (``--sigmoid-shape auto``) minimises the
(row-weighted) least-squares residual over them by variable projection, one joint at a time:

1. the problem without ``fsig`` (base regressor ``A``) and the other joints' ``fsig`` columns ``S₋ⱼ`` at their
   current shapes are factored (thin QR ``[√w·A, S₋ⱼ] = Q·R``), the torque projected out: ``y = √w·τ − Q·Qᵀ√w·τ``;
2. joint ``j``'s column ``s`` is non-zero on its own rows only, so the residual of the fit with it is
   ``‖y‖² − (sᵀy)² / (sᵀs − ‖Qᵀs‖²)``: a cost of (its rows × columns) per candidate shape;
3. a grid of :data:`STEEP_GRID` × :data:`OFFSET_GRID` candidates over ``log φ2 ∈`` :data:`STEEP` / speed and
   ``φ3 ∈ ±``:data:`OFFSET_SPAN` × speed (speed: the joint's largest) picks the best cell (on the first visit; later ones start from the current shape); Nelder–Mead refines
   within the same bounds (outside them the column tends to a multiple of ``fv``'s or ``fc``'s).

The joints are visited in turn (Gauss–Seidel) until no shape moves by more than :data:`SWEEP_TOL` (relative), at
most :data:`SWEEPS` times, from the model's shapes (the default when ``"auto"``).  A joint whose column is (nearly) in the span of the others keeps its start (``fitted: false``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError
from pinid.model import terms as _terms
from pinid.model.base import base_parameters
from pinid.model.robot import RobotModel
from pinid.model.terms_sigmoid import SETTING, shapes, sigmoid_column
from pinid.problem.problem import IdentificationProblem, check_dataset

STEEP = (2.0, 2000.0)  # range of φ2·(the joint's largest speed): transition widths from ~2× to 1/1000 of it
STEEP_GRID = 13
OFFSET_SPAN, OFFSET_GRID = 0.05, 9  # φ3 within ± this fraction of the joint's largest speed; its candidates
SWEEPS, SWEEP_TOL = 4, 1e-5  # at most this many visits of every joint; stop when no shape moves more (relative)
MAXITER = 400  # Nelder–Mead's iterations per visit
XTOL = 1e-7  # Nelder–Mead's tolerance on (log φ2, φ3/speed)


@dataclass
class SigmoidFit:
    """The fitted sigmoid shape of each joint and how it was found."""

    steepness: dict[str, float]  # φ2 [s/rad] per joint
    offset: dict[str, float]  # φ3 [rad/s] per joint
    fitted: dict[str, bool]  # False: the joint's column was degenerate, its start kept
    residual: float  # weighted sum of squared torque residuals at the optimum [N²·m²]
    evaluations: int

    def setting(self) -> dict[str, dict[str, float]]:
        """The model setting ``"sigmoid"`` of the fit: ``{joint: {"steepness", "offset"}}``."""
        return {j: {"steepness": self.steepness[j], "offset": self.offset[j]} for j in self.steepness}

    def summary(self) -> dict:
        """Plain dict for the results JSON (data["sigmoid"])."""
        return {
            "fitted": True,
            "per_joint": {j: {**v, "fitted": self.fitted[j]} for j, v in self.setting().items()},
            "residual": self.residual,
            "evaluations": self.evaluations,
        }


@dataclass
class _Residual:
    """The weighted squared residual of the fit with one joint's ``fsig`` column of shape ``x`` = (log(φ2·speed),
    φ3/speed): ``‖y‖² − (sᵀy)² / (sᵀs − ‖Qᵀs‖²)`` on that joint's rows (``y``, ``Q`` already projected)."""

    v: np.ndarray  # the joint's velocity on its rows [rad/s]
    speed: float  # its largest speed [rad/s]
    sw: np.ndarray  # the rows' √weights
    Q: np.ndarray  # the rows of the orthonormal basis of the other columns
    y: np.ndarray  # the rows of the projected torque
    yy: float  # ‖y‖² over every row

    def __call__(self, x: np.ndarray) -> float:
        s = sigmoid_column(self.v, np.exp(x[0]) / self.speed, x[1] * self.speed) * self.sw
        den = float(s @ s - np.sum((self.Q.T @ s) ** 2))
        return self.yy if den <= 1e-12 * max(float(s @ s), 1e-300) else self.yy - float(s @ self.y) ** 2 / den


def fit_shapes(problem: IdentificationProblem, datasets: Sequence[Dataset], *, sweeps: int = SWEEPS) -> SigmoidFit:
    """Sigmoid shapes of every joint minimising the least-squares residual of ``problem`` (built from
    ``datasets`` without ``fsig``) with the ``fsig`` columns added; see the module text.  DataError when the
    data do not move."""
    from scipy.optimize import minimize  # scipy.optimize: only for this search

    if not isinstance(problem, IdentificationProblem):
        raise SpecError(f"problem: got {type(problem).__name__}, expected an IdentificationProblem without fsig")
    if isinstance(sweeps, bool) or not isinstance(sweeps, int) or sweeps < 1:
        raise SpecError(f"sweeps: {sweeps!r}, expected an integer ≥ 1")
    model = problem.model
    checked = [check_dataset(ds, model) for ds in datasets]
    dq = np.concatenate([ds.dq for ds in checked])[problem.sample]
    joint = np.asarray(problem.joint)
    rows = np.arange(problem.rows)
    v = dq[rows, joint]  # the velocity of each row's joint [rad/s]
    sw = np.sqrt(problem.weights)
    A, tau = problem.W * sw[:, None], problem.tau * sw
    names = list(model.joint_names)
    shape = shapes(model).copy()
    fitted = dict.fromkeys(names, False)
    evaluations = 0
    cost = float(tau @ tau)
    for sweep in range(sweeps):
        before = shape.copy()
        for j, name in enumerate(names):
            mine = np.flatnonzero(joint == j)
            if not mine.size:  # a joint left out of the fit (fit_joints): its start is kept
                continue
            speed = float(np.max(np.abs(v[mine])))
            if not speed > 0:
                raise DataError(f"sigmoid shape of {name}: the data do not move it (largest speed 0)")
            present = [i for i in np.unique(joint) if i != j]
            others = np.zeros((problem.rows, len(present)))
            for k, i in enumerate(present):
                at = joint == i
                others[at, k] = sigmoid_column(v[at], shape[i, 0], shape[i, 1]) * sw[at]
            Q = scipy.linalg.qr(np.hstack([A, others]), mode="economic")[0]
            y = tau - Q @ (Q.T @ tau)
            yy = float(y @ y)
            residual = _Residual(v[mine], speed, sw[mine], Q[mine], y[mine], yy)
            grid = [
                (a, b)
                for a in np.linspace(*np.log(STEEP), STEEP_GRID)
                for b in np.linspace(-OFFSET_SPAN, OFFSET_SPAN, OFFSET_GRID)
            ]
            if sweep:  # later visits refine from the joint's current shape
                grid = [(np.log(shape[j, 0] * speed), shape[j, 1] / speed)]
            costs = [residual(np.array(g)) for g in grid]
            start = np.array(grid[int(np.argmin(costs))])
            opt = minimize(
                residual,
                start,
                method="Nelder-Mead",
                bounds=[tuple(np.log(STEEP)), (-OFFSET_SPAN, OFFSET_SPAN)],
                options={"xatol": XTOL, "fatol": 1e-14 * max(yy, 1e-300), "maxiter": MAXITER},
            )
            evaluations += len(grid) + int(opt.nfev)
            best = min(float(opt.fun), min(costs))
            if best < yy * (1 - 1e-12):
                x = opt.x if opt.fun <= min(costs) else start
                shape[j] = [np.exp(x[0]) / speed, x[1] * speed]
                fitted[name] = True
            cost = best
        moved = np.abs(shape - before) / np.maximum(np.abs(before), 1e-3)
        if np.max(moved) < SWEEP_TOL:
            break
    return SigmoidFit(
        {n: float(shape[j, 0]) for j, n in enumerate(names)},
        {n: float(shape[j, 1]) for j, n in enumerate(names)},
        fitted,
        cost,
        evaluations,
    )


def fit_sigmoid(
    model: RobotModel,
    train: Sequence[Dataset],
    terms: _terms.TermSelection,
    *,
    fit_joints: Sequence[str] | None = None,
    problem_options: Mapping | None = None,
) -> tuple[RobotModel, dict]:
    """``(model with the fitted "sigmoid" setting, data["sigmoid"] summary)``: the shapes of ``fsig`` fitted
    on the training recordings ``train`` with the other terms of ``terms`` (:func:`fit_shapes`);
    ``problem_options``: ``rest_velocity``, ``rest_fraction``, ``fit_joints`` of the problem."""
    if not isinstance(model, RobotModel) or not isinstance(terms, _terms.TermSelection):
        raise SpecError("fit_sigmoid: expected a RobotModel and a TermSelection")
    if "fsig" not in terms:
        raise SpecError("sigmoid shape 'auto' without the sigmoid friction; expected --terms …,fsig")
    plain = _terms.TermSelection(names=[n for n in terms.names if n != "fsig"])
    options = dict(problem_options or {})
    problem = IdentificationProblem.from_datasets(
        model, train, terms=plain, base=base_parameters(model, plain, joints=fit_joints), **options
    )
    fit = fit_shapes(problem, train)
    return model.with_setting(SETTING, fit.setting()), fit.summary()
