"""Tracking figures (as seed 001 Figs. 9–10): reference and response, error, torque per joint."""

from __future__ import annotations

import numpy as np

from pinid.report.figures import new_figure


def tracking_figure(results: dict, *, title: str = ""):
    """One column per joint; rows: position (reference dashed), error, torque; one line per model.

    ``results`` is ``{model_name: TrackingResult}`` for one controller."""
    first = next(iter(results.values()))
    nv = len(first.joints)
    fig, axes = new_figure(3, nv, figsize=(5.5 * nv, 7.5), sharex=True, squeeze=False)
    for j, joint in enumerate(first.joints):
        ax_q, ax_e, ax_t = axes[:, j]
        ax_q.plot(first.t, first.q_d[:, j], "k--", lw=1.2, label="reference")
        for name, r in results.items():
            ax_q.plot(r.t, r.q[:, j], lw=1, label=name)
            ax_e.plot(r.t, 1e3 * r.error[:, j], lw=1, label=name)
            ax_t.plot(r.t, r.tau[:, j], lw=0.8, label=name)
        ax_q.set_title(joint)
        ax_q.set_ylabel("q [rad]")
        ax_e.set_ylabel("error [mrad]")
        ax_t.set_ylabel("torque [N·m]")
        ax_t.set_xlabel("t [s]")
        lim = max(np.percentile(np.abs(1e3 * r.error[len(r.t) // 4 :, j]), 99.5) for r in results.values())
        ax_e.set_ylim(-1.3 * lim, 1.3 * lim)
        for ax in (ax_q, ax_e, ax_t):
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig
