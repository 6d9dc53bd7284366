"""The torque channel's delay estimated on the training recordings (``--delay auto``).

Method: a 1-D search over the delay ``d`` minimising the least-squares residual of the torque model with
the torque read at ``t + d`` (:mod:`pinid.data.delay`).  The motion (q, dq, ddq) does not move with ``d``,
so the base regressor ``W`` is built once, on the samples whose shifted time stays inside the recording for
every ``d`` of the searched range; with ``W = Q·R`` the residual of the least-squares fit is
``‖τ_d‖² − ‖Qᵀ·τ_d‖²`` — one product per candidate.  Candidates: every sample step in ``[lo, hi]`` (default
±0.2 s; at most 201 on a coarser grid first, then every step around the best), then bounded Brent
(``scipy.optimize.minimize_scalar``) within one step of the best one, between samples (linear
interpolation).  Rows at rest are left out as in the fit (:mod:`pinid.problem.problem`).

``auto`` estimates one delay for every torque channel; ``auto-per-joint`` (``per_joint=True``) then starts from
it and searches each channel's own delay, the others fixed, the joints visited twice (:func:`_per_joint`).  A
separate option, not a change of ``auto``: with one shared lag (the usual case, one clock for every drive) the
per-channel search only adds nv − 1 free numbers that noise can move.  Only the training recordings are used;
the delays found are then applied to the training and the validation recordings.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pinid.data.dataset import Dataset
from pinid.data.delay import DELAY_RANGE, shifted
from pinid.errors import DataError, SpecError
from pinid.problem.problem import REST_FRACTION, base_regressor, check_dataset
from pinid.problem.rows import fit_mask, kept_rows, motor_kept_rows, rest_threshold
from pinid.model.base import BaseParameters, base_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel

_COARSE = 201  # most candidates of the first grid
SWEEPS = 2  # visits of every joint by the per-channel search (``per_joint``)


def estimate_delay(
    model: RobotModel,
    datasets: Sequence[Dataset],
    *,
    terms: TermSelection = TermSelection(),
    base: BaseParameters | None = None,
    bounds: tuple[float, float] = (-DELAY_RANGE, DELAY_RANGE),
    rest_velocity="auto",
    rest_fraction: float = REST_FRACTION,
    fit_joints=None,
    per_joint: bool = False,
) -> dict:
    """The delay [s] of the torque channels behind the positions on prepared recordings (module text).

    Returns ``{"delay": d, "bounds": [lo, hi], "residual": …, "candidates": n, "step": dt, "rows": …}``; with
    ``per_joint`` also one delay per torque channel (``"per_joint_delays"``, nv values [s], and
    ``"per_channel": True``; the residual then that of the per-channel delays)."""
    if not isinstance(per_joint, bool):
        raise SpecError(f"per_joint: got {type(per_joint).__name__}, expected True or False")
    lo, hi = (float(b) for b in bounds)
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise SpecError(f"delay search range [{lo:g}, {hi:g}] s: expected finite lo < hi")
    base = base if base is not None else base_parameters(model, terms)
    checked = [check_dataset(ds, model) for ds in datasets]
    fit = fit_mask(model, fit_joints)
    nv = model.nv
    parts = []  # (t, tau, sample indices inside, kept rows) per recording
    for ds in checked:
        t = ds.t
        inside = np.flatnonzero((t + lo >= t[0]) & (t + hi <= t[-1]))
        if inside.size == 0:
            raise DataError(
                f"{ds.source}: {ds.duration:g} s long, too short to search a torque delay in [{lo:g}, {hi:g}] s"
            )
        part = ds.select(inside)
        thr = rest_threshold(part, model, terms, rest_velocity, rest_fraction)
        keep = kept_rows(part, thr) & motor_kept_rows(part, model, terms, rest_velocity, rest_fraction)
        keep &= np.tile(fit, part.n)
        parts.append((t, ds.tau, part, keep))
    W = np.concatenate([base_regressor(model, terms, base, p, keep=k) for _, _, p, k in parts])
    if len(W) <= base.count:
        raise DataError("too few torque rows to estimate a delay; expected more rows than base parameters")
    Q = np.linalg.qr(W, mode="reduced")[0]

    def residual(d: float) -> float:
        y = np.concatenate(
            [
                np.column_stack([shifted(t, tau[:, j], p.t + d) for j in range(nv)]).reshape(-1)[k]
                for t, tau, p, k in parts
            ]
        )
        return float(y @ y - np.sum((Q.T @ y) ** 2))

    step = float(np.median(np.diff(checked[0].t)))
    d, r, count = _search(residual, lo, hi, step)
    out = {"delay": d, "bounds": [lo, hi], "residual": r, "candidates": count, "step": step, "rows": int(len(W))}
    if per_joint:
        out.update(_per_joint(parts, Q, np.full(nv, d), lo, hi, step, fit))
    return out


def _search(cost, lo: float, hi: float, step: float) -> tuple[float, float, int]:
    """``(d, cost(d), evaluations)``: the best delay [s] in [lo, hi] — every sample step (a coarser grid of at
    most ``_COARSE`` first, then every step around its best), then bounded Brent within one step."""
    import scipy.optimize  # loaded on use: only --delay auto needs it

    steps = np.arange(np.ceil(lo / step - 1e-9), np.floor(hi / step + 1e-9) + 1)
    stride = max(1, int(np.ceil(len(steps) / _COARSE)))
    coarse = steps[::stride]
    values = [cost(k * step) for k in coarse]
    best = coarse[int(np.argmin(values))]
    fine = steps[(steps >= best - stride) & (steps <= best + stride)]
    values = [cost(k * step) for k in fine]
    count = len(coarse) + len(fine)
    k = fine[int(np.argmin(values))]
    a, b = max(lo, (k - 1) * step), min(hi, (k + 1) * step)
    res = scipy.optimize.minimize_scalar(cost, bounds=(a, b), method="bounded", options={"xatol": 1e-3 * step})
    d, r = (float(res.x), float(res.fun)) if res.fun <= min(values) else (float(k * step), float(min(values)))
    return d, r, int(count + res.nfev)


def _per_joint(parts, Q: np.ndarray, start: np.ndarray, lo: float, hi: float, step: float, fit: np.ndarray) -> dict:
    """One delay per torque channel (``--delay auto-per-joint``): from the shared delay ``start``, a 1-D search
    (:func:`_search`) per joint on the residual with the other channels' delays fixed, the joints visited
    :data:`SWEEPS` times (Gauss–Seidel).  Channel ``j``'s torque is on its own rows only, so a candidate costs
    (its rows × base parameters): ``‖y‖² − ‖Qᵀy‖²`` with ``Qᵀy = Qᵀy₋ⱼ + Q[rows j]ᵀ·y_j``."""
    nv = len(start)
    d = start.astype(float).copy()
    owner = np.concatenate([np.tile(np.arange(nv), p.n)[k] for _, _, p, k in parts])  # each row's joint

    def channel(j: int, dj: float) -> np.ndarray:
        return np.concatenate([shifted(t, tau[:, j], p.t + dj)[k.reshape(p.n, nv)[:, j]] for t, tau, p, k in parts])

    y = np.empty(len(owner))
    for j in range(nv):
        y[owner == j] = channel(j, d[j])
    evaluations = 0
    residual = float(y @ y - np.sum((Q.T @ y) ** 2))
    for _ in range(SWEEPS):
        for j in range(nv):
            mine = owner == j
            if not mine.any() or not fit[j]:
                continue
            rest = np.where(mine, 0.0, y)
            c, rr, Qj = Q.T @ rest, float(rest @ rest), Q[mine]

            def cost(dj: float, j=j, c=c, rr=rr, Qj=Qj) -> float:
                yj = channel(j, dj)
                return float(rr + yj @ yj - np.sum((c + Qj.T @ yj) ** 2))

            d[j], residual, n = _search(cost, lo, hi, step)
            y[mine] = channel(j, d[j])
            evaluations += n
    return {
        "per_channel": True,
        "per_joint_delays": [float(x) for x in d],
        "residual": residual,
        "candidates_per_joint": evaluations,
    }
