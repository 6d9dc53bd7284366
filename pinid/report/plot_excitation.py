"""Figures of excitation design: the trajectory within its limit bands, and optimiser convergence."""

from __future__ import annotations

import numpy as np

from pinid.report.figures import fixed_layout, new_figure


def plot_excitation(trajectory, spec=None, *, points: int = 1000, title: str | None = None):
    """q, dq and ddq of every joint over one period (rows), one column per joint, with the limits shaded.

    ``spec``: an :class:`pinid.excitation.spec.ExcitationSpec` whose limits are drawn (the region beyond a
    limit is shaded red, the margin, if any, dashed).  Returns the figure.
    """
    t = np.linspace(0.0, trajectory.period, points)
    values = [trajectory.derivative(t, k) for k in range(3)]
    nv = len(trajectory.joints)
    fig, axes = new_figure(3, nv, figsize=(3.6 * nv + 0.8, 7.2), sharex=True, squeeze=False)
    labels = ["q [rad]", "dq [rad/s]", "ddq [rad/s²]"]
    for j, name in enumerate(trajectory.joints):
        for r in range(3):
            ax = axes[r, j]
            y = values[r][:, j]
            ax.plot(t, y, color="C0", lw=1.4)
            if spec is not None:
                i = list(spec.joints).index(name)
                if r == 0:
                    lo, hi, mlo, mhi = spec.q_min[i], spec.q_max[i], spec.lower[i], spec.upper[i]
                    ax.axhline(spec.q0[i], color="0.6", lw=0.8, ls=":")
                else:
                    lim = spec.dq_max[i] if r == 1 else spec.ddq_max[i]
                    mlim = spec.velocity[i] if r == 1 else spec.acceleration[i]
                    lo, hi, mlo, mhi = -lim, lim, -mlim, mlim
                span = max(hi - lo, 1e-9)
                ax.axhspan(hi, hi + 0.12 * span, color="C3", alpha=0.15, lw=0)
                ax.axhspan(lo - 0.12 * span, lo, color="C3", alpha=0.15, lw=0)
                ax.axhline(hi, color="C3", lw=1.0)
                ax.axhline(lo, color="C3", lw=1.0)
                if spec.margin:
                    ax.axhline(mhi, color="C3", lw=0.8, ls="--")
                    ax.axhline(mlo, color="C3", lw=0.8, ls="--")
                ax.set_ylim(lo - 0.12 * span, hi + 0.12 * span)
            if j == 0:
                ax.set_ylabel(labels[r])
            if r == 0:
                ax.set_title(name)
            ax.grid(alpha=0.3)
        axes[2, j].set_xlabel("t [s]")
    if title:
        fig.suptitle(title)
    # margins in inches (tight_layout's for a 6-DOF arm, with room for 5-character tick labels): a
    # tight_layout pass measures every tick label with a draw of its own, a quarter of the drawing time
    fixed_layout(fig, left=0.85, right=0.2, bottom=0.55, top=0.7 if title else 0.4, hspace=0.2, wspace=0.7)
    return fig


def plot_convergence(
    histories: dict, ax=None, *, references: dict | None = None, ylabel: str = "condition number", log: bool = True
):
    """Best value per iteration of several optimisers (as seed 001 Fig. 3a).

    ``histories``: name -> array of best values (index 0 = initial population); ``references``:
    name -> value drawn as a horizontal dashed line (e.g. the default design, seed 001 Table 3).
    """
    if ax is None:
        fig, ax = new_figure(figsize=(6.4, 4.0))
    else:
        fig = ax.figure
    for k, (name, h) in enumerate(histories.items()):
        h = np.asarray(h, dtype=float)
        ax.plot(np.arange(len(h)), h, label=name, color=f"C{k}", lw=1.5)
    for k, (name, value) in enumerate((references or {}).items()):
        ax.axhline(value, ls="--", lw=1.0, color=f"C{len(histories) + k}", label=name)
    if log:
        ax.set_yscale("log")
    ax.set_xlabel("iteration")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.tight_layout()
    return fig
