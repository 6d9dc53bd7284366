"""Figures of a :class:`pinid.identification.compare.Comparison`: convergence curves (seed 000 Figs. 8, 11; seed 001 Fig. 3b),
validation error bars (seed 000 Figs. 10, 13) and parameter errors against the truth."""

from __future__ import annotations

import numpy as np

from pinid.estimators import ESTIMATORS
from pinid.report.colors import method_color
from pinid.report.figures import new_figure
from pinid.report.plot_identification import error_bars


def _converges(method: str) -> bool:
    """Whether the method's history is a best-fitness curve (WLS: its passes; RLS: an error along the rows)."""
    cls = ESTIMATORS.get(method)
    return cls is not None and cls.history == "fitness"


def convergence(comparison, *, stage: str = "main", ax=None, title: str | None = None, excess: bool = True):
    """Best fitness per iteration of every metaheuristic run (thin: each seed; thick: the median), log scale.

    ``stage``: ``"main"`` (the fit, or a segmental run's second stage) or ``"first"`` (the first stage).
    ``excess`` (default): plot ``f/f_min − 1``, how far the best particle is above the global minimum of
    its fitness on the same rows (least squares for ½Σr², least absolute deviations for Σ|r|; each run's
    own, since a segmental second stage depends on that run's first stage); a dashed line marks where
    least squares sits for Σ|r|.  Otherwise the raw fitness with the minima as lines.  Returns the figure.
    """
    if ax is None:
        fig, ax = new_figure(figsize=(8.5, 4))
    else:
        fig = ax.figure
    fitness_kinds = set()
    ls_excess = []
    drawn = 0
    for m, runs in comparison.runs.items():
        if not _converges(m):
            continue
        color = method_color(m)
        curves = []
        for r in runs:
            c = r.history_first if stage == "first" else r.history
            if not c or len(c) <= 2:
                continue
            c = np.asarray(c, float)
            src = (
                (r.info.get("first_stage" if stage == "first" else "second_stage") or {})
                if comparison.segmental
                else r.info
            )
            if "fitness" in r.info:
                fitness_kinds.add(r.info["fitness"])
            if excess:
                low = src.get("min_fitness") or src.get("ls_fitness")
                if not low:
                    continue
                c = np.maximum(c / float(low) - 1.0, 1e-12)
                if src.get("ls_fitness") and src.get("min_fitness"):
                    ls_excess.append(float(src["ls_fitness"]) / float(src["min_fitness"]) - 1.0)
            curves.append(c)
        if not curves:
            continue
        for c in curves:
            ax.plot(np.arange(len(c)), c, color=color, lw=0.6, alpha=0.35)
        n = min(len(c) for c in curves)
        med = np.median(np.vstack([c[:n] for c in curves]), axis=0)
        ax.plot(np.arange(n), med, color=color, lw=1.8, label=f"{m} (median of {len(curves)})")
        drawn += 1
    kind = next(iter(fitness_kinds)) if len(fitness_kinds) == 1 else None
    ref = comparison.reference.get(stage) or {}
    if excess:
        name = {"sse": "½Σr²", "sae": "Σ|r|"}.get(kind, "fitness")
        ax.set_ylabel(f"{name} of the best / its minimum − 1")
        if kind == "sae" and ls_excess and np.median(ls_excess) > 1e-12:
            ax.axhline(float(np.median(ls_excess)), color="black", ls="--", lw=1.0, label="least squares")
    else:
        ax.set_ylabel({"sse": "best fitness ½Σr² [N²·m²]", "sae": "best fitness Σ|r| [N·m]"}.get(kind, "best fitness"))
        if ref.get("sse") and kind == "sse":
            ax.axhline(ref["sse"], color="black", ls="--", lw=1.0, label="least squares (the minimum)")
        if ref.get("sae") and kind == "sae":
            ax.axhline(ref["sae"], color="tab:green", ls=":", lw=1.2, label="least absolute deviations (the minimum)")
    ax.set_yscale("log")
    ax.set_xlabel("iteration")
    ax.grid(alpha=0.3, which="both")
    if drawn:  # outside the axes, on the right: the curves keep the whole plot
        ax.legend(fontsize="small", loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    return fig


def validation_errors(comparison, label: str | None = None, *, title: str | None = None):
    """The absolute validation torque error per joint and method: mean and [p5, p95] band, each averaged
    over the runs (:func:`~pinid.report.plot_identification.error_bars`).

    ``label``: which validation set (default the first).  Returns the figure.
    """
    labels = list(comparison.validation_sources)
    if not labels:
        raise ValueError("the comparison has no validation recordings")
    label = labels[0] if label is None else label
    metrics = {}
    for m, runs in comparison.runs.items():
        vals = [r.validation[label] for r in runs]

        def avg(pick, vals=vals):
            keys = [k for k in ("mean_abs", "p5_abs", "p95_abs") if all(pick(v).get(k) is not None for v in vals)]
            return {k: float(np.mean([pick(v)[k] for v in vals])) for k in keys}

        metrics[m] = {
            "per_joint": {j: avg(lambda v, j=j: v["per_joint"][j]) for j in vals[0]["per_joint"]},
            "all": avg(lambda v: v["all"]),
            "units": vals[0].get("units"),
            "per_unit": {u: avg(lambda v, u=u: v["per_unit"][u]) for u in vals[0].get("per_unit") or {}},
        }
    return error_bars(
        metrics,
        title=title
        or f"validation torque error ({label}, against the torque as recorded): mean and [p5, p95], over runs",
    )


def parameter_errors(comparison, *, ax=None, title: str | None = None):
    """Error of every base parameter against the truth [%] per method (bars: mean over runs; whiskers:
    min and max), log scale.  Returns the figure."""
    if comparison.truth is None:
        raise ValueError("the comparison has no true parameters (truth=None)")
    zero = set(comparison.zero_truth())  # no relative error where the truth is 0
    names = [n for n in comparison.base_names if n not in zero]
    methods = list(comparison.runs)
    if ax is None:
        fig, ax = new_figure(figsize=(min(12.0, max(7.0, 0.12 * len(names) * max(1, len(methods)) + 2)), 4))
    else:
        fig = ax.figure
    width = 0.8 / max(1, len(methods))
    x = np.arange(len(names))
    for k, m in enumerate(methods):
        e = np.array([[r.parameter_error[n] for n in names] for r in comparison.runs[m]])
        mean = e.mean(axis=0)
        lo, hi = mean - e.min(axis=0), e.max(axis=0) - mean
        ax.bar(
            x + (k - (len(methods) - 1) / 2) * width,
            np.maximum(mean, 1e-6),
            width,
            yerr=[lo, hi],
            capsize=1.5,
            label=m,
            color=method_color(m),
        )
    ax.set_yscale("log")
    ax.set_xticks(x, names, rotation=35, ha="right")
    ax.set_ylabel("|x − x_true| / |x_true| [%]")
    ax.grid(axis="y", alpha=0.3, which="both")
    # above the axes (the bars keep the whole plot), the title above the legend
    rows = -(-len(methods) // min(7, max(1, len(methods))))
    ax.legend(
        fontsize="x-small",
        ncol=min(7, max(1, len(methods))),
        loc="lower center",
        bbox_to_anchor=(0.5, 1.01),
        frameon=False,
    )
    if title:
        ax.set_title(title, pad=10 + 15 * rows)
    fig.tight_layout()
    return fig


def comparison_figures(comparison) -> dict:
    """All figures of a comparison, ``{file name: figure}`` (``compare_*.png``)."""
    figs = {}
    if any(_converges(m) and r.history and len(r.history) > 2 for m, runs in comparison.runs.items() for r in runs):
        figs["compare_convergence.png"] = convergence(
            comparison, title="convergence" + (" (second stage)" if comparison.segmental else "")
        )
    if comparison.segmental and any(r.history_first for runs in comparison.runs.values() for r in runs):
        figs["compare_convergence_first.png"] = convergence(
            comparison, stage="first", title="convergence (first stage)"
        )
    for label in comparison.validation_sources:
        safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in label)
        figs[f"compare_errors_{safe}.png"] = validation_errors(comparison, label)
    if comparison.truth is not None:
        figs["compare_parameters.png"] = parameter_errors(comparison, title="error against the true parameters")
    return figs
