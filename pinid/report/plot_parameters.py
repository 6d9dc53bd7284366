"""The parameter-plausibility figure of the identification report: per base parameter, a method's estimate
with its ±2σ interval against the URDF's value and, when known, the true value, every one divided by the
parameter's natural scale (mass, mass·length, mass·length² of its bodies; 1 for joint terms:
:attr:`pinid.problem.problem.IdentificationProblem.natural_scale`), so that all of them share one axis."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from pinid.report.figures import fixed_layout, new_figure


def _scaled(values, scale: np.ndarray) -> np.ndarray:
    return np.asarray([np.nan if v is None else float(v) for v in values], dtype=float) / scale


def parameter_plausibility(
    names: Sequence[str],
    nominal: Sequence[float],
    scale: Sequence[float] | None,
    estimates: Mapping[str, Mapping],
    *,
    truth: Sequence[float | None] | None = None,
    title: str | None = None,
):
    """Per base parameter (one row each, top to bottom in the order of ``names``): every method of
    ``estimates`` as a dot with its ±2σ bar, the URDF's value (``nominal``, an open square) and ``truth``
    (a black cross, when given; None entries skipped), all divided by ``scale`` (each parameter's natural
    magnitude; None: the largest of |URDF| and the estimates, at least 1e-12).

    ``estimates``: ``{method: {"value": (nb,), "std": (nb,) or None, "consistent": bool}}``; a NaN or
    missing σ (metaheuristics, a value on a bound) draws the estimate alone.  A method that is not
    physically consistent is drawn hollow with a dashed bar and says so in the legend.  One colour per
    method (:func:`pinid.report.colors.method_color`); the legend sits above the axes.  Returns the figure.
    """
    from pinid.report.colors import method_color

    names = list(names)
    nb = len(names)
    nominal_v = np.asarray([np.nan if v is None else float(v) for v in nominal], dtype=float)
    values = {m: np.asarray(e["value"], dtype=float) for m, e in estimates.items()}
    if scale is None or len(scale) != nb:
        stack = np.vstack([np.abs(nominal_v)] + [np.abs(v) for v in values.values()])
        s = np.nanmax(stack, axis=0)
    else:
        s = np.abs(np.asarray(scale, dtype=float))
    s = np.where(np.isfinite(s) & (s > 1e-12), s, 1e-12)
    y = np.arange(nb)[::-1].astype(float)
    rows = max(1, nb)
    head = (0.45 if title else 0.1) + 0.26 * -(-(len(estimates) + 1 + (truth is not None)) // 3) + 0.1
    fig, ax = new_figure(figsize=(9, min(0.22 * rows + 0.9 + head, 24)))
    for k in range(0, nb, 2):  # shaded bands: which row a marker belongs to
        ax.axhspan(y[k] - 0.5, y[k] + 0.5, color="0.95", zorder=0, lw=0)
    ax.axvline(0.0, color="0.5", lw=0.6, zorder=1)
    ax.plot(nominal_v / s, y, "s", mfc="none", mec="black", ms=6, zorder=4, label="URDF")
    if truth is not None:
        ax.plot(_scaled(truth, s), y, "x", color="black", ms=6, mew=1.5, zorder=5, label="truth")
    offsets = np.linspace(-0.22, 0.22, len(values)) if len(values) > 1 else [0.0]
    for dy, (m, est) in zip(offsets, estimates.items()):
        c = method_color(m)
        v = values[m] / s
        std = est.get("std")
        ok = bool(est.get("consistent", True))
        label = m if ok else f"{m} (not physically consistent)"
        if std is not None:
            err = 2.0 * np.asarray([np.nan if x is None else float(x) for x in std], dtype=float) / s
            has = np.isfinite(err)
            if has.any():
                bars = ax.errorbar(
                    v[has], y[has] + dy, xerr=err[has], fmt="none", ecolor=c, elinewidth=1.4, capsize=2.5, zorder=3
                )
                if not ok:
                    for part in bars.lines[2]:
                        part.set_linestyle("--")
        ax.plot(v, y + dy, "o", color=c, mfc=c if ok else "white", mew=1.4, ms=5, zorder=6, label=label)
    ax.set_yticks(y, names, fontsize="small")
    ax.set_ylim(-0.6, nb - 0.4)
    ax.set_xlabel("value / natural scale of the parameter (URDF's masses, lengths; 1 for joint terms)")
    ax.grid(axis="x", alpha=0.3)
    if title:
        fig.suptitle(title, fontsize="medium", y=1 - 0.2 / fig.get_figheight())
    handles, labels = ax.get_legend_handles_labels()
    fig.legend(
        handles,
        labels,
        loc="upper center",
        bbox_to_anchor=(0.5, 1 - (0.45 if title else 0.1) / fig.get_figheight()),
        ncol=3,
        fontsize="small",
        frameon=False,
    )
    longest = max((len(n) for n in names), default=4)
    fixed_layout(fig, left=0.3 + 0.07 * longest, right=0.2, bottom=0.55, top=head)
    return fig
