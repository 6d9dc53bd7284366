"""Essential parameters: least squares on the base parameters the data determine, the rest fixed to the URDF.

Pham & Gautier's essential parameters (as in FloBaRoID): the base parameter with the largest relative
standard deviation ``σ % = 100·σ/|θ|`` is fixed to its URDF (nominal) value, its column's torque moved to
the target, and the rest refitted by least squares, until every remaining parameter's σ % is below a
threshold, or fixing the next one would make the residual grow measurably.  σ is the calibrated
Newey–West σ of :func:`pinid.problem.covariance.hac_std`, that of the reduced fit.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from pinid.estimators.base import Estimator, Setting
from pinid.linalg import unit_weights
from pinid.problem.covariance import hac_std
from pinid.problem.problem import Problem


class Essential(Estimator):
    """Least squares on the essential base parameters; the poorly determined ones fixed to the URDF's values.

    Starting from ordinary least squares on every base parameter, repeatedly fix the one with the largest
    relative standard deviation ``100·σ/|θ|`` [%] to its nominal value (the URDF's) and refit the others,
    until every remaining one is below ``threshold`` [%] or fixing the next one would raise the residual
    norm by more than ``max_growth`` (relative to the least-squares residual on every parameter).  σ: the
    Newey–West σ of the reduced fit (:func:`pinid.problem.covariance.hac_std`).

    Assumes what OLS does, and that the URDF's values of the parameters the data leave undetermined are
    better than what noise makes of them.  ``info_["fixed"]`` names the parameters fixed to the URDF,
    ``info_["identified"]`` the ones kept, with their σ %.
    """

    name = "essential"
    summary = (
        "Pham & Gautier's essential parameters (as FloBaRoID): from OLS, the base parameter of largest "
        "relative σ (Newey–West, `100·σ/|θ|`) fixed to its URDF value (its column's torque moved to the "
        "target), the rest refitted, until every kept one is below `threshold` or fixing the next one would "
        "raise the residual norm by more than `max_growth`; `info` lists `identified` (with σ %) and `fixed`"
    )
    assumptions = (
        "as OLS, plus: the URDF's values of the parameters the data leave undetermined are better than what "
        "noise makes of them"
    )
    settings_summary = "`threshold` (10 %), `max_growth` (0.01: 1 % over OLS's residual norm)"
    description = "least squares on the essential base parameters; those the data do not determine fixed to the URDF"
    colour = "#6b8e23"
    history = "passes"
    in_defaults = False  # pinid compare / pinid demo run it only when named (docs/identification.md)
    settings = {
        "threshold": Setting("float", low=0.0, low_open=True, help="largest relative σ kept [%]"),
        "max_growth": Setting(
            "float", low=0.0, help="largest rise of the residual norm over least squares' (relative, 0.01 = 1 %)"
        ),
    }

    def __init__(self, threshold: float = 10.0, max_growth: float = 0.01) -> None:
        self.threshold = threshold
        self.max_growth = max_growth

    def fit(self, problem: Problem) -> "Essential":
        """Fix the base parameters of largest relative σ to their nominal values one by one; sets ``base_``."""
        R, c, rho, scale = problem.compressed()
        nominal = np.asarray(problem.nominal_base, dtype=float)
        keep = np.ones(problem.nb, dtype=bool)
        x, rss, Rk = _reduced_fit(R, c, rho, scale, nominal, keep)
        rss0 = rss
        history, stop = [float(np.sqrt(rss))], "threshold"
        columns = _Columns(problem)
        while True:
            pct = _relative_std(problem, columns, x, Rk, scale, keep)
            if not keep.any() or not np.any(pct > float(self.threshold)):
                break
            j = int(np.flatnonzero(keep)[np.argmax(np.where(np.isnan(pct), np.inf, pct))])
            trial = keep.copy()
            trial[j] = False
            x_t, rss_t, Rk_t = _reduced_fit(R, c, rho, scale, nominal, trial)
            if np.sqrt(rss_t) > (1.0 + float(self.max_growth)) * np.sqrt(rss0):
                stop = f"residual: fixing {problem.names[j]} would raise it by more than max_growth"
                break
            keep, x, rss, Rk = trial, x_t, rss_t, Rk_t
            history.append(float(np.sqrt(rss)))
        names = list(problem.names)
        self.base_ = x
        self.standard_ = None
        self.weights_ = None
        self.history_ = history
        self.status_ = "ok"
        self.info_ = {
            "identified": {names[i]: float(p) for i, p in zip(np.flatnonzero(keep), pct)},
            "fixed": [names[i] for i in np.flatnonzero(~keep)],
            "threshold_percent": float(self.threshold),
            "residual_growth": float(np.sqrt(rss / rss0) - 1.0) if rss0 > 0 else 0.0,
            "stopped_by": stop,
        }
        return self


def _reduced_fit(R, c, rho, scale, nominal, keep):
    """``(x, rss, Rk)``: least squares on the ``keep`` columns of the compressed problem ``‖R z − c‖² + ρ²``
    (``z = scale·x``), the others fixed to ``nominal``; ``Rk`` the triangular factor of the kept columns."""
    z = scale * nominal
    target = c - R[:, ~keep] @ z[~keep]
    Rk = np.zeros((0, 0))
    if keep.any():
        Q, Rk = np.linalg.qr(R[:, keep])
        z[keep] = scipy.linalg.solve_triangular(Rk, Q.T @ target)
    rss = float(np.sum((R @ z - c) ** 2) + rho**2)
    x = z / scale
    x[~keep] = nominal[~keep]  # exactly the URDF's values
    return x, rss, Rk


def _relative_std(problem, columns, x, Rk, scale, keep) -> np.ndarray:
    """``100·σ/|x|`` [%] of the kept parameters, σ the Newey–West σ of the reduced fit (hac_std)."""
    k = int(keep.sum())
    if k == 0:
        return np.zeros(0)
    r = problem.residual(x) if hasattr(problem, "residual") else problem.tau - problem.W @ x
    Rinv = scipy.linalg.solve_triangular(Rk, np.eye(k))
    dof = max(problem.rows - k, 1)
    std = hac_std(columns.select(keep), r, Rinv, scale[keep], dof, weights=unit_weights(problem.weights))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(np.abs(x[keep]) > 0, 100.0 * std / np.abs(x[keep]), np.inf)


class _Columns:
    """The problem seen through some of its base columns: what :func:`hac_std` reads (``W`` or its rows in
    blocks, ``nb``, ``rows``, ``sample``, the recordings' lengths)."""

    def __init__(self, problem) -> None:
        self.problem = problem
        self.rows = problem.rows
        self.sample = problem.sample
        self.source = getattr(problem, "regressor_rows", None)
        self.blocked = bool(getattr(problem, "blocked", False))
        self.recording_sizes = getattr(problem, "recording_sizes", None)
        self.keep = np.ones(problem.nb, dtype=bool)

    def select(self, keep: np.ndarray) -> "_Columns":
        """Itself, seeing the ``keep`` columns."""
        self.keep = keep
        self.nb = int(keep.sum())
        self.regressor_rows = None if self.source is None else _ColumnRows(self.source, keep)
        return self

    @property
    def W(self) -> np.ndarray:
        """The kept columns of the problem's regressor."""
        return self.problem.W[:, self.keep]


class _ColumnRows:
    """A problem's ``regressor_rows`` whose blocks hold only the ``keep`` columns."""

    def __init__(self, rows, keep: np.ndarray) -> None:
        self.rows, self.keep = rows, keep
        self.datasets, self.keeps, self.chunk = rows.datasets, rows.keeps, rows.chunk

    def blocks(self, *, bar=None):
        """``(first row, block of the kept columns)`` in the order of the rows."""
        for r0, Wk in self.rows.blocks(bar=bar):
            yield r0, Wk[:, self.keep]
