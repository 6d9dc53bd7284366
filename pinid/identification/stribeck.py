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

With ``fit_shape`` the shape δ is searched the same way (:data:`SHAPE_GRID` candidates over
:data:`SHAPES`, then Brent on ``log δ``), each candidate δ with its own velocity search (nested 1-D
searches: about 20 × the velocity search's cost).

Above the largest speed the Stribeck column tends to the Coulomb column sign(v) (collinear with ``fc``),
below ``LOW·`` of it the column is zero but near rest: the search stays between.
"""

from __future__ import annotations

from dataclasses import dataclass
from collections.abc import Sequence

import numpy as np
import scipy.linalg

from pinid.data.dataset import Dataset
from pinid.errors import DataError
from pinid.problem.problem import IdentificationProblem, check_dataset
from pinid.model import terms as _terms

GRID = 25  # log-spaced candidates of the coarse search
LOW, HIGH = 1e-3, 1.0  # search range: fractions of the largest speed of the term's space
XTOL = 1e-4  # Brent's tolerance on log v_s (≈ 0.01 % relative)
SHAPES = (0.5, 4.0)  # range of the shape search (``shape="auto"``)
SHAPE_GRID, SHAPE_XTOL = 7, 1e-3  # its coarse candidates and Brent's tolerance on log δ


@dataclass
class VelocityFit:
    """The fitted Stribeck velocity (and shape) of one term and how they were found."""

    term: str
    velocity: float  # [rad/s] (or m/s) in the term's space
    shape: float
    residual: float  # weighted sum of squared torque residuals at the optimum [N²·m²]
    bounds: tuple[float, float]  # searched range [rad/s]
    evaluations: int
    shape_fitted: bool = False

    def summary(self) -> dict:
        """Plain dict for the results JSON."""
        return {
            "velocity": self.velocity,
            "shape": self.shape,
            "fitted": True,
            "shape_fitted": self.shape_fitted,
            "residual": self.residual,
            "bounds": list(self.bounds),
            "evaluations": self.evaluations,
        }


def _search(cost, lo: float, hi: float, grid: int, xtol: float) -> tuple[float, float, int]:
    """``(x, cost(x), evaluations)``: the best of ``grid`` points in [lo, hi], refined by bounded Brent
    between its neighbours."""
    from scipy.optimize import minimize_scalar  # scipy.optimize: only for this search

    xs = np.linspace(lo, hi, grid)
    costs = np.array([cost(x) for x in xs])
    k = int(np.argmin(costs))
    opt = minimize_scalar(
        cost, bounds=(xs[max(k - 1, 0)], xs[min(k + 1, grid - 1)]), method="bounded", options={"xatol": xtol}
    )
    best = (float(opt.x), float(opt.fun)) if opt.fun <= costs[k] else (float(xs[k]), float(costs[k]))
    return best[0], best[1], grid + int(opt.nfev)


def fit_velocity(
    problem: IdentificationProblem, datasets: Sequence[Dataset], term: str, *, fit_shape: bool = False
) -> VelocityFit:
    """Stribeck velocity of ``term`` (``fs`` or ``motor_fs``; shape from ``problem.model``, or fitted too
    with ``fit_shape``) minimising the least-squares residual of ``problem`` (built from ``datasets``
    without the term) with the term's columns added; see the module text.  DataError when the data do not
    move."""
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
    sel = _terms.TermSelection(names=[term])

    def residual(log_v: float, shape: float) -> float:
        trial = model.with_stribeck({term: _terms.Stribeck(float(np.exp(log_v)), shape)})
        S = _terms.columns(trial, sel, q, dq, ddq)[rows, problem.joint] * sw[:, None]
        S -= Q @ (Q.T @ S)
        beta = np.linalg.lstsq(S, y, rcond=None)[0]
        r = y - S @ beta
        return float(r @ r)

    lo, hi = np.log(LOW * speed), np.log(HIGH * speed)

    def velocity(shape: float) -> tuple[float, float, int]:
        return _search(lambda x: residual(x, shape), lo, hi, GRID, XTOL)

    bounds = (float(np.exp(lo)), float(np.exp(hi)))
    if not fit_shape:
        shape = _terms.stribeck(model, term).shape
        x, cost, n = velocity(shape)
        return VelocityFit(term, float(np.exp(x)), shape, cost, bounds, n)
    inner: dict[float, tuple[float, float, int]] = {}

    def by_shape(log_d: float) -> float:
        inner[log_d] = velocity(float(np.exp(log_d)))
        return inner[log_d][1]

    log_d, cost, _ = _search(by_shape, *np.log(SHAPES), SHAPE_GRID, SHAPE_XTOL)
    x = inner[log_d][0] if log_d in inner else velocity(float(np.exp(log_d)))[0]
    return VelocityFit(
        term, float(np.exp(x)), float(np.exp(log_d)), cost, bounds, sum(v[2] for v in inner.values()), shape_fitted=True
    )
