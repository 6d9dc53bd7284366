"""Identification figures: measured vs predicted torque with the error underneath (seed 000 Figs. 9, 12)
and the mean ± std of the absolute torque error per method (seed 000 Figs. 10, 13)."""

from __future__ import annotations

from typing import Mapping

import numpy as np

from pinid.report.figures import new_figure


def _thin(n: int, max_points: int) -> np.ndarray:
    """Indices that keep at most ``max_points`` evenly spread samples (plots, not analysis)."""
    step = max(1, int(np.ceil(n / max_points)))
    return np.arange(0, n, step)


def torque_comparison(t: np.ndarray, measured: np.ndarray, predicted: np.ndarray | Mapping[str, np.ndarray],
                      joints: list[str], *, title: str | None = None, window: float | None = 30.0,
                      max_points: int = 2_000):
    """Per joint: measured and predicted torque [N·m] against time, and the error τ_meas − τ_pred below.

    ``predicted`` is one ``(N, nv)`` array or ``{method: array}`` to overlay several methods.  Only the
    first ``window`` seconds are drawn (None: all), thinned to ``max_points`` samples.  Returns the figure.
    """
    t = np.asarray(t, dtype=float)
    measured = np.asarray(measured, dtype=float)
    preds = dict(predicted) if isinstance(predicted, Mapping) else {"predicted": predicted}
    if window is not None and len(t) and t[-1] - t[0] > window:
        n = int(np.searchsorted(t, t[0] + window))
        t, measured = t[:n], measured[:n]
        preds = {k: np.asarray(v)[:n] for k, v in preds.items()}
    nv = len(joints)
    fig, axes = new_figure(2 * nv, 1, figsize=(9, 2.6 * 2 * nv), sharex=True, squeeze=False,
                           gridspec_kw={"height_ratios": [2, 1] * nv})
    idx = _thin(len(t), max_points)
    for j, name in enumerate(joints):
        top, bottom = axes[2 * j, 0], axes[2 * j + 1, 0]
        top.plot(t[idx], measured[idx, j], color="black", lw=1.0, label="measured")
        for k, (m, p) in enumerate(preds.items()):
            p = np.asarray(p, dtype=float)
            top.plot(t[idx], p[idx, j], lw=0.9, label=m, alpha=0.85)
            bottom.plot(t[idx], measured[idx, j] - p[idx, j], lw=0.8, label=m, alpha=0.85)
        top.set_ylabel(f"{name}\nτ [N·m]")
        bottom.set_ylabel("error [N·m]")
        bottom.axhline(0.0, color="grey", lw=0.5)
        top.grid(alpha=0.3)
        bottom.grid(alpha=0.3)
        if j == 0:
            top.legend(loc="upper right", fontsize="small", ncol=min(4, 1 + len(preds)))
    axes[-1, 0].set_xlabel("time [s]")
    if title:
        fig.suptitle(title)
    # a fixed layout in inches (tight_layout measures every label with an extra draw: slow on long figures)
    width, height = fig.get_size_inches()
    top = 0.55 if title else 0.2
    fig.subplots_adjust(left=0.95 / width, right=1 - 0.15 / width, bottom=0.5 / height, top=1 - top / height,
                        hspace=0.35 / 2.6)
    return fig


def error_bars(metrics: Mapping[str, object], *, ax=None, title: str | None = None):
    """Bar chart of the mean ± std of the absolute torque error [N·m], per joint and method.

    ``metrics``: ``{method: TorqueMetrics}`` (or their ``to_dict()`` forms).  Returns the figure.
    """
    methods = list(metrics)
    per = {}
    for m, v in metrics.items():
        d = v.to_dict() if hasattr(v, "to_dict") else v
        per[m] = d
    joints = list(next(iter(per.values()))["per_joint"]) + ["all"] if per else []
    if ax is None:
        fig, ax = new_figure(figsize=(max(5, 1.2 * len(joints) * max(1, len(methods))), 3.8))
    else:
        fig = ax.figure
    width = 0.8 / max(1, len(methods))
    x = np.arange(len(joints))
    for k, m in enumerate(methods):
        d = per[m]
        rows = [d["per_joint"][j] for j in joints[:-1]] + [d["all"]]
        mean = [r["mean_abs"] if r["mean_abs"] is not None else np.nan for r in rows]
        std = [r["std_abs"] if r["std_abs"] is not None else np.nan for r in rows]
        bars = ax.bar(x + (k - (len(methods) - 1) / 2) * width, mean, width, yerr=std, capsize=3, label=m)
        for b, v in zip(bars, mean):
            if np.isfinite(v):
                ax.annotate(f"{v:.3g}", (b.get_x() + b.get_width() / 2, v), ha="center", va="bottom",
                            fontsize="x-small", xytext=(0, 1), textcoords="offset points")
    ax.set_xticks(x, joints)
    ax.set_ylabel("|τ error|, mean ± std [N·m]")
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize="small")
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig
