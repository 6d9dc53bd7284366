"""Tracking figures (as seed 001 Figs. 9–10): reference and response, error, torque per joint."""

from __future__ import annotations

import numpy as np

from pinid.errors import SpecError
from pinid.report.figures import envelope, fixed_layout, new_figure


#: Runs per drawn line (:func:`pinid.report.figures.envelope`): more than the pixel columns of a panel
#: (5.5 inches at 120 dpi), so the lines cover the pixels of every sample.
_COLUMNS = 1_000


def tracking_figure(results: dict, *, title: str = "", after: float = 0.0):
    """One column per joint; rows: position (reference dashed), error, torque; one line per model.

    ``results`` is ``{model_name: TrackingResult}`` for one controller.  ``after`` [s]: where the error
    statistics of :meth:`~pinid.control.controllers.TrackingResult.metrics` start; the start-up before it is
    shaded, and the error axis shows the settle band (± its ``band``) that the table's settling time uses."""
    first = next(iter(results.values()))
    nv = len(first.joints)
    t0 = float(first.t[0])
    fig, axes = new_figure(3, nv, figsize=(5.5 * nv, 7.5), sharex=True, squeeze=False)
    for j, joint in enumerate(first.joints):
        ax_q, ax_e, ax_t = axes[:, j]
        ax_q.plot(*envelope(first.t, first.q_d[:, j], _COLUMNS), "k--", lw=1.2, label="reference")
        for name, r in results.items():
            ax_q.plot(*envelope(r.t, r.q[:, j], _COLUMNS), lw=1, label=name)
            ax_e.plot(*envelope(r.t, 1e3 * r.error[:, j], _COLUMNS), lw=1, label=name)
            ax_t.plot(*envelope(r.t, r.tau[:, j], _COLUMNS), lw=0.8, label=name)
        band = 1e3 * max(0.02 * np.ptp(first.q_d[:, j]), 1e-3)  # as TrackingResult.metrics
        ax_e.axhline(band, color="0.4", ls=":", lw=0.8, label="settle band")
        ax_e.axhline(-band, color="0.4", ls=":", lw=0.8)
        ax_q.set_title(joint)
        ax_q.set_ylabel("q [rad]")
        ax_e.set_ylabel("error [mrad]")
        ax_t.set_ylabel("torque [N·m]")
        ax_t.set_xlabel("t [s]")
        tail = [
            np.abs(1e3 * r.error[r.t >= after, j]) if after > t0 else np.abs(1e3 * r.error[len(r.t) // 4 :, j])
            for r in results.values()
        ]
        lim = max([np.percentile(e, 99.5) for e in tail if e.size] + [1e-9])
        ax_e.set_ylim(-1.3 * max(lim, band), 1.3 * max(lim, band))
        for ax in (ax_q, ax_e, ax_t):
            ax.grid(alpha=0.3)
            if after > t0:
                ax.axvspan(t0, after, color="0.9", zorder=0)
        if after > t0:
            ax_e.text(t0, 1.25 * max(lim, band), " start-up: not in the table", fontsize=7, va="top", color="0.3")
    axes[0, 0].legend(fontsize=8)
    axes[1, 0].legend(fontsize=8)
    if title:
        fig.suptitle(title)
    # margins in inches (tight_layout's, with room for 5-character tick labels): a tight_layout pass
    # measures every tick label with a draw of its own, a third of the drawing time
    fixed_layout(fig, left=0.8, right=0.15, bottom=0.55, top=0.65 if title else 0.4, hspace=0.2, wspace=0.9)
    return fig


def tracking_models_figure(rms: dict, *, title: str = "", log: bool | None = None):
    """Grouped bars of the RMS tracking error [mrad] per joint, one bar per model × controller.

    ``rms`` is ``{controller: {model label: {joint: RMS [rad]}}}`` (the metrics' ``rms``, after the
    start-up).  Each model has its colour, each controller its hatch.  ``log``: a logarithmic axis; None
    (default) when the largest bar is more than 100 times the smallest.  Returns the figure."""
    if not isinstance(rms, dict) or not rms or not all(isinstance(v, dict) and v for v in rms.values()):
        raise SpecError(f"rms: got {type(rms).__name__}, expected {{controller: {{model: {{joint: RMS}}}}}}")
    controllers = list(rms)
    models = list(dict.fromkeys(m for per_model in rms.values() for m in per_model))
    joints = list(dict.fromkeys(j for per_model in rms.values() for r in per_model.values() for j in r))
    bars = [(m, c) for m in models for c in controllers if m in rms[c]]
    values = np.array([[1e3 * float(rms[c][m].get(j, np.nan)) for j in joints] for m, c in bars])
    positive = values[np.isfinite(values) & (values > 0)]
    if log is None:
        log = positive.size > 1 and positive.max() > 100 * positive.min()
    width = 0.8 / len(bars)
    rows = -(-len(bars) // (2 if len(controllers) > 1 else 3))  # of the legend, below the axes
    fig, ax = new_figure(figsize=(max(7.0, 1.2 + len(joints) * (0.5 + 0.28 * len(bars))), 4.2 + 0.22 * rows))
    x = np.arange(len(joints))
    hatches = ("", "//", "..", "xx", "\\\\", "++")
    for k, (m, c) in enumerate(bars):
        drawn = ax.bar(
            x - 0.4 + (k + 0.5) * width,
            values[k],
            width,
            color=f"C{models.index(m) % 10}",
            hatch=hatches[controllers.index(c) % len(hatches)],
            edgecolor="0.2",
            lw=0.5,
            label=f"{m}, {c}" if len(controllers) > 1 else m,
        )
        if values.size <= 24:  # the value on each bar while they are few enough to read
            ax.bar_label(drawn, fmt="%.2g", fontsize=7, padding=1)
    if log:
        ax.set_yscale("log")
    ax.set_xticks(x, joints, rotation=30 if len(joints) > 4 else 0)
    ax.set_ylabel("RMS tracking error [mrad]" + (" (log scale)" if log else ""))
    ax.grid(axis="y", alpha=0.3, which="both" if log else "major")
    ax.margins(y=0.12)
    ax.legend(
        fontsize=8,
        ncol=min(len(bars), 2 if len(controllers) > 1 else 3),
        loc="upper center",
        bbox_to_anchor=(0.5, -0.12 if len(joints) <= 4 else -0.2),
    )
    fig.suptitle(title or "tracking error per joint: every model × controller", fontsize=10)
    fig.tight_layout()
    return fig
