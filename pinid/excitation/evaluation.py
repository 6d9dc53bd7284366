"""Evaluating an excitation trajectory: the criteria of its base regressor and its extremes against limits.

The criteria are those of the **base regressor** ``W_b`` (the base columns of :func:`pinid.model.regressor`,
joint terms — Coulomb and viscous friction by default — included, unscaled) stacked over ``samples``
equally spaced instants of one period:

* ``cond``: the condition number ``σ_max/σ_min`` of ``W_b`` (seed 001 Eq. (20), :func:`condition_number`);
* ``logdet``: the D-optimal criterion, ``−log det(W_bᵀ W_b)`` (:func:`log_det_information`).

The extremes of a trajectory are measured on a dense grid (``DENSE_SAMPLES`` per period, refined by
Newton steps on the analytic derivatives) and compared with an :class:`~pinid.excitation.spec.ExcitationSpec`'s
limits: :func:`limit_usage`, :func:`is_feasible`, :func:`limit_violations`; :func:`evaluate_trajectory`
gives all of it at once.
"""

from __future__ import annotations

import numpy as np

from pinid.model.base import BaseParameters, base_parameters
from pinid.checks import as_floats, count, number
from pinid.errors import SpecError
from pinid.model.robot import RobotModel, as_robot
from pinid.model.regressor import regressor, standard_parameters
from pinid.model.terms import TermSelection
from pinid.excitation.trajectory import FourierTrajectory
from pinid.excitation.spec import DEFAULT_SAMPLES, ExcitationSpec

#: Points per period of the grid on which the final extremes are measured.
DENSE_SAMPLES = 4000

_REST_TOL = 1e-10  # |dq| below this at a sample is exact rest (sign(dq) = 0 in the Coulomb column)


def sample_times(period: float, samples: int) -> np.ndarray:
    """``samples`` equally spaced instants of one period, starting at 0 [s]."""
    samples = count(samples, "samples", low=1)
    period = number(period, "period", low=0, low_open=True)
    return np.arange(samples) * (period / samples)


def clean_rest(dq: np.ndarray) -> np.ndarray:
    """Velocities [rad/s] that are zero up to rounding are zero (so that sign(dq) = 0 in the Coulomb column)."""
    dq = as_floats(dq, "dq", finite=False)
    return np.where(np.abs(dq) < _REST_TOL, 0.0, dq)


def _base_regressor(
    model: RobotModel,
    trajectory: FourierTrajectory,
    terms: TermSelection = TermSelection(),
    samples: int = DEFAULT_SAMPLES,
    base: BaseParameters | None = None,
) -> np.ndarray:
    """The base regressor ``(samples·nv, nb)`` of a trajectory over one period (unscaled)."""
    _check_joints(model, trajectory)
    base = base or base_parameters(model, terms)
    q, dq, ddq = trajectory.evaluate(sample_times(trajectory.period, samples))
    return base.columns(regressor(model, q, clean_rest(dq), ddq, terms))


def condition_number(
    model: RobotModel,
    trajectory: FourierTrajectory,
    terms: TermSelection = TermSelection(),
    samples: int = DEFAULT_SAMPLES,
    base: BaseParameters | None = None,
) -> float:
    """Condition number of the base regressor (friction columns included, unscaled) over one period,
    ``samples`` equally spaced instants from t = 0 — the figure seed 001 minimises (its Eq. (20))."""
    return float(np.linalg.cond(_base_regressor(model, trajectory, terms, samples, base)))


def log_det_information(
    model: RobotModel,
    trajectory: FourierTrajectory,
    terms: TermSelection = TermSelection(),
    samples: int = DEFAULT_SAMPLES,
    base: BaseParameters | None = None,
) -> float:
    """``log det(W_bᵀ W_b)`` of the base regressor (the D-optimal criterion maximises it)."""
    s = np.linalg.svd(_base_regressor(model, trajectory, terms, samples, base), compute_uv=False)
    return float(2 * np.sum(np.log(s))) if s[-1] > 0 else -np.inf


