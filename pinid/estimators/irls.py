"""Iteratively reweighted least squares: an M-estimator (Huber or Tukey) robust to outliers in the torque.

A few wrong torque samples (a dropped packet, a spike of the current sensor, a collision) pull least
squares a long way, because the squared cost grows without bound.  IRLS minimises
``Σ ρ(r_i / s)`` with a robust loss ``ρ`` instead, by least squares with row weights
``w_i = ψ(u_i)/u_i`` (``u_i = r_i / s``) recomputed from the residuals of the previous pass:

* ``loss="huber"``: ``w = 1`` for ``|u| ≤ k``, ``k/|u|`` beyond (default ``k = 1.345``: 95 % efficiency
  under Gaussian noise); convex, so IRLS converges to its unique minimiser.
* ``loss="tukey"`` (bisquare): ``w = (1 − (u/k)²)²`` for ``|u| < k``, 0 beyond (default ``k = 4.685``):
  rejects gross outliers completely; not convex, started from the Huber fit.

The scale ``s`` is per joint (joints' torques differ in size): the normalised median absolute deviation
``1.4826·MAD`` of that joint's residuals, re-estimated every pass (``tuning`` multiplies the default
``k``).  Starts from OLS; stops when the base parameters change less than ``tol`` relatively.
``weights_`` holds the final row weights (times ``problem.weights``); ``info_["downweighted"]`` the
fraction of rows with weight below 0.5.

On noise-free data every residual is zero, the weights stay 1 and IRLS returns least squares (the
truth).  ``physical=True``: the last pass is the LMI-constrained least squares of
:class:`~pinid.estimators.sdp.SDP` with the final robust weights, so the result is physically
consistent (the weights come from unconstrained passes).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pinid.estimators.base import Estimator, Setting
from pinid.estimators.sdp import SDP
from pinid.problem.problem import Problem
from pinid.linalg import solve_r, weighted_lstsq

#: Default tuning constants (95 % Gaussian efficiency).
TUNING = {"huber": 1.345, "tukey": 4.685}


def _robust_weights(u: np.ndarray, loss: str, k: float) -> np.ndarray:
    """Row weights ``ψ(u)/u`` of the Huber or Tukey loss for standardised residuals ``u``."""
    a = np.abs(u)
    if loss == "huber":
        return np.where(a <= k, 1.0, k / np.maximum(a, 1e-300))
    return np.where(a < k, (1.0 - (u / k) ** 2) ** 2, 0.0)


def _joint_mad(problem, r: np.ndarray) -> np.ndarray:
    """Per row, the robust scale ``1.4826·MAD`` of its joint's residuals (floored at 1e-12·RMS τ_j) [N·m]."""
    s = np.ones(problem.nv)
    for j in range(problem.nv):
        sel = problem.joint == j
        if not np.any(sel):
            continue
        rj = r[sel]
        mad = 1.4826 * float(np.median(np.abs(rj - np.median(rj))))
        s[j] = max(mad, 1e-12 * float(np.sqrt(np.mean(problem.tau[sel] ** 2))), 1e-300)
    return s[problem.joint]


class IRLS(Estimator):
    """Iteratively reweighted least squares with Huber or Tukey weights, per-joint MAD scale (module text).

    Settings: ``loss`` ("huber", default, or "tukey"), ``tuning`` (multiplies the loss's default constant,
    default 1), ``iterations`` (at most, default 50), ``tol`` (default 1e-8), ``physical`` (last pass
    LMI-constrained, default False).
    """

    name = "irls"
    summary = (
        "iteratively reweighted least squares, Huber (or Tukey bisquare, started from Huber) weights of "
        "residuals scaled by each joint's MAD"
    )
    assumptions = "a minority of gross outliers in the torque"
    settings_summary = '`loss` ("huber"), `tuning` (1), `iterations` (50), `tol` (1e-8), `physical` (False)'
    description = "iteratively reweighted least squares (Huber or Tukey weights): robust to outliers"
    colour = "#b8860b"
    history = "passes"
    settings = {
        "loss": Setting("str", choices=("huber", "tukey"), help="robust loss"),
        "tuning": Setting("float", low=0.0, low_open=True, help="multiplies the loss's default tuning constant"),
        "iterations": Setting("int", low=1, help="reweighting passes at most"),
        "tol": Setting("float", low=0.0, help="stop when the parameters change less than this, relatively"),
        "physical": Setting("bool", help="last pass physically consistent (LMI)"),
    }

    def __init__(
        self, loss: str = "huber", tuning: float = 1.0, iterations: int = 50, tol: float = 1e-8, physical: bool = False
    ) -> None:
        self.loss = loss
        self.tuning = tuning
        self.iterations = iterations
        self.tol = tol
        self.physical = physical

    def fit(self, problem: Problem) -> "IRLS":
        """OLS, then reweighted least squares until the parameters settle; sets ``base_`` and ``weights_``."""
        R, c, _, scale = problem.compressed()
        x = solve_r(R, c, scale)
        W, tau, w0 = problem.W, problem.tau, problem.weights
        stages = ["huber", "tukey"] if self.loss == "tukey" else ["huber"]
        history: list[float] = []
        weights = w0
        change = float("inf")
        for loss in stages:
            k = TUNING[loss] * float(self.tuning)
            for _ in range(int(self.iterations)):
                r = tau - W @ x
                u = r / _joint_mad(problem, r)
                rw = _robust_weights(u, loss, k)
                if np.count_nonzero(rw * w0) <= problem.nb:
                    break  # too few rows left to determine the parameters: keep the last fit
                weights = w0 * rw
                x_new = weighted_lstsq(W, tau, weights)
                change = float(np.linalg.norm(x_new - x) / max(np.linalg.norm(x_new), 1e-300))
                x = x_new
                history.append(float(np.sum(weights * (tau - W @ x) ** 2) / max(np.sum(weights), 1e-300)))
                if change < self.tol:
                    break
        standard = None
        if self.physical:
            est = SDP().fit(replace(problem, W=W, weights=weights, regressor_rows=None))
            x, standard = est.base_, est.standard_
        self.base_ = x
        self.standard_ = standard
        self.weights_ = weights
        self.history_ = history
        self.status_ = "ok" if change < self.tol or not history else f"not settled after {len(history)} passes"
        self.info_ = {
            "loss": self.loss,
            "passes": len(history),
            "downweighted": float(np.mean((weights / np.maximum(w0, 1e-300)) < 0.5)),
        }
        return self
