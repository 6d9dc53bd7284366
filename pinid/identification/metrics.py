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

``all`` pools every joint's samples (one number for a whole method).
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


@dataclass
class TorqueMetrics:
    """Metrics per joint (``per_joint[name][metric]``) and pooled (``all[metric]``), over ``samples`` rows."""

    per_joint: dict[str, dict[str, float]]
    all: dict[str, float]
    samples: int

    def to_dict(self) -> dict:
        """Plain-dict form; NaN becomes None so that it is valid JSON."""
        clean = lambda d: {k: (None if not np.isfinite(v) else v) for k, v in d.items()}
        return {
            "per_joint": {j: clean(m) for j, m in self.per_joint.items()},
            "all": clean(self.all),
            "samples": self.samples,
        }

    @classmethod
    def from_dict(cls, d: dict) -> "TorqueMetrics":
        """Rebuild from :meth:`to_dict`'s output."""
        unclean = lambda m: {k: (float("nan") if v is None else float(v)) for k, v in m.items()}
        return cls({j: unclean(m) for j, m in d["per_joint"].items()}, unclean(d["all"]), int(d["samples"]))

    def table(self) -> list[list[str]]:
        """Rows ``[joint, rms, rel %, mean ± std, max]`` as text, for printing."""
        rows = []
        for name, m in list(self.per_joint.items()) + [("all", self.all)]:
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
    measured: np.ndarray, predicted: np.ndarray, joints: list[str], joint_index: np.ndarray | None = None
) -> TorqueMetrics:
    """Metrics of predicted against measured torques [N·m].

    Either ``(N, nv)`` arrays in the order of ``joints``, or stacked 1-D rows with ``joint_index`` giving
    each row's joint (rows of a joint may be missing, e.g. samples dropped at rest).
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
    pooled = _stats(measured.reshape(-1), (measured - predicted).reshape(-1))
    return TorqueMetrics(per_joint, pooled, int(samples))
