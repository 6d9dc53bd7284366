"""Torque-error metrics for training and validation.

Per joint, with ``e = τ_measured − τ_predicted`` [N·m]:

=================== ===========================================================================
``rms``             √mean(e²)
``rel_rms_percent`` 100·rms(e)/rms(τ_measured)
``mean_abs``        mean |e|       — seed 000's "mean ± std of the absolute torque error"
``std_abs``         std |e|          (Figs. 10 and 13), the population standard deviation
``max_abs``         max |e|
``p5_abs``          5th and 95th percentiles of |e|: the band the report's errors.png draws (an
``p95_abs``         absolute error never goes below zero, unlike mean − std)
=================== ===========================================================================

``all`` pools every joint's samples (one number for a whole method) when every joint has the same unit;
``per_unit`` pools the joints of each unit (``"N·m"`` for revolute joints, ``"N"`` for prismatic ones).
A robot with both gets NaN (None in JSON) in ``all``: an RMS of N·m and N together means nothing, so
every summary reads ``per_unit`` instead (:func:`pooled_labels`).

The yardstick (``measured``) is the caller's: pinid passes the torque as recorded for the headline
figures and the low-passed torque for the "filtered" ones (docs/identification.md, "The yardstick").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pinid.checks import array_like

METRIC_NAMES: tuple[str, ...] = ("rms", "rel_rms_percent", "mean_abs", "std_abs", "max_abs", "p5_abs", "p95_abs")


def _stats(measured: np.ndarray, error: np.ndarray) -> dict:
    if error.size == 0:
        return {k: float("nan") for k in METRIC_NAMES}
    a = np.abs(error)
    rms = float(np.sqrt(np.mean(error**2)))
    ref = float(np.sqrt(np.mean(measured**2)))
    p5, p95 = np.percentile(a, [5.0, 95.0])
    return {
        "rms": rms,
        "rel_rms_percent": 100.0 * rms / ref if ref > 0 else float("nan"),
        "mean_abs": float(a.mean()),
        "std_abs": float(a.std()),
        "max_abs": float(a.max()),
        "p5_abs": float(p5),
        "p95_abs": float(p95),
    }


def _stats_in(measured: np.ndarray, error: np.ndarray, buf: np.ndarray) -> dict:
    """:func:`_stats` — the same numbers, operation for operation — with ``error`` overwritten and ``buf``
    (which may be ``measured`` itself, then overwritten too) as the only scratch array (issue 35)."""
    if error.size == 0:
        return {k: float("nan") for k in METRIC_NAMES}
    ref = float(np.sqrt(np.mean(np.square(measured, out=buf))))
    rms = float(np.sqrt(np.mean(np.square(error, out=buf))))
    a = np.abs(error, out=buf)
    mean_abs, max_abs = float(a.mean()), float(a.max())
    std_abs = _std(a, scratch=error)
    p5, p95 = np.percentile(a, [5.0, 95.0], overwrite_input=True)  # the same order statistics, in place
    return {
        "rms": rms,
        "rel_rms_percent": 100.0 * rms / ref if ref > 0 else float("nan"),
        "mean_abs": mean_abs,
        "std_abs": std_abs,
        "max_abs": max_abs,
        "p5_abs": float(p5),
        "p95_abs": float(p95),
    }


def _std(a: np.ndarray, scratch: np.ndarray) -> float:
    """``a.std()`` of a 1-D float array, numpy's own steps (``numpy._core._methods._var``), the deviations
    in ``scratch`` instead of a new array."""
    n = a.size
    mean = np.add.reduce(a, keepdims=True)
    np.true_divide(mean, n, out=mean)
    x = np.subtract(a, mean, out=scratch)
    np.square(x, out=x)
    var = np.add.reduce(x)
    return float(np.sqrt(var.dtype.type(var / n)))


@dataclass
class TorqueMetrics:
    """Metrics per joint (``per_joint[name][metric]``) and pooled (``all[metric]``), over ``samples`` rows."""

    per_joint: dict[str, dict[str, float]]
    all: dict[str, float]
    samples: int
    units: dict[str, str] | None = None
    per_unit: dict[str, dict[str, float]] | None = None

    def pools(self) -> dict[str, dict[str, float]]:
        """The pooled metrics to show: ``{"all": …}`` for one unit, else ``{"all N·m": …, "all N": …}``."""
        if not self.per_unit or len(self.per_unit) <= 1:
            return {"all": self.all}
        return {f"all {u}": m for u, m in self.per_unit.items()}

    def headline(self, key: str = "rms") -> float:
        """One number for ranking methods: ``all[key]``, or with mixed units the mean of the per-unit
        relative RMS [%] (units cancel there)."""
        if not self.per_unit or len(self.per_unit) <= 1:
            return self.all[key]
        return float(np.mean([m["rel_rms_percent"] for m in self.per_unit.values()]))

    def to_dict(self) -> dict:
        """Plain-dict form; NaN becomes None so that it is valid JSON."""
        clean = lambda d: {k: (None if not np.isfinite(v) else v) for k, v in d.items()}
        out = {
            "per_joint": {j: clean(m) for j, m in self.per_joint.items()},
            "all": clean(self.all),
            "samples": self.samples,
        }
        if self.units is not None:
            out["units"] = dict(self.units)
            out["per_unit"] = {u: clean(m) for u, m in (self.per_unit or {}).items()}
        return out

    @classmethod
    def from_dict(cls, d: dict) -> "TorqueMetrics":
        """Rebuild from :meth:`to_dict`'s output."""
        unclean = lambda m: {k: (float("nan") if v is None else float(v)) for k, v in m.items()}
        per_unit = d.get("per_unit")
        return cls(
            {j: unclean(m) for j, m in d["per_joint"].items()},
            unclean(d["all"]),
            int(d["samples"]),
            d.get("units"),
            None if per_unit is None else {u: unclean(m) for u, m in per_unit.items()},
        )

    def table(self) -> list[list[str]]:
        """Rows ``[joint, rms, rel %, mean ± std, max]`` as text, for printing (the pooled rows per unit)."""
        rows = []
        for name, m in list(self.per_joint.items()) + list(self.pools().items()):
            rows.append(
                [
                    name,
                    f"{m['rms']:.4g}",
                    f"{m['rel_rms_percent']:.3g}",
                    f"{m['mean_abs']:.4g} ± {m['std_abs']:.4g}",
                    f"{m['max_abs']:.4g}",
                ]
            )
        return rows