def _check_joints(model: RobotModel, trajectory: FourierTrajectory) -> None:
    as_robot(model)
    if not isinstance(trajectory, FourierTrajectory):
        raise SpecError(f"trajectory: got {type(trajectory).__name__}, expected a FourierTrajectory")
    if list(trajectory.joints) != model.joint_names:
        raise SpecError(
            f"trajectory joints {list(trajectory.joints)} do not match the model's active joints {model.joint_names}"
        )


def _refine_extreme(trajectory: FourierTrajectory, t: np.ndarray, order: int, j: int, spacing: float) -> np.ndarray:
    """Newton steps on the derivative of order ``order + 1`` to locate extremes of derivative ``order`` of joint j,
    each step at most the grid ``spacing`` (so that it stays with the extreme the grid found)."""
    for _ in range(8):
        d1 = trajectory.derivative(t, order + 1)[:, j]
        d2 = trajectory.derivative(t, order + 2)[:, j]
        step = np.where(np.abs(d2) > 1e-300, d1 / np.where(d2 == 0, 1, d2), 0.0)
        t = t - np.clip(step, -spacing, spacing)
    return trajectory.derivative(t, order)[:, j]


def trajectory_extremes(trajectory: FourierTrajectory, points: int = DENSE_SAMPLES) -> dict:
    """Per joint ``{q_min, q_max, dq_abs_max, ddq_abs_max}`` over one period [rad, rad/s, rad/s²].

    Measured on a grid of ``points`` per period, each extreme then refined by Newton steps on the analytic
    derivatives (so they are exact to rounding, not to the grid)."""
    if not isinstance(trajectory, FourierTrajectory):
        raise SpecError(f"trajectory: got {type(trajectory).__name__}, expected a FourierTrajectory")
    t = sample_times(trajectory.period, points)
    out = {}
    values = [trajectory.derivative(t, k) for k in range(3)]
    for j, name in enumerate(trajectory.joints):
        q, dq, ddq = (v[:, j] for v in values)
        cand_t = np.array([t[np.argmin(q)], t[np.argmax(q)], t[np.argmax(np.abs(dq))], t[np.argmax(np.abs(ddq))]])
        h = trajectory.period / points
        qr = _refine_extreme(trajectory, cand_t[:2], 0, j, h)
        dqr = _refine_extreme(trajectory, cand_t[2:3], 1, j, h)
        ddqr = _refine_extreme(trajectory, cand_t[3:4], 2, j, h)
        out[name] = {
            "q_min": float(min(q.min(), qr[0])),
            "q_max": float(max(q.max(), qr[1])),
            "dq_abs_max": float(max(np.abs(dq).max(), abs(dqr[0]))),
            "ddq_abs_max": float(max(np.abs(ddq).max(), abs(ddqr[0]))),
        }
    return out


def torque_extremes(
    model: RobotModel, trajectory: FourierTrajectory, terms: TermSelection = TermSelection(), points: int = 1000
) -> np.ndarray:
    """Largest |torque| [N·m] per joint over one period, with the nominal URDF parameters (``points`` samples)."""
    model = as_robot(model)
    q, dq, ddq = trajectory.evaluate(sample_times(trajectory.period, points))
    tau = (regressor(model, q, clean_rest(dq), ddq, terms) @ standard_parameters(model, terms)).reshape(points, -1)
    return np.abs(tau).max(axis=0)


def limit_usage(
    extremes: dict, spec: ExcitationSpec, tau_abs_max: np.ndarray | None = None, q0: np.ndarray | None = None
) -> dict:
    """How much of each limit a trajectory uses, per joint, as fractions (1.0 = at the limit).

    ``q_low`` / ``q_high``: how far towards each position limit the motion goes from q0 (1 = reaches it);
    ``q_range``: the share of the range covered; ``dq``, ``ddq``, ``tau``: peak over limit.  Limits here are
    the spec's, before the margin; ``q0``: the trajectory's offsets (default: the spec's)."""
    if not isinstance(extremes, dict):
        raise SpecError(f"extremes: got {type(extremes).__name__}, expected the extremes dict of trajectory_extremes")
    out = {}
    q0s = spec.q0 if q0 is None else np.asarray(q0, dtype=float)
    for i, j in enumerate(spec.joints):
        e = extremes[j]
        q0, lo, hi = q0s[i], spec.q_min[i], spec.q_max[i]
        u = {
            "q_low": (q0 - e["q_min"]) / (q0 - lo),
            "q_high": (e["q_max"] - q0) / (hi - q0),
            "q_range": (e["q_max"] - e["q_min"]) / (hi - lo),
            "dq": e["dq_abs_max"] / spec.dq_max[i],
            "ddq": e["ddq_abs_max"] / spec.ddq_max[i],
        }
        if tau_abs_max is not None and np.isfinite(spec.tau_max[i]):
            u["tau"] = float(tau_abs_max[i] / spec.tau_max[i])
        out[j] = {k: float(v) for k, v in u.items()}
    return out


