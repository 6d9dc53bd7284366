"""The Stribeck velocity fitted by a 1-D search around the linear fit.

For a given Stribeck velocity ``v_s`` (and shape δ) the model is linear in every parameter, so the fit
is least squares; only ``v_s`` enters nonlinearly.  :func:`fit_velocity` minimises the (row-weighted)
least-squares residual over ``log v_s``:

1. the problem without the Stribeck term (base regressor ``A``) is factored once (thin QR ``√w·A = Q·R``);
   for a candidate ``v_s`` only the Stribeck columns ``S(v_s)`` are computed, and the residual is that of
   ``S⊥ = S − Q·QᵀS`` against ``τ⊥ = √w·τ − Q·Qᵀ√w·τ`` (variable projection: the same residual as the
   full least-squares fit, at the cost of ``rows × nb × k`` per candidate, ``k`` the Stribeck columns);
2. a grid of :data:`GRID` log-spaced velocities over ``[LOW, HIGH] × `` the largest speed of the term's
   space (joint speeds for ``fs``, motor speeds G·dq for ``motor_fs``) picks the best cell;
3. bounded Brent (``scipy.optimize.minimize_scalar``) refines ``log v_s`` between its grid neighbours
   (relative tolerance :data:`XTOL`).

Above the largest speed the Stribeck column tends to the Coulomb column sign(v) (collinear with ``fc``),
below ``LOW·`` of it the column is zero but near rest: the search stays between.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from collections.abc import Sequence

import numpy as np
import scipy.linalg

from pinid.data.dataset import Dataset
from pinid.errors import DataError
from pinid.identification.problem import IdentificationProblem, check_dataset
from pinid.model import terms as _terms
from pinid.model.robot import RobotModel

GRID = 25  # log-spaced candidates of the coarse search
LOW, HIGH = 1e-3, 1.0  # search range: fractions of the largest speed of the term's space
XTOL = 1e-4  # Brent's tolerance on log v_s (≈ 0.01 % relative)


@dataclass
class VelocityFit:
    """The fitted Stribeck velocity of one term and how it was found."""

    term: str
    velocity: float  # [rad/s] (or m/s) in the term's space
    shape: float
    residual: float  # weighted sum of squared torque residuals at the optimum [N²·m²]
    bounds: tuple[float, float]  # searched range [rad/s]
    evaluations: int

    def summary(self) -> dict:
        """Plain dict for the results JSON."""
        return {"velocity": self.velocity, "shape": self.shape, "fitted": True, "residual": self.residual,
                "bounds": list(self.bounds), "evaluations": self.evaluations}


def fit_velocity(problem: IdentificationProblem, datasets: Sequence[Dataset], term: str) -> VelocityFit:
    """Stribeck velocity of ``term`` (``fs`` or ``motor_fs``, shape from ``problem.model``) minimising the
    least-squares residual of ``problem`` (built from ``datasets`` without the term) with the term's
    columns added; see the module text.  DataError when the data do not move."""
    from scipy.optimize import minimize_scalar  # scipy.optimize: only for this search

    model = problem.model
    # the motion of every row (its sample in the concatenated recordings)
    checked = [check_dataset(ds, model) for ds in datasets]
    q, dq, ddq = (np.concatenate([getattr(ds, k) for ds in checked])[problem.sample] for k in ("q", "dq", "ddq"))
    rows = np.arange(problem.rows)
    space = _terms.TERMS[term].space
    speed = float(np.max(np.abs(_terms.motion(model, q, dq, ddq, space).dq)))
    if not speed > 0:
        raise DataError(f"Stribeck velocity of {term}: the data do not move (largest speed 0)")

    sw = np.sqrt(problem.weights)
    Q = scipy.linalg.qr(problem.W * sw[:, None], mode="economic")[0]
    y = problem.tau * sw
    y -= Q @ (Q.T @ y)
    trial = copy.copy(model)
    trial.stribeck = dict(model.stribeck)
    shape = _terms.stribeck(model, term).shape
    sel = _terms.JointTerms(names=[term])

    def residual(log_v: float) -> float:
        trial.stribeck[term] = _terms.Stribeck(float(np.exp(log_v)), shape)
        S = _terms.columns(trial, sel, q, dq, ddq)[rows, problem.joint] * sw[:, None]
        S -= Q @ (Q.T @ S)
        beta = np.linalg.lstsq(S, y, rcond=None)[0]
        r = y - S @ beta
        return float(r @ r)

    lo, hi = np.log(LOW * speed), np.log(HIGH * speed)
    grid = np.linspace(lo, hi, GRID)
    costs = np.array([residual(x) for x in grid])
    k = int(np.argmin(costs))
    a, b = grid[max(k - 1, 0)], grid[min(k + 1, GRID - 1)]
    opt = minimize_scalar(residual, bounds=(a, b), method="bounded", options={"xatol": XTOL})
    best, cost = (opt.x, opt.fun) if opt.fun <= costs[k] else (grid[k], costs[k])
    return VelocityFit(term, float(np.exp(best)), shape, float(cost), (float(np.exp(lo)), float(np.exp(hi))),
                       GRID + int(opt.nfev))


def with_stribeck(model: RobotModel, settings: dict[str, _terms.Stribeck]) -> RobotModel:
    """A shallow copy of ``model`` with these Stribeck shapes (the caller's model is left as it is)."""
    out = copy.copy(model)
    out.stribeck = {**model.stribeck, **settings}
    return out
