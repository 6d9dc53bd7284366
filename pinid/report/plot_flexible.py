"""Figures of flexible-joint identification (seed 003 Figs. 6-7, cost curves, parameter errors)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from pinid.report.figures import new_figure

_STYLES = {
    "measured": dict(color="0.2", lw=0.8, alpha=0.8),
    "flexible": dict(color="C0", lw=1.4),
    "rigid": dict(color="C3", lw=1.2, ls="--"),
}


def plot_angles(
    t: np.ndarray,
    measured: np.ndarray,
    simulated: Mapping[str, np.ndarray],
    joints: Sequence[str],
    *,
    title: str | None = None,
    errors: bool = True,
    degrees: bool = True,
    window=None,
):
    """Measured and simulated link angles per joint (a column each), errors underneath (seed Figs. 6-7).

    ``measured`` ``(N, nv)`` [rad]; ``simulated``: label → ``(N, nv)``; ``window``: ``(t0, t1)`` [s] to zoom.
    Returns the figure.
    """
    nv = len(joints)
    rows = 2 if errors else 1
    fig, axes = new_figure(rows, nv, figsize=(5.2 * nv, 3.2 * rows), squeeze=False, sharex=True)
    k = np.degrees if degrees else (lambda a: a)
    unit = "deg" if degrees else "rad"
    sel = slice(None) if window is None else (t >= window[0]) & (t <= window[1])
    for j, name in enumerate(joints):
        ax = axes[0, j]
        ax.plot(t[sel], k(measured[sel, j]), label="measured", **_STYLES["measured"])
        for label, q in simulated.items():
            ax.plot(t[sel], k(q[sel, j]), label=label, **_STYLES.get(label, {}))
        ax.set_title(f"{name} angle")
        ax.set_ylabel(f"angle [{unit}]")
        ax.grid(alpha=0.3)
        if errors:
            ax = axes[1, j]
            for label, q in simulated.items():
                e = q[sel, j] - measured[sel, j]
                rms = np.sqrt(np.mean((q[:, j] - measured[:, j]) ** 2))
                ax.plot(t[sel], k(e), label=f"{label} (RMS {k(rms):.3g} {unit})", **_STYLES.get(label, {}))
            ax.set_ylabel(f"simulated − measured [{unit}]")
            ax.legend(fontsize=8, loc="upper left")
            ax.grid(alpha=0.3)
        axes[-1, j].set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=8, loc="best")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_cost_curves(
    histories: Mapping[str, Sequence[Sequence[float]]], *, ax=None, title: str | None = None, ylabel: str = "best cost"
):
    """Best cost against the number of simulated parameter sets, one line per method (log scale)."""
    if ax is None:
        fig, ax = new_figure(figsize=(6.4, 4.0))
    else:
        fig = ax.figure
    for label, h in histories.items():
        h = np.asarray(h, dtype=float)
        if h.size == 0:
            continue
        ok = np.isfinite(h[:, 1])
        ax.plot(np.maximum(h[ok, 0], 1), h[ok, 1], label=label, drawstyle="steps-post")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("simulated parameter sets")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig


def plot_parameter_errors(
    errors: Mapping[str, Mapping[str, float]], *, ax=None, title: str | None = None, limit: float = 2.0
):
    """Relative error [%] of every fitted parameter, grouped bars per method; a band at ±``limit`` %."""
    if ax is None:
        fig, ax = new_figure(figsize=(10, 4.0))
    else:
        fig = ax.figure
    labels = list(errors)
    names = list(next(iter(errors.values()))) if errors else []
    x = np.arange(len(names))
    width = 0.8 / max(1, len(labels))
    for i, label in enumerate(labels):
        vals = np.array([100 * abs(errors[label].get(n, np.nan)) for n in names])
        ax.bar(x + (i - (len(labels) - 1) / 2) * width, np.maximum(vals, 1e-4), width, label=label)
    ax.axhline(limit, color="k", lw=0.8, ls=":")
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels(names, rotation=60, ha="right", fontsize=8)
    ax.set_ylabel("|fitted − truth| / |truth| [%]")
    ax.grid(alpha=0.3, axis="y", which="both")
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig
