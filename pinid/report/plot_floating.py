"""Figures of a floating-base identification (issue 46), for a whole-body robot (26 joints) as for two legs: the
base wrench measured against predicted per axis (forces [N] and moments [N·m] in panels of their own), the contact
phases, the base trajectory, the determined base parameters (the rest listed), and the errors of the rows used
(no joint panel without joint-torque rows).  matplotlib is imported inside the functions (Agg backend); each
function returns the figure.  Long traces are thinned to the pixels drawn (:func:`pinid.report.figures.envelope`),
so a figure costs about the same for 10 s or 10 minutes."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from pinid.report.figures import envelope, fixed_layout, new_figure

#: The six base rows: force then moment on the base link, in the base frame.
AXES: tuple[str, ...] = ("fx", "fy", "fz", "tx", "ty", "tz")
#: Columns of a trace (the pixels of a 10-inch panel at the report's resolution): the envelope's width.
COLUMNS = 900


def _window(t: np.ndarray, window: float | None) -> slice:
    t = np.asarray(t, dtype=float)
    if window is None or not len(t) or t[-1] - t[0] <= window:
        return slice(None)
    return slice(0, int(np.searchsorted(t, t[0] + window)))


def _trace(ax, t, y, **kw):
    x, v = envelope(np.asarray(t, dtype=float), np.asarray(y, dtype=float), COLUMNS)
    return ax.plot(x, v, **kw)


def wrench_comparison(
    t: np.ndarray,
    measured: np.ndarray,
    predicted: Mapping[str, np.ndarray],
    *,
    errors: Mapping[str, Mapping[str, float]] | None = None,
    title: str | None = None,
    window: float | None = 30.0,
):
    """The base wrench measured (grey) against each method's prediction, per axis: forces fx, fy, fz [N] in the
    left column, moments tx, ty, tz [N·m] in the right one, base frame, against time, the first ``window`` seconds.

    ``measured``, ``predicted[m]``: (N, 6) in :data:`AXES`' order.  ``errors``: ``{axis: {"rms", "rel_rms_percent"}}``
    of the first method, written in each panel's title.  Returns the figure."""
    from pinid.report.colors import method_color

    t = np.asarray(t, dtype=float)
    measured = np.asarray(measured, dtype=float)
    k = _window(t, window)
    fig, axes = new_figure(3, 2, figsize=(10, 6.6), sharex=True, squeeze=False)
    for i, axis in enumerate(AXES):
        ax = axes[i % 3, i // 3]
        _trace(ax, t[k], measured[k, i], color="0.45", lw=1.0, label="measured")
        for m, p in predicted.items():
            _trace(ax, t[k], np.asarray(p, dtype=float)[k, i], color=method_color(m), lw=0.9, label=f"{m} predicted")
        unit = "N" if i < 3 else "N·m"
        ax.set_ylabel(f"{axis} [{unit}]")
        e = (errors or {}).get(axis)
        if e:
            ax.set_title(
                f"{axis}: RMS error {e['rms']:.3g} {unit} ({e['rel_rms_percent']:.3g} % of the measured RMS)",
                fontsize="small",
            )
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    top = 0.4 if title else 0.05
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 1 - top / fig.get_figheight()),
               ncol=len(handles), fontsize="small", frameon=False)  # fmt: skip
    if title:
        fig.suptitle(title, fontsize="medium", y=1 - 0.12 / fig.get_figheight())
    fixed_layout(fig, left=0.85, right=0.2, bottom=0.5, top=top + 0.55, hspace=0.45, wspace=0.85)
    return fig


def contact_phases(
    t: np.ndarray,
    forces: Mapping[str, np.ndarray],
    phases: Mapping[str, np.ndarray] | None = None,
    *,
    threshold: float | None = None,
    title: str | None = None,
    window: float | None = 30.0,
):
    """The normal force under each contact link [N] (one panel each, the link's own z) with its contact phases
    shaded: ``phases[link]`` (booleans, a recording's contact channel) when given, else where the force exceeds
    ``threshold`` [N] (default 5 % of the largest force).  The share of time in contact is in each title.
    Returns the figure."""
    t = np.asarray(t, dtype=float)
    links = list(forces)
    k = _window(t, window)
    fig, axes = new_figure(
        max(1, len(links)), 1, figsize=(10, 1.2 + 1.5 * max(1, len(links))), sharex=True, squeeze=False
    )
    peak = max((float(np.max(np.abs(f))) for f in forces.values() if len(f)), default=1.0)
    level = 0.05 * peak if threshold is None else float(threshold)
    for ax, link in zip(axes[:, 0], links):
        f = np.asarray(forces[link], dtype=float)
        given = phases is not None and link in phases and phases[link] is not None
        on = np.asarray(phases[link], bool) if given else f > level
        _trace(ax, t[k], f[k], color="C0", lw=1.0)
        tk, onk = t[k], on[k]
        edges = np.flatnonzero(np.diff(np.r_[0, onk.astype(int), 0]))
        for a, b in zip(edges[::2], edges[1::2]):
            ax.axvspan(tk[a], tk[min(b, len(tk)) - 1], color="C2", alpha=0.18, lw=0)
        how = "contact channel" if given else f"force > {level:.3g} N"
        ax.set_title(f"{link}: in contact {100 * on.mean():.0f} % of the time (shaded: {how})", fontsize="small")
        ax.set_ylabel("normal force [N]")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    if title:
        fig.suptitle(title, fontsize="medium")
    fixed_layout(fig, left=0.85, right=0.2, bottom=0.5, top=0.6 if title else 0.3, hspace=0.45)
    return fig


def base_trajectory(
    recordings: Sequence[Mapping],
    *,
    title: str | None = None,
):
    """The base link's path seen from above (x–y [m], equal axes, a dot at each recording's start), its height z
    [m] and its heading (yaw [°], unwrapped) against time; ``recordings``: ``[{"label", "t", "position" (N, 3),
    "yaw" (N,) [rad]}]`` (e.g. the training and the validation ranges).  Returns the figure."""
    import matplotlib.gridspec as gridspec

    fig, _ = new_figure(figsize=(10, 4.6))
    fig.clf()
    gs = gridspec.GridSpec(2, 2, figure=fig, width_ratios=[1.0, 1.25])
    top, zax, yax = fig.add_subplot(gs[:, 0]), fig.add_subplot(gs[0, 1]), fig.add_subplot(gs[1, 1])
    for i, rec in enumerate(recordings):
        c = f"C{i}"
        t, p = np.asarray(rec["t"], dtype=float), np.asarray(rec["position"], dtype=float)
        top.plot(p[:, 0], p[:, 1], color=c, lw=1.0, label=rec.get("label"))  # a path: every sample, in order
        top.plot(p[:1, 0], p[:1, 1], "o", color=c, ms=5)
        _trace(zax, t, p[:, 2], color=c, lw=1.0)
        _trace(yax, t, np.degrees(np.unwrap(np.asarray(rec["yaw"], dtype=float))), color=c, lw=1.0)
    top.set_aspect("equal", adjustable="datalim")
    top.set_xlabel("x [m]")
    top.set_ylabel("y [m]")
    top.set_title("seen from above (dot: start)", fontsize="small")
    top.grid(alpha=0.3)
    if any(r.get("label") for r in recordings):
        top.legend(fontsize="small", frameon=False)
    zax.set_ylabel("z [m]")
    zax.tick_params(labelbottom=False)
    yax.set_ylabel("yaw [°]")
    yax.set_xlabel("time [s]")
    for ax in (zax, yax):
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title, fontsize="medium")
    fixed_layout(fig, left=0.85, right=0.2, bottom=0.55, top=0.6 if title else 0.3, hspace=0.25, wspace=0.9)
    return fig


def determined_parameters(
    names: Sequence[str],
    nominal: Sequence[float],
    scale: Sequence[float],
    estimates: Mapping[str, Mapping],
    determined: Sequence[bool],
    *,
    fill: int = 12,
    title: str | None = None,
):
    """:func:`pinid.report.plot_parameters.parameter_plausibility` of the determined base parameters (those
    ``determined`` marks), then, when fewer than ``fill``, the best determined of the rest (smallest 2σ over the
    natural scale of the first method) up to ``fill``, their names marked "(barely)" in grey; a line under the axes
    counts the ones left out (the report lists them).  Returns the figure."""
    from pinid.report.plot_parameters import parameter_plausibility

    det = np.asarray(determined, bool)
    first = next(iter(estimates.values()))
    sc = np.abs(np.asarray(scale, dtype=float))
    ratio = 2 * np.asarray(first.get("std") if first.get("std") is not None else [np.nan] * len(names), dtype=float)
    ratio = np.where(np.isfinite(ratio), ratio / np.where(sc > 0, sc, 1.0), np.inf)
    rest = [k for k in np.argsort(ratio, kind="stable") if not det[k] and np.isfinite(ratio[k])]
    keep = [*np.flatnonzero(det), *rest[: max(0, fill - int(det.sum()))]]
    if not keep:
        fig, ax = new_figure(figsize=(9, 1.6))
        ax.axis("off")
        ax.text(0.5, 0.5, f"none of the {len(names)} base parameters has a σ", ha="center", va="center")
        return fig
    pick = lambda v: [v[i] for i in keep]  # noqa: E731
    sub = {}
    for m, e in estimates.items():
        std = e.get("std")
        sub[m] = {
            **e,
            "value": np.asarray(e["value"], dtype=float)[keep],
            "std": None if std is None else pick(list(std)),
        }
    shown = [names[k] + ("" if det[k] else " (barely)") for k in keep]
    nd, left = int(det.sum()), len(names) - len(keep)
    if title is None:
        title = (
            f"base parameters: {nd} of {len(names)} determined (2σ ≤ 10 % of natural scale)"
            + (f", {len(keep) - nd} next best (grey)" if len(keep) > nd else "")
            + (f"; {left} more in the report" if left else "")
        )
    fig = parameter_plausibility(shown, pick(list(nominal)), pick(list(sc)), sub, title=title)
    for label in fig.axes[0].get_yticklabels():
        if label.get_text().endswith(" (barely)"):
            label.set_color("0.45")
    return fig


def chain_motion(
    t: np.ndarray,
    q: np.ndarray,
    joints: Sequence[str],
    chains: Sequence[Sequence[str]],
    *,
    title: str | None = None,
    window: float | None = 30.0,
):
    """The joint positions [rad] against time, one panel per chain of joints
    (:func:`pinid.identification.floating.joint_chains`: a leg, an
    arm …), a line and a legend entry per joint: a whole-body robot's 26 joints in 6 panels.  Returns the figure."""
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    k = _window(t, window)
    col = {j: i for i, j in enumerate(joints)}
    ncols = min(3, max(1, len(chains)))
    nrows = -(-len(chains) // ncols)
    fig, axes = new_figure(nrows, ncols, figsize=(10, 0.9 + 2.7 * nrows), sharex=True, squeeze=False)
    for n, chain in enumerate(chains):
        ax = axes[n // ncols, n % ncols]
        for i, j in enumerate(chain):
            _trace(ax, t[k], q[k, col[j]], color=f"C{i % 10}", lw=0.9, label=j)
        ax.legend(fontsize="x-small", frameon=False, loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3,
                  handlelength=1.2, columnspacing=0.8, borderaxespad=0.1)  # fmt: skip
        ax.grid(alpha=0.3)
        if n % ncols == 0:
            ax.set_ylabel("q [rad]")
    for n in range(len(chains), nrows * ncols):
        axes[n // ncols, n % ncols].set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    if title:
        fig.suptitle(title, fontsize="medium")
    fixed_layout(fig, left=0.7, right=0.15, bottom=0.5, top=0.95 if title else 0.6, hspace=0.65, wspace=0.55)
    return fig


def wrench_errors(
    axes_errors: Mapping[str, Mapping[str, Mapping[str, float]]],
    joints: Mapping[str, Mapping[str, Mapping[str, float]]] | None = None,
    *,
    title: str | None = None,
):
    """The RMS error of each base row per method: forces fx, fy, fz [N] in one panel, moments tx, ty, tz [N·m] in
    another (the value and the % of the measured RMS written upright), and, only when joint-torque rows were used,
    the joints' [N·m] in a third below them, as wide as the figure.  ``axes_errors``: ``{method: {axis: {"rms", "rel_rms_percent"}}}``; ``joints``:
    ``{method: {joint: {"rms", "rel_rms_percent"}}}`` or None.  Returns the figure."""
    from pinid.report.colors import method_color

    import matplotlib.gridspec as gridspec

    methods = list(axes_errors)
    groups = [("forces [N]", AXES[:3], axes_errors), ("moments [N·m]", AXES[3:], axes_errors)]
    joint_names = [] if not joints else list(next(iter(joints.values())))
    if joint_names:
        groups.append(("joint torques", tuple(joint_names), joints))
    longest = max((len(n) for n in joint_names), default=0)
    bottom = 0.5 + (0.065 * longest if joint_names else 0.0)  # the joints' names, turned upright
    height = 3.6 + (2.8 + 0.065 * longest if joint_names else 0.0)
    fig, _ = new_figure(figsize=(10, height))
    fig.clf()
    grid = gridspec.GridSpec(2 if joint_names else 1, 2, figure=fig)
    axes = [fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[0, 1])]
    if joint_names:
        axes.append(fig.add_subplot(grid[1, :]))
    width = 0.8 / max(1, len(methods))
    for ax, (label, names, table) in zip(axes, groups):
        x = np.arange(len(names))
        top = 0.0
        for i, m in enumerate(methods):
            src = table.get(m, {})
            v = np.array([src.get(n, {}).get("rms", np.nan) for n in names], dtype=float)
            rel = [src.get(n, {}).get("rel_rms_percent", np.nan) for n in names]
            xs = x + (i - (len(methods) - 1) / 2) * width
            ax.bar(xs, v, width, color=method_color(m), label=m)
            for xi, vi, ri in zip(xs, v, rel):
                if np.isfinite(vi):  # upright, so that neighbouring bars' values never overlap
                    ax.annotate(f"{vi:.3g} ({ri:.3g} %)", (xi, vi), xytext=(0, 2), textcoords="offset points",
                                ha="center", va="bottom", rotation=90, fontsize="xx-small")  # fmt: skip
                    top = max(top, vi)
        ax.set_xticks(x, names, rotation=0 if len(names) <= 6 else 90, fontsize="small")
        ax.set_ylim(0, 1.9 * top if top > 0 else 1.0)
        unit = "" if names in (AXES[:3], AXES[3:]) else " [N·m]"
        ax.set_ylabel(f"RMS error, {label}{unit}", fontsize="small")
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    top = 0.45 if title else 0.1
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 1 - top / fig.get_figheight()),
               ncol=len(methods), fontsize="small", frameon=False)  # fmt: skip
    if title:
        fig.suptitle(title, fontsize="medium", y=1 - 0.15 / fig.get_figheight())
    fixed_layout(fig, left=0.75, right=0.2, bottom=bottom, top=top + 0.35, wspace=1.0, hspace=0.55)
    return fig
