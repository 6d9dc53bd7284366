"""Which rows of a recording enter the fit: the joints whose torque is fitted (``--fit-joints``), and the
samples at rest (a joint's, or a motor's through a coupled transmission) whose Coulomb sign is noise."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pinid.checks import array_like
from pinid.data.dataset import Dataset, as_dataset
from pinid.errors import SpecError
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel, as_robot
from pinid.model.terms import as_terms

#: Default fraction of a joint's largest speed below which its row counts as "at rest".
REST_FRACTION = 0.02


def rest_thresholds(dq: np.ndarray, fraction: float = REST_FRACTION) -> np.ndarray:
    """Per joint: max(fraction·max|dq|, 3·σ̂_v) [rad/s], σ̂_v the velocity noise from the second difference."""
    array_like(dq, "dq")
    dq = np.asarray(dq, dtype=float)
    peak = np.max(np.abs(dq), axis=0) if len(dq) else np.zeros(dq.shape[1])
    if len(dq) >= 5:
        d2 = np.diff(dq, 2, axis=0)
        mad = np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0)
        noise = 1.4826 * mad / np.sqrt(6.0)
    else:
        noise = np.zeros(dq.shape[1])
    return np.maximum(fraction * peak, 3.0 * noise)


def rest_threshold(
    ds: Dataset, model: RobotModel, terms: TermSelection, rest_velocity="auto", rest_fraction: float = REST_FRACTION
) -> np.ndarray:
    """Per joint, the speed [rad/s] below which a row of ``ds`` counts as at rest and is left out (zeros
    when Coulomb friction is not in the model or ``rest_velocity`` is 0/None; see the module text)."""
    ds = as_dataset(ds)
    nv = model.nv
    if (
        not terms.coulomb
        or rest_velocity is None
        or (not isinstance(rest_velocity, str) and np.ndim(rest_velocity) == 0 and float(rest_velocity) == 0.0)
    ):
        return np.zeros(nv)
    return rest_speeds(ds.dq, rest_velocity, model.joint_names, rest_fraction)


def rest_speeds(
    dq: np.ndarray, rest_velocity, joint_names: Sequence[str], rest_fraction: float = REST_FRACTION
) -> np.ndarray:
    """Per joint, the speed [rad/s] below which a row counts as at rest: ``rest_velocity`` "auto"
    (:func:`rest_thresholds` of ``dq`` (N, nv) [rad/s]), a number, one per joint, or None/0 (zeros: every
    row kept); a SpecError naming what is wrong otherwise."""
    array_like(dq, "dq")
    nv = len(joint_names)
    if rest_velocity is None:
        return np.zeros(nv)
    if isinstance(rest_velocity, str):
        if rest_velocity != "auto":
            raise SpecError(f"rest_velocity={rest_velocity!r}, expected 'auto', a number or one per joint")
        return rest_thresholds(dq, rest_fraction)
    try:
        v = np.asarray(rest_velocity, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise SpecError(f"rest_velocity={rest_velocity!r}, expected 'auto', a number or one per joint") from None
    if v.size not in (1, nv):
        raise SpecError(
            f"rest_velocity={rest_velocity!r}: {v.size} values, expected one or one per joint "
            f"({nv}: {', '.join(joint_names)})"
        )
    v = np.broadcast_to(v, (nv,)).copy()
    if np.any(~np.isfinite(v)) or np.any(v < 0):
        raise SpecError(f"rest_velocity={rest_velocity!r}, expected non-negative numbers [rad/s]")
    return v


def fit_mask(model: RobotModel, fit_joints: Sequence[str] | str | None = None) -> np.ndarray:
    """(nv,) booleans: the joints whose torque rows enter the fit, from ``"J1,J2"``, a list or None (all).

    SpecError for an empty list or a name that is not an active joint (naming the joints that are)."""
    names = as_robot(model).joint_names
    if fit_joints is None:
        return np.ones(len(names), bool)
    if isinstance(fit_joints, str):
        fit_joints = [j.strip() for j in fit_joints.split(",") if j.strip()]
    elif not isinstance(fit_joints, Sequence) or not all(isinstance(j, str) for j in fit_joints):
        raise SpecError(f"fit_joints {fit_joints!r}: expected joint names, some of {', '.join(names)}")
    unknown = [j for j in fit_joints if j not in names]
    if unknown:
        raise SpecError(
            f"fit joints: {', '.join(repr(j) for j in unknown)} is not an active joint of {model.name}; "
            f"expected some of {', '.join(names)}"
        )
    if not fit_joints:
        raise SpecError(f"fit joints: none given; expected some of {', '.join(names)}")
    return np.isin(names, list(fit_joints))


def motor_kept_rows(
    ds: Dataset, model: RobotModel, terms: TermSelection, rest_velocity="auto", rest_fraction: float = REST_FRACTION
) -> np.ndarray:
    """(N·nv,) booleans: False at the rows ``k·nv + j`` whose joint ``j`` is driven (``G[m, j] ≠ 0``) by a
    motor ``m`` at rest at sample ``k`` — when motor Coulomb friction (``motor_fc``) is in the model.

    A motor's Coulomb column is sign((G·dq)_m): it flips with the noise of the *motor* velocity, whatever the
    joint velocities are (a differential's motor stands still when dq5 = −dq6 while both joints move).  The
    motor's threshold is :func:`rest_thresholds` of the motor velocities (``"auto"``), or ``|G|·v`` for given
    joint thresholds ``v``; 0 or None keeps every row."""
    ds, model, terms = as_dataset(ds), as_robot(model), as_terms(terms)
    n, nv = ds.dq.shape
    drives = getattr(model, "drives", None)
    if "motor_fc" not in terms or drives is None:
        return np.ones(n * nv, bool)
    G = drives.matrix
    if isinstance(rest_velocity, str):
        rest_threshold(ds, model, TermSelection(), rest_velocity, rest_fraction)  # the same checks as the joints'
        thr = rest_thresholds(ds.dq @ G.T, rest_fraction)
    else:
        thr = np.abs(G) @ rest_threshold(ds, model, TermSelection(), rest_velocity, rest_fraction)
    if not np.any(thr > 0):
        return np.ones(n * nv, bool)
    still = np.abs(ds.dq @ G.T) < thr  # (N, motors)
    return ~((still.astype(float) @ (G != 0)) > 0).reshape(-1)


def kept_rows(ds: Dataset, threshold: np.ndarray) -> np.ndarray:
    """(N·nv,) booleans: the rows ``k·nv + j`` of a checked recording whose joint speed reaches its threshold."""
    ds = as_dataset(ds)
    if not np.any(threshold > 0):
        return np.ones(ds.dq.size, bool)
    return (np.abs(ds.dq) >= threshold).reshape(-1)


def kept_targets(datasets: Sequence[Dataset], keeps: Sequence[np.ndarray], nv: int) -> tuple[np.ndarray, np.ndarray]:
    """``(tau, joint)`` of :func:`stacked_targets` with ``joint`` in the smallest integer type (int8 up to
    127 joints: 1 byte per row instead of 8) and without ``sample``, which the problem computes when read."""
    if isinstance(nv, bool) or not isinstance(nv, (int, np.integer)) or nv < 1:
        raise SpecError(f"nv: got {nv!r}, expected the number of joints (a whole number ≥ 1)")
    if not isinstance(datasets, Sequence) or not isinstance(keeps, Sequence) or len(datasets) != len(keeps):
        raise SpecError("datasets and keeps: expected two sequences of the same length (a row mask per recording)")
    kind = np.int8 if nv <= 127 else np.intp
    taus = [ds.tau.reshape(-1)[keep] for ds, keep in zip(datasets, keeps)]
    joints = [np.tile(np.arange(nv, dtype=kind), ds.n)[keep] for ds, keep in zip(datasets, keeps)]
    if len(taus) == 1:
        return taus[0], joints[0]
    return np.concatenate(taus), np.concatenate(joints)
