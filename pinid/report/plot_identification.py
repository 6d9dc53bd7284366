"""Identification figures: measured vs predicted torque with the error underneath (seed 000 Figs. 9, 12),
the absolute torque error per joint and method as mean and [p5, p95] band (seed 000 Figs. 10, 13 draw
mean ± std, which goes below zero), and the recorded excitation."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pinid.report.figures import close_figure, envelope, fixed_layout, new_figure, png_bytes


def _line(t: np.ndarray, y: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """``(t, y)`` for a line of at most ``max_points`` points that the eye cannot tell from every sample's:
    :func:`~pinid.report.figures.envelope` over ``max_points // 2`` runs (about one per pixel column of the
    report's time series at :data:`~pinid.report.figures.DPI`), each run's minimum and maximum in time order,
    so that peaks and noise bands stay (every k-th sample would drop them)."""
    return envelope(t, y, max(1, max_points // 2))


def torque_comparison(
    t: np.ndarray,
    measured: np.ndarray,
    predicted: np.ndarray | Mapping[str, np.ndarray],
    joints: list[str],
    *,
    filtered: np.ndarray | None = None,
    units: list[str] | None = None,
    title: str | None = None,
    window: float | None = 30.0,
    max_points: int = 1_600,
    colors: Mapping[str, str] | None = None,
):
    """Per joint: measured and predicted torque [N·m] against time, and the prediction error below.

    ``predicted`` is one ``(N, nv)`` array or ``{method: array}`` to overlay several methods (each in its
    colour, :func:`pinid.report.colors.method_color`, drawn above the measurements).  ``measured`` is the
    torque as recorded (light grey); ``filtered``, when given, the torque after pinid's low-pass (a thin
    dark line).  The error panel shows τ_meas − τ_pred against the torque as recorded (raw, light) and,
    with ``filtered``, against the low-passed torque (filtered, full colour).  ``units``: each joint's
    unit (default N·m).  Only the first ``window`` seconds are drawn (None: all), thinned to ``max_points``
    samples (each run's minimum and maximum: :func:`_line`).  The legend sits above the panels.  ``colors``:
    ``{name: colour}`` for predictions that are not methods (the wearer's three models; default: each name's
    :func:`method_color`).  Returns the
    figure.
    """
    preds = dict(predicted) if isinstance(predicted, Mapping) else {"predicted": predicted}
    fig, _ = _torque_figure(
        t,
        measured,
        preds,
        joints,
        filtered=filtered,
        units=units,
        title=title,
        window=window,
        max_points=max_points,
        colors=colors,
    )
    return fig


def _window(t, arrays: dict, window: float | None) -> tuple[np.ndarray, dict, int]:
    """``t`` and ``arrays`` (None kept) cut to the first ``window`` seconds; the number of samples kept."""
    t = np.asarray(t, dtype=float)
    n = len(t)
    if window is not None and len(t) and t[-1] - t[0] > window:
        n = int(np.searchsorted(t, t[0] + window))
    return t[:n], {k: None if v is None else np.asarray(v, dtype=float)[:n] for k, v in arrays.items()}, n


def _legend_columns(labels: list[str], width: float) -> int:
    """How many legend columns (at most 4) of ``labels`` fit a figure ``width`` inches wide at fontsize "small"
    (about 0.05 in per character and 0.5 in for the line and the gaps, measured on the figures): long model names (the wearer's "exo + table
    wearer: error, raw") take fewer, so that the last column is not cut at the figure's edge (issue 47)."""
    longest = max((len(label) for label in labels), default=0)
    return max(1, min(4, len(labels), int(0.97 * width // (0.05 * longest + 0.5))))


def _legend_above(fig, handles: list, top: float) -> tuple[object, float]:
    """A figure legend of ``handles`` centred above the panels, ``top`` inches below the figure's top edge;
    returns it and the height it takes [in]."""
    ncol = _legend_columns([h.get_label() for h in handles], fig.get_figwidth())
    rows = -(-len(handles) // ncol)
    legend = fig.legend(
        handles=handles,
        loc="upper center",
        bbox_to_anchor=(0.5, 1 - top / fig.get_figheight()),
        ncol=ncol,
        fontsize="small",
        frameon=False,
    )
    return legend, 0.24 * rows + 0.1


def _torque_figure(
    t,
    measured,
    preds: dict,
    joints,
    *,
    filtered=None,
    units=None,
    title=None,
    window=30.0,
    max_points: int = 1_600,
    colors: Mapping[str, str] | None = None,
):
    """:func:`torque_comparison`'s figure and a function ``redraw(method, prediction, title)`` that puts
    another single method's prediction into it (lines, errors, colours, legend, title, autoscaled y)."""
    from pinid.report.colors import method_color

    t, cut, n = _window(t, {"measured": measured, "filtered": filtered, **preds}, window)
    measured, filtered = cut.pop("measured"), cut.pop("filtered")
    preds = cut
    nv = len(joints)
    f = filtered is not None
    labels = ["measured (as recorded)", *(["measured, low-passed"] if f else [])] + [
        f"{m}: {kind}" for m in preds for kind in ("predicted", "error, raw", "error, filtered")[: 2 + f]
    ]  # measured, low-passed; per method: 2 or 3 lines
    legend_rows = -(-len(labels) // _legend_columns(labels, 9))
    head = (0.5 if title else 0.1) + 0.24 * legend_rows + 0.1
    fig, axes = new_figure(
        2 * nv,
        1,
        figsize=(9, 2.0 * 2 * nv + head - 0.2),
        sharex=True,
        squeeze=False,
        gridspec_kw={"height_ratios": [2, 1] * nv},
    )
    lines: list[tuple] = []  # per joint: (top, bottom, prediction, raw error, filtered error) of the last method
    for j, name in enumerate(joints):
        top, bottom = axes[2 * j, 0], axes[2 * j + 1, 0]
        bottom.axhline(0.0, color="grey", lw=0.5)  # first: in the data limits, as after a redraw's relim
        top.plot(*_line(t, measured[:, j], max_points), color="0.75", lw=0.8, zorder=1, label="measured (as recorded)")
        if filtered is not None:
            top.plot(*_line(t, filtered[:, j], max_points), color="0.3", lw=0.5, zorder=2, label="measured, low-passed")
        line = err = ferr = None
        for m, p in preds.items():
            c = (colors or {}).get(m) or method_color(m)
            (line,) = top.plot(*_line(t, p[:, j], max_points), color=c, lw=1.1, zorder=3, label=f"{m}: predicted")
            (err,) = bottom.plot(
                *_line(t, measured[:, j] - p[:, j], max_points), color=c, lw=0.6, alpha=0.35, label=f"{m}: error, raw"
            )
            if filtered is not None:
                (ferr,) = bottom.plot(
                    *_line(t, filtered[:, j] - p[:, j], max_points),
                    color=c,
                    lw=0.9,
                    zorder=3,
                    label=f"{m}: error, filtered",
                )
        lines.append((top, bottom, line, err, ferr))
        unit = "N·m" if units is None else units[j]
        top.set_ylabel(f"{name}\nτ [{unit}]")
        bottom.set_ylabel(f"error [{unit}]")
        top.grid(alpha=0.3)
        bottom.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    # 0.2 inch from the top edge, above the legend (suptitle's default, 2 % of the height, is inside it)
    heading = fig.suptitle(title, y=1 - 0.2 / fig.get_figheight()) if title else None
    legend_top = 0.5 if title else 0.1

    def handles() -> list:
        return list(axes[0, 0].get_lines()) + [ln for ln in axes[1, 0].get_lines() if ln.get_label()[0] != "_"]

    legend, _ = _legend_above(fig, handles(), legend_top)
    fixed_layout(fig, left=0.95, right=0.15, bottom=0.5, top=head, hspace=0.32)

    def redraw(method: str, prediction: np.ndarray, new_title: str | None) -> None:
        nonlocal legend
        p = np.asarray(prediction, dtype=float)[:n]
        c = method_color(method)
        for j, (top, bottom, line, err, ferr) in enumerate(lines):
            line.set_data(*_line(t, p[:, j], max_points))
            err.set_data(*_line(t, measured[:, j] - p[:, j], max_points))
            line.set_label(f"{method}: predicted")
            err.set_label(f"{method}: error, raw")
            for ln in (line, err) + ((ferr,) if ferr is not None else ()):
                ln.set_color(c)
            if ferr is not None:
                ferr.set_data(*_line(t, filtered[:, j] - p[:, j], max_points))
                ferr.set_label(f"{method}: error, filtered")
            for ax in (top, bottom):
                ax.relim()
                ax.autoscale_view()
        legend.remove()
        legend, _ = _legend_above(fig, handles(), legend_top)
        if heading is not None and new_title:
            heading.set_text(new_title)

    return fig, redraw


def torque_pngs(
    t: np.ndarray,
    measured: np.ndarray,
    predicted: Mapping[str, np.ndarray],
    joints: list[str],
    *,
    titles: Mapping[str, str],
    **kwargs,
) -> list[bytes]:
    """The PNG bytes of :func:`torque_comparison` for each method of ``predicted`` alone (title ``titles[m]``),
    one figure redrawn with each method's lines: its axes and ticks are made once (the same bytes as a new
    figure per method, tested; on a 6-DOF arm 0.3 s instead of 0.45 s for each method after the first).
    ``kwargs``: :func:`torque_comparison`'s ``filtered``, ``units``, ``window``, ``max_points``."""
    methods = list(predicted)
    first = methods[0]
    fig, redraw = _torque_figure(t, measured, {first: predicted[first]}, joints, title=titles[first], **kwargs)
    try:
        pngs = [png_bytes(fig)]
        for m in methods[1:]:
            redraw(m, predicted[m], titles[m])
            pngs.append(png_bytes(fig))
    finally:
        close_figure(fig)
    return pngs


def prediction_overlay(
    t: np.ndarray,
    measured: np.ndarray,
    predicted: Mapping[str, np.ndarray],
    joints: list[str],
    *,
    reference: str,
    units: list[str] | None = None,
    title: str | None = None,
    window: float | None = 30.0,
    max_points: int = 1_000,
):
    """Every method's predicted torque [N·m] in one figure, per joint: the predictions over the torque as
    recorded (light grey), and below each prediction minus ``reference``'s (the best method's), where the
    methods differ.  One colour per method (:func:`pinid.report.colors.method_color`), the legend above the
    panels; the first ``window`` seconds (None: all), thinned to ``max_points`` (min/max envelopes: :func:`_line`).
    Returns the figure."""
    from pinid.report.colors import method_color

    if reference not in predicted:
        raise KeyError(f"reference {reference!r} is not one of the predictions ({', '.join(predicted)})")
    t, cut, _ = _window(t, {"measured": measured, **predicted}, window)
    measured = cut.pop("measured")
    nv = len(joints)
    head = (0.5 if title else 0.1) + 0.24 * -(-(1 + len(cut)) // 4) + 0.1
    fig, axes = new_figure(
        2 * nv,
        1,
        figsize=(9, 1.8 * 2 * nv + head),
        sharex=True,
        squeeze=False,
        gridspec_kw={"height_ratios": [2, 1] * nv},
    )
    ref = cut[reference]
    for j, name in enumerate(joints):
        top, bottom = axes[2 * j, 0], axes[2 * j + 1, 0]
        top.plot(*_line(t, measured[:, j], max_points), color="0.75", lw=0.8, zorder=1, label="measured (as recorded)")
        for m, p in cut.items():
            c, lw = method_color(m), (1.3 if m == reference else 0.8)
            top.plot(*_line(t, p[:, j], max_points), color=c, lw=lw, zorder=3 if m == reference else 2, label=m)
            if m != reference:
                bottom.plot(*_line(t, p[:, j] - ref[:, j], max_points), color=c, lw=0.8)
        unit = "N·m" if units is None else units[j]
        top.set_ylabel(f"{name}\nτ [{unit}]")
        bottom.set_ylabel(f"τ − τ_{reference} [{unit}]")
        bottom.axhline(0.0, color=method_color(reference), lw=1.0)
        top.grid(alpha=0.3)
        bottom.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time [s]")
    if title:
        fig.suptitle(title, y=1 - 0.2 / fig.get_figheight())
    _legend_above(fig, list(axes[0, 0].get_lines()), 0.5 if title else 0.1)
    fixed_layout(fig, left=0.95, right=0.15, bottom=0.5, top=head, hspace=0.32)
    return fig


def error_bars(metrics: Mapping[str, object], *, title: str | None = None):
    """The absolute torque error |e| [N·m] per joint (one panel each, and one pooling all joints) and method:
    the mean (dot, value written) and the [p5, p95] band of |e| (never below zero, unlike mean − std).

    ``metrics``: ``{method: TorqueMetrics}`` (or their ``to_dict()`` forms).  A grid of at most three
    panels per row, 10 inches wide, so it fits a page.  Returns the figure.
    """
    from pinid.report.colors import method_color

    per = {m: (v.to_dict() if hasattr(v, "to_dict") else v) for m, v in metrics.items()}
    methods = list(per)
    first = next(iter(per.values())) if per else {}
    units = first.get("units") or {}
    pools = list(first.get("per_unit") or {}) if len(set(units.values())) > 1 else []
    # one pooled panel per unit: N·m (revolute) and N (prismatic) never share an axis
    panels = (list(first["per_joint"]) + ([f"all {u}" for u in pools] or ["all"])) if per else []
    ncols = max(1, min(3, len(panels)))
    nrows = max(1, -(-len(panels) // ncols))
    height = nrows * (0.9 + 0.28 * max(1, len(methods))) + (0.4 if title else 0.0)
    fig, axes = new_figure(nrows, ncols, figsize=(10, min(height, 13)), squeeze=False)
    y = np.arange(len(methods))[::-1]
    colours = [method_color(m) for m in methods]
    for k, name in enumerate(panels):
        ax = axes[k // ncols, k % ncols]
        top = 0.0
        for i, m in enumerate(methods):
            if name == "all":
                d = per[m]["all"]
            elif name.startswith("all ") and name[4:] in (per[m].get("per_unit") or {}):
                d = per[m]["per_unit"][name[4:]]
            else:
                d = per[m]["per_joint"][name]
            mean = d.get("mean_abs")
            if mean is None:
                continue
            lo, hi = d.get("p5_abs"), d.get("p95_abs")
            if lo is not None and hi is not None:
                ax.plot([lo, hi], [y[i], y[i]], lw=6, alpha=0.35, color=colours[i], solid_capstyle="butt")
                top = max(top, hi)
            ax.plot([mean], [y[i]], "o", color=colours[i], ms=5)
            ax.annotate(
                f"{mean:.3g}", (mean, y[i]), xytext=(0, 6), textcoords="offset points", ha="center", fontsize="x-small"
            )
            top = max(top, mean)
        ax.set_xlim(0, 1.12 * top if top > 0 else 1.0)
        ax.set_ylim(-0.7, len(methods) - 0.3)
        ax.set_yticks(y, methods if k % ncols == 0 else [""] * len(methods), fontsize="small")
        unit = name[4:] if name.startswith("all ") else units.get(name, next(iter(set(units.values())), "N·m"))
        ax.set_title("all joints" if name == "all" else f"all {unit} joints" if name.startswith("all ") else name)
        ax.set_xlabel(f"|τ error| [{unit}]", fontsize="small")
        ax.tick_params(axis="x", labelsize="small")
        ax.grid(axis="x", alpha=0.3)
    for k in range(len(panels), nrows * ncols):
        axes[k // ncols, k % ncols].set_visible(False)
    if title:
        fig.suptitle(title, fontsize="medium")
    longest = max((len(m) for m in methods), default=4)
    left = 0.25 + 0.075 * longest  # the method names label the first column's rows ("small" font)
    fixed_layout(fig, left=left, right=0.2, bottom=0.5, top=0.65 if title else 0.35, hspace=0.8, wspace=0.3)
    return fig


def recorded_motion(
    t: np.ndarray,
    q: np.ndarray,
    dq: np.ndarray | None,
    joints: list[str],
    *,
    title: str | None = None,
    window: float | None = 30.0,
    max_points: int = 1_600,
):
    """The excitation as recorded: q [rad] (top row) and dq [rad/s] (bottom row, when known) against time,
    one column per joint, the first ``window`` seconds (None: all) thinned to ``max_points``.  Returns the figure.
    """
    t = np.asarray(t, dtype=float)
    n = int(np.searchsorted(t, t[0] + window)) if window is not None and len(t) and t[-1] - t[0] > window else len(t)
    t = t[:n]
    rows = [("q [rad]", np.asarray(q, dtype=float)[:n])] + (
        [] if dq is None else [("dq [rad/s]", np.asarray(dq, dtype=float)[:n])]
    )
    nv = len(joints)
    ncols = min(nv, 3)
    nblocks = -(-nv // ncols)
    fig, axes = new_figure(
        len(rows) * nblocks, ncols, figsize=(10, 2.0 * len(rows) * nblocks + 0.5), sharex=True, squeeze=False
    )
    for j, name in enumerate(joints):
        for r, (label, y) in enumerate(rows):
            ax = axes[(j // ncols) * len(rows) + r, j % ncols]
            ax.plot(*_line(t, y[:, j], max_points), lw=1.0, color="C0")
            ax.grid(alpha=0.3)
            if r == 0:
                ax.set_title(name, fontsize="medium")
            if j % ncols == 0:
                ax.set_ylabel(label)
    for k in range(nv, nblocks * ncols):
        for r in range(len(rows)):
            axes[(k // ncols) * len(rows) + r, k % ncols].set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    if title:
        fig.suptitle(title, fontsize="medium")
    fixed_layout(fig, left=0.85, right=0.15, bottom=0.5, top=0.6 if title else 0.3, hspace=0.4, wspace=0.6)
    return fig