def torque_metrics(
    measured: np.ndarray,
    predicted: np.ndarray,
    joints: list[str],
    joint_index: np.ndarray | None = None,
    units: list[str] | None = None,
) -> TorqueMetrics:
    """Metrics of predicted against measured torques [N·m] (forces [N] for prismatic joints).

    Either ``(N, nv)`` arrays in the order of ``joints``, or stacked 1-D rows with ``joint_index`` giving
    each row's joint (rows of a joint may be missing, e.g. samples dropped at rest).  ``units``: each
    joint's unit ("N·m" or "N"; default all N·m), pooled separately in ``per_unit``.
    """
    array_like(measured, "measured")
    measured = np.asarray(measured, dtype=float)
    predicted = np.asarray(predicted, dtype=float)
    if measured.shape != predicted.shape:
        raise ValueError(f"measured {measured.shape} and predicted {predicted.shape} torques differ in shape")
    if joint_index is None:
        if measured.ndim != 2 or measured.shape[1] != len(joints):
            raise ValueError(f"torques of shape {measured.shape}, expected (N, {len(joints)})")
        cols = [(measured[:, j], predicted[:, j]) for j in range(len(joints))]
        samples = measured.shape[0]
    else:
        joint_index = np.asarray(joint_index)
        cols = [(measured[joint_index == j], predicted[joint_index == j]) for j in range(len(joints))]
        samples = measured.shape[0]
    per_joint = {name: _stats(m, m - p) for name, (m, p) in zip(joints, cols)}
    units = ["N·m"] * len(joints) if units is None else list(units)
    kinds = list(dict.fromkeys(units))
    if len(kinds) == 1:
        pooled = _stats(measured.reshape(-1), (measured - predicted).reshape(-1))
        per_unit = {kinds[0]: pooled}
    else:  # N·m and N pooled together mean nothing: one pool per unit
        pooled = {k: float("nan") for k in METRIC_NAMES}
        per_unit = {}
        for u in kinds:
            ms = [m for (m, _), uu in zip(cols, units) if uu == u]
            es = [m - p for (m, p), uu in zip(cols, units) if uu == u]
            per_unit[u] = _stats(np.concatenate(ms), np.concatenate(es))
    return TorqueMetrics(per_joint, pooled, int(samples), dict(zip(joints, units)), per_unit)


def error_metrics(
    measured: np.ndarray,
    error: np.ndarray,
    joints: list[str],
    joint_index: np.ndarray | None = None,
    units: list[str] | None = None,
) -> TorqueMetrics:
    """:func:`torque_metrics` from the error ``measured − predicted`` [N·m] itself — the same numbers — with
    ``error`` used as scratch space (**overwritten**): at most one more array of its size, for long
    recordings (issue 35).  Arguments as :func:`torque_metrics`, ``error`` in place of ``predicted``."""
    array_like(measured, "measured")
    array_like(error, "error")
    measured = np.asarray(measured, dtype=float)
    error = np.asarray(error, dtype=float)
    if measured.shape != error.shape:
        raise ValueError(f"measured {measured.shape} and error {error.shape} torques differ in shape")
    if joint_index is None:
        if measured.ndim != 2 or measured.shape[1] != len(joints):
            raise ValueError(f"torques of shape {measured.shape}, expected (N, {len(joints)})")
        pick = lambda a, j: a[:, j].copy()  # noqa: E731
    else:
        joint_index = np.asarray(joint_index)
        pick = lambda a, j: a[joint_index == j]  # noqa: E731
    per_joint = {}
    for j, name in enumerate(joints):
        m = pick(measured, j)
        per_joint[name] = _stats_in(m, pick(error, j), m)
    units = ["N·m"] * len(joints) if units is None else list(units)
    kinds = list(dict.fromkeys(units))
    if len(kinds) == 1:
        flat = error.reshape(-1)
        pooled = _stats_in(measured.reshape(-1), flat, np.empty_like(flat))
        per_unit = {kinds[0]: pooled}
    else:  # as torque_metrics: each unit's joints one after the other
        pooled = {k: float("nan") for k in METRIC_NAMES}
        per_unit = {}
        for u in kinds:
            js = [j for j, uu in enumerate(units) if uu == u]
            m = np.concatenate([pick(measured, j) for j in js])
            per_unit[u] = _stats_in(m, np.concatenate([pick(error, j) for j in js]), m)
    return TorqueMetrics(per_joint, pooled, int(measured.shape[0]), dict(zip(joints, units)), per_unit)


def joint_units(model) -> list[str]:
    """Each active joint's torque unit: "N" for a prismatic joint, "N·m" otherwise."""
    from pinid.model.robot import as_robot  # here: metrics loads without Pinocchio

    model = as_robot(model)
    return ["N" if j.kind == "prismatic" else "N·m" for j in model.joints]
