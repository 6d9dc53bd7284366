"""Statistics of a fitted problem: standard deviations and condition numbers (:func:`base_statistics`), and
standard parameters behind base ones (:func:`completed_standard`, :func:`least_norm_completion`).

Re-exported by :mod:`pinid.problem.problem`, where they were first written.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg

from pinid.errors import SpecError
from pinid.linalg import unit_weights
from pinid.model.base import BaseParameters
from pinid.model.physical import parameter_scale
from pinid.model.regressor import standard_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.problem.covariance import hac_std

if TYPE_CHECKING:
    from pinid.problem.problem import IdentificationProblem, Problem


def base_statistics(
    problem: Problem,
    base: np.ndarray,
    weights: np.ndarray | None = None,
    *,
    residual: np.ndarray | None = None,
    kind: str = "hac",
) -> tuple[np.ndarray, float, float]:
    """``(std, condition_number, condition_number_scaled)`` of base parameters fitted with row ``weights``.

    ``kind="hac"`` (default): the Newey–West sandwich of :mod:`pinid.problem.covariance`, calibrated for
    time-correlated residuals; ``"white"``: σ²·(Wᵀ diag(w) W)⁻¹ with σ² = Σ w·r² / (rows − nb).  The
    condition numbers are those of diag(√w)·W as it is and with unit-norm columns.  ``residual``:
    ``tau − W @ base`` when already known (else computed, reading ``problem.W``).
    """
    if not hasattr(problem, "weights"):
        raise SpecError(
            f"problem: got {type(problem).__name__}, expected an identification problem (IdentificationProblem)"
        )
    w = problem.weights if weights is None else weights
    r = problem.tau - problem.W @ base if residual is None else residual
    dof = max(problem.rows - problem.nb - _offset_columns(problem), 1)
    R, _, _, scale = problem.compressed(weights)
    try:
        Rinv = scipy.linalg.solve_triangular(R, np.eye(len(R)))
        if kind == "white":
            sigma2 = float(np.sum(w * r * r)) / dof
            std = np.sqrt(sigma2 * np.sum(Rinv**2, axis=1)) / scale
        else:
            std = hac_std(problem, r, Rinv, scale, dof, weights=unit_weights(w))  # w·r block by block
    except (np.linalg.LinAlgError, ValueError):
        std = np.full(problem.nb, np.inf)
    s_scaled = np.linalg.svd(R, compute_uv=False)
    s_raw = np.linalg.svd(R * scale, compute_uv=False)
    cond = float(s_raw[0] / s_raw[-1]) if s_raw[-1] > 0 else float("inf")
    cond_scaled = float(s_scaled[0] / s_scaled[-1]) if s_scaled[-1] > 0 else float("inf")
    return std, cond, cond_scaled


def base_covariance(problem: Problem, base: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """The Newey–West covariance (nb, nb) of base parameters fitted with row ``weights`` (the sandwich whose
    diagonal :func:`base_statistics` gives as σ²); NaN where the compressed regressor is singular."""
    w = problem.weights if weights is None else weights
    r = problem.tau - problem.predict(base)  # block by block while the tall W is not built
    dof = max(problem.rows - problem.nb - _offset_columns(problem), 1)
    R, _, _, scale = problem.compressed(weights)
    try:
        Rinv = scipy.linalg.solve_triangular(R, np.eye(len(R)))
        return hac_std(problem, r, Rinv, scale, dof, weights=unit_weights(w), full=True)
    except (np.linalg.LinAlgError, ValueError):
        return np.full((problem.nb, problem.nb), np.nan)


def completed_standard(model: RobotModel, terms: TermSelection, base: BaseParameters, values: np.ndarray) -> np.ndarray:
    """The standard vector closest to the nominal one (in the scaled norm) with ``base.P·θ = values``."""
    nominal = standard_parameters(model, terms)
    S = parameter_scale(nominal, model.nv, len(terms))
    A = base.P * S
    dz = np.linalg.lstsq(A, np.asarray(values, dtype=float) - A @ (nominal / S), rcond=None)[0]
    return (nominal / S + dz) * S


def least_norm_completion(problem: IdentificationProblem, base: np.ndarray) -> np.ndarray:
    """The standard vector closest to the nominal one (in the scaled norm) with ``P·θ = base``."""
    if not hasattr(problem, "nominal"):
        raise SpecError(f"problem: got {type(problem).__name__}, expected an IdentificationProblem")
    S = parameter_scale(problem.nominal, problem.nv, len(problem.terms))
    A = problem.base.P * S
    z0 = problem.nominal / S
    dz = np.linalg.lstsq(A, base - A @ z0, rcond=None)[0]
    return (z0 + dz) * S


def _offset_columns(problem) -> int:
    """The offset columns profiled out of ``problem`` (offsets per recording: one per recording and joint with
    rows, :func:`pinid.identification.offsets.profile_offsets`), which the degrees of freedom count; 0 without."""
    sizes = getattr(problem, "recording_sizes", None)
    if getattr(problem, "offset_shift", None) is None or sizes is None:
        return 0
    recording = np.searchsorted(np.cumsum(sizes), problem.sample, side="right")
    return int(np.unique(recording * problem.nv + np.asarray(problem.joint)).size)