def is_feasible(extremes: dict, spec: ExcitationSpec, tau_abs_max: np.ndarray | None = None, tol: float = 1e-9) -> bool:
    """Whether the extremes are inside the spec's limits (after the margin), to ``tol``."""
    if not isinstance(extremes, dict):
        raise SpecError(f"extremes: got {type(extremes).__name__}, expected the extremes dict of trajectory_extremes")
    for i, j in enumerate(spec.joints):
        e = extremes[j]
        if (
            e["q_min"] < spec.lower[i] - tol
            or e["q_max"] > spec.upper[i] + tol
            or e["dq_abs_max"] > spec.velocity[i] + tol
            or e["ddq_abs_max"] > spec.acceleration[i] + tol
        ):
            return False
        if tau_abs_max is not None and tau_abs_max[i] > spec.torque[i] * (1 + 1e-6):
            return False
    return True


def limit_violations(extremes: dict, spec: ExcitationSpec, tol: float = 1e-9) -> list[str]:
    """One readable line per limit the extremes exceed (after the margin), e.g.
    ``"hip: q_min -0.08742 < -0.087 by 0.00042 rad"``; empty when inside."""
    if not isinstance(extremes, dict):
        raise SpecError(f"extremes: got {type(extremes).__name__}, expected the extremes dict of trajectory_extremes")
    out = []
    for i, j in enumerate(spec.joints):
        e = extremes[j]
        checks = [
            ("q_min", e["q_min"], spec.lower[i], -1, "rad"),
            ("q_max", e["q_max"], spec.upper[i], 1, "rad"),
            ("|dq|", e["dq_abs_max"], spec.velocity[i], 1, "rad/s"),
            ("|ddq|", e["ddq_abs_max"], spec.acceleration[i], 1, "rad/s²"),
        ]
        if "tau_abs_max" in e and np.isfinite(spec.torque[i]):
            checks.append(("|tau|", e["tau_abs_max"], spec.torque[i], 1, "N·m"))
        for name, value, limit, side, unit in checks:
            excess = (value - limit) * side
            if excess > tol:
                rel = "<" if side < 0 else ">"
                out.append(f"{j}: {name} {value:.6g} {rel} {limit:.6g} by {excess:.2g} {unit}")
    return out


def evaluate_trajectory(
    model: RobotModel, trajectory: FourierTrajectory, spec: ExcitationSpec, *, base: BaseParameters | None = None
) -> dict:
    """Condition number, log det, dense-grid extremes, limit usage and feasibility of a trajectory under a spec."""
    _check_joints(model, trajectory)
    base = base or base_parameters(model, spec.terms)
    ext = trajectory_extremes(trajectory)
    tau = torque_extremes(model, trajectory, spec.terms) if spec.has_torque_limits else None
    if tau is not None:
        for j, name in enumerate(trajectory.joints):
            ext[name]["tau_abs_max"] = float(tau[j])
    return {
        "condition_number": condition_number(model, trajectory, spec.terms, spec.samples, base),
        "log_det": log_det_information(model, trajectory, spec.terms, spec.samples, base),
        "extremes": ext,
        "usage": limit_usage(ext, spec, tau, trajectory.q0),
        "feasible": is_feasible(ext, spec, tau),
        "tau_abs_max": tau,
        "rest_start": trajectory.starts_at_rest(),
    }
