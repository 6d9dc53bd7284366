"""Tracking figures (as seed 001 Figs. 9–10): reference and response, error, torque per joint."""

from __future__ import annotations

import numpy as np

from pinid.report.figures import new_figure


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
        ax_q.plot(first.t, first.q_d[:, j], "k--", lw=1.2, label="reference")
        for name, r in results.items():
            ax_q.plot(r.t, r.q[:, j], lw=1, label=name)
            ax_e.plot(r.t, 1e3 * r.error[:, j], lw=1, label=name)
            ax_t.plot(r.t, r.tau[:, j], lw=0.8, label=name)
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
    fig.tight_layout()
    return fig
