"""A readable report of an identification, with its figures, for a lab notebook: ``report.md`` and the same
text as one self-contained page, ``report.html`` (figures embedded; :mod:`pinid.report.html`).

The report leads with the comparison: the summary table, ``errors.png`` (the absolute torque error per joint
and method, mean and [p5, p95] band; seed 000 Figs. 10/13 draw mean ± std, which goes below zero for an
absolute error), ``parameters.png`` (the best method's and OLS's base parameters ±2σ against the URDF and
the truth, :mod:`pinid.report.plot_parameters`), ``torque_<best>.png`` (measured vs predicted torque of the
best method with the raw and filtered error underneath; seed 000 Figs. 9/12) and ``predictions.png`` (every
method's prediction, and its difference to the best's).  Then the robot and data with
``training_motion.png`` (q and dq of the first training recording), and each method's detail folded
(``<details>``; the best one open).  :func:`report_files` renders the figures once (the identification's
writer writes them with its other files); :func:`figure_recipes` has a torque figure for every method
(:meth:`pinid.identification.result.Identification.plot`).
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path

import numpy as np

from pinid.io import display_path
from pinid.model.base import marks_summary
from pinid.model.physical import NOISE, com_inertia, tidy_inertial
from pinid.model.robot import INERTIAL_NAMES
from pinid.model.terms import TermSelection
from pinid.report.figures import Recipe
from pinid.report.plot_identification import (
    error_bars,
    prediction_overlay,
    recorded_motion,
    torque_comparison,
    torque_pngs,
)
from pinid.report.plot_choices import cross_validation_figure
from pinid.report.plot_parameters import parameter_plausibility
from pinid.report.floating import floating_figure_lines, floating_recipes, mass_section, shown_estimates

#: Every file a report writes (patterns): what ``pinid identify --force`` removes of an earlier run's report.
REPORT_FILES = (
    "report.md",
    "report.html",
    "errors.png",
    "parameters.png",
    "predictions.png",
    "training_motion.png",
    "cross_validation.png",
    "torque_*.png",
    "base_wrench.png",
    "contacts.png",
    "base_trajectory.png",
)


def number_text(x, fmt: str = ".4g") -> str:
    """``x`` formatted with ``fmt``; ``–`` for None or a non-finite float."""
    if x is None or (isinstance(x, float) and not np.isfinite(x)):
        return "–"
    return format(x, fmt)


def markdown_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table; a ``|`` inside a cell is escaped (``\\|``)."""

    def line(cells) -> str:
        return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"

    return "\n".join([line(header), "|" + "|".join("---" for _ in header) + "|"] + [line(r) for r in rows])


#: Seconds of the torque traces drawn in the report (from the start of the recording).
WINDOW = 30.0


def figure_names(ident) -> dict[str, str]:
    """File names of the report's figures: ``{"errors": …, "parameters": …, "predictions": …, "motion": …,
    "torque_<method>": …}`` (a torque figure for every method; the report draws the best one's)."""
    names = {
        "errors": "errors.png",
        "parameters": "parameters.png",
        "predictions": "predictions.png",
        "motion": "training_motion.png",
        "choices": "cross_validation.png",
    }
    names.update({f"torque_{m}": f"torque_{m}.png" for m in ident.results})
    names.update({"wrench": "base_wrench.png", "contacts": "contacts.png", "base_motion": "base_trajectory.png"})
    return names


def shown_figures(ident) -> list[str]:
    """The keys of :func:`figure_names` the report draws: the comparison figures, the best method's torque."""
    if not ident.results:
        return []
    chosen = ["choices"] if _choices(ident) else []
    floating = ["wrench", "contacts", "base_motion"] if _floating(ident) else []
    return ["errors", "parameters", *floating, "predictions", "motion", *chosen, f"torque_{ident.best}"]


def _floating(ident) -> bool:
    """A floating base's identification (its figures: pinid.report.plot_floating)."""
    return (ident.data or {}).get("base") == "floating"


def _choices(ident) -> dict:
    """The choices made by cross-validation (``--cutoff auto``, ``--terms auto``): ``{"cutoff": …,
    "terms": …}`` of those made, from the identification's data."""
    data = ident.data or {}
    return {k: data[d] for k, d in (("cutoff", "cutoff"), ("terms", "terms_choice")) if data.get(d)}


def _plausibility_recipe(ident) -> Recipe | None:
    """:func:`~pinid.report.plot_parameters.parameter_plausibility` of the best method and OLS (when run and
    not the best), against the URDF and the truth; None without base parameters."""
    names = ident.base.get("names") or []
    if not names or not ident.results:
        return None
    estimates = shown_estimates(ident)
    truth = next((r.truth_error["truth"] for r in ident.results.values() if r.truth_error), None)
    truth_v = None if truth is None else [truth.get(n) for n in names]
    title = (
        f"base parameters: estimate ± 2σ against the URDF{' and the truth' if truth else ''}, "
        "each divided by its natural scale"
    )
    nominal = ident.base.get("nominal") or [None] * len(names)
    return (
        parameter_plausibility,
        (names, nominal, ident.base.get("scale"), estimates),
        {"truth": truth_v, "title": title},
    )


def figure_recipes(ident) -> dict[str, Recipe]:
    """The report's figures by key (see :func:`figure_names`) as recipes for
    :func:`pinid.report.figures.render_pngs`, largest first; the torque, prediction and motion figures only
    with the torque curves (:attr:`~pinid.identification.result.Identification.curves`)."""
    figs = {}
    c = ident.curves or {}
    joints = ident.robot["joints"]
    if c.get("predicted"):
        t = np.asarray(c["t"])
        span = f", first {WINDOW:g} s" if len(t) and t[-1] - t[0] > WINDOW else ""
        for m, pred in c["predicted"].items():
            title = f"{m}: measured and predicted torque ({c['kind']}, {Path(str(c['source'])).name}{span})"
            figs[f"torque_{m}"] = (
                torque_comparison,
                (c["t"], c["measured"], {m: pred}, joints),
                {"window": WINDOW, "title": title, "filtered": c.get("filtered"), "units": c.get("units")},
            )
        if len(c["predicted"]) > 1 and ident.best in c["predicted"]:
            title = f"every method's predicted torque ({c['kind']}, {Path(str(c['source'])).name}{span})"
            figs["predictions"] = (
                prediction_overlay,
                (c["t"], c["measured"], c["predicted"], joints),
                {"reference": ident.best, "window": WINDOW, "title": title, "units": c.get("units")},
            )
    plausible = _plausibility_recipe(ident)
    if plausible is not None:
        figs["parameters"] = plausible
    motion = c.get("motion")
    if motion is not None and len(motion["t"]):
        t = np.asarray(motion["t"])
        span = f", first {WINDOW:g} s" if t[-1] - t[0] > WINDOW else ""
        title = f"training motion ({Path(str(motion['source'])).name}{span})"
        figs["motion"] = (recorded_motion, (t, motion["q"], motion["dq"], joints), {"window": WINDOW, "title": title})
    choices = _choices(ident)
    if choices:
        figs["choices"] = (cross_validation_figure, (choices.get("cutoff"), choices.get("terms")), {})
    if _floating(ident):
        figs.update(floating_recipes(ident, joints, WINDOW))
        return figs
    metrics = {m: (r.validation if r.validation is not None else r.train) for m, r in ident.results.items()}
    if metrics:
        kind = "validation" if all(r.validation is not None for r in ident.results.values()) else "training"
        title = f"absolute torque error ({kind}, against the torque as recorded): mean (dot) and [p5, p95] band"
        figs["errors"] = (error_bars, (metrics,), {"title": title})
    return figs


#: Relative drawing cost of the report's figures (6-DOF arm, 2000 points per line): the first torque
#: figure 1, each further method redrawn into it (:func:`~pinid.report.plot_identification.torque_pngs`)
#: 0.65, the motion and error figures ~0.6 each.
_FIRST, _REDRAWN, _OTHER = 1.0, 0.65, 0.6


def grouped_recipes(recipes: dict[str, Recipe], workers: int) -> dict[str | tuple[str, ...], Recipe]:
    """:func:`figure_recipes` with the torque figures drawn in groups, each group one figure redrawn per
    method (:func:`~pinid.report.plot_identification.torque_pngs`, keyed by the tuple of its keys): as many
    groups as finish soonest on ``workers`` processes (one process: one group), the fewest of those; the
    largest first.  The same PNG bytes as ``recipes``."""
    torque = [k for k in recipes if k.startswith("torque_")]
    others = {k: r for k, r in recipes.items() if k not in torque}
    if len(torque) < 2:
        return dict(recipes)

    def finish(groups: int) -> tuple[float, float]:  # (the last worker's load, the total), list scheduling
        sizes = [len(torque) // groups + (i < len(torque) % groups) for i in range(groups)]
        loads = [0.0] * max(1, workers)
        jobs = sorted([_FIRST + _REDRAWN * (n - 1) for n in sizes] + [_OTHER] * len(others), reverse=True)
        for job in jobs:
            loads[loads.index(min(loads))] += job
        return round(max(loads), 6), round(sum(jobs), 6)

    groups = min(range(1, min(len(torque), max(1, workers)) + 1), key=finish)
    out: dict[str | tuple[str, ...], Recipe] = {}
    for g in range(groups):
        keys = tuple(torque[g::groups])
        _, (t, measured, _, joints), kwargs = recipes[keys[0]]
        predicted = {k.removeprefix("torque_"): next(iter(recipes[k][1][2].values())) for k in keys}
        titles = {k.removeprefix("torque_"): recipes[k][2]["title"] for k in keys}
        rest = {name: v for name, v in kwargs.items() if name != "title"}
        out[keys] = (torque_pngs, (t, measured, predicted, joints), {"titles": titles, **rest})
    return {**out, **others}


def pooled(metrics, key: str, fmt: str = ".4g") -> str:
    """``metrics``' pooled ``key`` as text: one number, or one per unit (``0.12 N·m / 0.03 N``) for a robot
    with revolute and prismatic joints; ``–`` without metrics."""
    if metrics is None:
        return "–"
    pools = metrics.pools()
    if len(pools) == 1:
        return number_text(pools["all"][key], fmt)
    unit = lambda label: "" if key.endswith("percent") else " " + label.split(" ", 1)[1]
    return " / ".join(f"{number_text(m[key], fmt)}{unit(label)}" for label, m in pools.items())


def _truth_cell(err: dict, name: str) -> str:
    """A parameter's error against the truth: ``12 %``, or the absolute error ``|e| 3e-05`` where the truth is 0."""
    rel = err["error_percent"].get(name)
    return f"{number_text(rel, '.2g')} %" if rel is not None else f"|e| {number_text(err['error'].get(name), '.2g')}"


def _unit(ident) -> str:
    """The header's unit of absolute torque errors: [N·m] or [N] for one unit; none (each cell says) for both."""
    units = {"N" if k == "prismatic" else "N·m" for k in (ident.robot.get("joint_kinds") or [])} or {"N·m"}
    for r in ident.results.values():
        units |= set((r.train.units or {}).values())
    return f" [{units.pop()}]" if len(units) == 1 else ""


def summary_table(ident, bold=lambda text: f"**{text}**") -> tuple[list[str], list[list[str]]]:
    """The summary: header and one row per method (consistency, cond(W_b), training and validation error —
    raw: against the torque as recorded; filtered: against the low-passed torque —, time, status); ``bold``
    marks the best method and inconsistent results (Markdown by default).  Pooled errors are per unit."""
    rows = []
    for m, r in ident.results.items():
        v = r.validation
        mean_std = "–"
        if v is not None:
            mean_std = " / ".join(
                f"{number_text(p['mean_abs'])} ± {number_text(p['std_abs'])}" for p in v.pools().values()
            )
        rows.append(
            [
                bold(m) if m == ident.best else m,
                "yes" if r.physically_consistent else bold("no"),
                number_text(r.condition_number, ".3g"),
                pooled(r.train, "rms"),
                pooled(v, "rms"),
                pooled(v, "rel_rms_percent", ".3g"),
                pooled(r.validation_filtered, "rel_rms_percent", ".3g"),
                mean_std,
                number_text(r.seconds, ".3g"),
                r.status,
            ]
        )
    unit = _unit(ident)
    return (
        [
            "method",
            "consistent",
            "cond(W_b)",
            f"train RMS raw{unit}",
            f"valid. RMS raw{unit}",
            "valid. RMS raw %",
            "valid. RMS filtered %",
            f"valid. |e| raw{unit}",
            "time [s]",
            "status",
        ],
        rows,
    )


def floor_line(ident) -> str | None:
    """One line: pooled and per joint, the model-class floor (the same terms fitted by least squares in-sample on
    the validation recordings: :mod:`pinid.identification.floor`) beside the best method's validation error, both
    RMS % against the torque as recorded, and which parameters the validation recordings left undetermined;
    None without a floor."""
    floor = getattr(ident, "floor", None)
    if floor is None or not ident.results:
        return None
    val = ident.results[ident.best].validation
    cells = [
        f"{j} {number_text(m['rel_rms_percent'], '.3g')}"
        + (f" ({ident.best} {number_text(val.per_joint[j]['rel_rms_percent'], '.3g')})" if val is not None else "")
        for j, m in floor.per_joint.items()
        if np.isfinite(m.get("rel_rms_percent", np.nan))  # the rows used only: no joint of a base-rows fit
    ]
    pooled = [
        f"{k} {number_text(m['rel_rms_percent'], '.3g')}"
        + (f" ({ident.best} {number_text(val.pools()[k]['rel_rms_percent'], '.3g')})" if val is not None else "")
        for k, m in floor.pools().items()
        if val is not None and k in val.pools()
    ]
    fit = (getattr(ident, "data", None) or {}).get("floor") or {}
    undetermined = list(fit.get("undetermined") or [])
    note = ""
    if undetermined:
        more = len(undetermined) - 5
        names = ", ".join(undetermined[:5]) + (f" and {more} more" if more > 0 else "")
        note = (
            f"; the validation recording determines {fit.get('rank')} of {fit.get('parameters')} parameters "
            f"(not {names}): minimum-norm fit of the columns it excites"
        )
    if not cells and not pooled:
        return None
    return (
        "model-class floor, valid. RMS raw % (the same terms fitted by least squares on the validation recording "
        f"itself, against the torque as recorded: no method of this class validates below it pooled): "
        f"{', '.join(pooled + cells)}; near the floor the model class limits the result, far above it the "
        f"identification{note}"
    )


#: What the summary's columns mean (the report prints it under the table; docs/identification.md too).
SUMMARY_NOTE = (
    "raw: against the torque as recorded (the fixed yardstick); filtered: against the torque after pinid's own "
    "low-pass, which moves with --cutoff. valid. |e|: mean ± std of the absolute validation torque error over all "
    "joints (of one unit)."
)


def _comparison_figures(ident, figures: dict[str, str]) -> list[str]:
    """The summary's figures (those of ``figures``' keys that exist), each with a line saying what it shows."""
    lines = []
    if "errors" in figures and _floating(ident):
        lines += ["", f"![RMS error per base axis (and joint) and method]({figures['errors']})"]
    elif "errors" in figures:
        lines += ["", f"![absolute torque error: mean and [p5, p95] per joint and method]({figures['errors']})"]
    if "parameters" in figures:
        shown = ident.best + (" and ols" if "ols" in ident.results and ident.best != "ols" else "")
        lines += [
            "",
            f"Base parameters of {shown}: the estimate (dot) ± 2σ (bar; none for a metaheuristic or a value on a "
            "bound) against the URDF's value (square) and, with a truth, the true value (cross), each divided by "
            "the parameter's natural scale (its bodies' mass, mass·length, mass·length²; 1 for joint terms). "
            "A hollow dot marks a result that is not physically consistent.",
            "",
            f"![base parameters: estimate ± 2σ against the URDF]({figures['parameters']})",
        ]
    lines += floating_figure_lines(ident, figures)
    key = f"torque_{ident.best}"
    if key in figures:
        lines += [
            "",
            f"### The best method's torque ({ident.best})",
            "",
            "The prediction (colour) over the torque as recorded (light grey) and low-passed (thin dark line); "
            "below, the error against each of them (raw: light, filtered: full colour).",
            "",
            f"![{ident.best}: measured and predicted torque]({figures[key]})",
        ]
    if "predictions" in figures:
        lines += [
            "",
            "### Every method's prediction",
            "",
            f"Each method's predicted torque in its colour and, below, its difference to {ident.best}'s.",
            "",
            f"![every method's predicted torque]({figures['predictions']})",
        ]
    return lines


def _method_table(result, unit: str = "") -> tuple[list[str], list[list[str]]]:
    """One table of a method's torque error per joint (and pooled): RMS (RMS %) on the training and
    validation data, against the torque as recorded (raw) and the low-passed one (filtered), then the mean
    ± std and max of |e| (validation raw, else training raw).  ``unit``: the header's unit (" [N·m]")."""
    sets = [
        (name, m)
        for name, m in (
            ("train raw", result.train),
            ("valid. raw", result.validation),
            ("train filtered", result.train_filtered),
            ("valid. filtered", result.validation_filtered),
        )
        if m is not None
    ]
    primary_name, primary = sets[1] if len(sets) > 1 and sets[1][0] == "valid. raw" else sets[0]

    def cell(m: dict | None) -> str:
        return "–" if m is None else f"{number_text(m['rms'])} ({number_text(m['rel_rms_percent'], '.3g')} %)"

    def row_of(metrics, name: str) -> dict | None:
        return metrics.per_joint.get(name) or metrics.pools().get(name)

    labels = list(primary.per_joint) + list(primary.pools())
    rows = []
    for name in labels:
        p = row_of(primary, name)
        rows.append(
            [name]
            + [cell(row_of(m, name)) for _, m in sets]
            + [f"{number_text(p['mean_abs'])} ± {number_text(p['std_abs'])}", number_text(p["max_abs"])]
        )
    header = ["joint"] + [f"RMS {n}{unit} (%)" for n, _ in sets]
    header += [f"{primary_name} |e| mean ± std{unit}", f"{primary_name} max |e|{unit}"]
    return header, rows


def _method_section(ident, m: str) -> list[str]:
    """Lines of method ``m``'s folded section: ``<details>`` (open for the best), a one-line summary, the
    description, consistency, cond(W_b), time, and :func:`_method_table`."""
    import html

    r = ident.results[m]
    best = m == ident.best
    v = r.validation if r.validation is not None else r.train
    kind = "valid." if r.validation is not None else "train"
    flag = "" if r.physically_consistent else ", <strong>not physically consistent</strong>"
    headline = (
        f"<summary><strong>{html.escape(m)}</strong>{' (best)' if best else ''}: {kind} RMS raw "
        f"{html.escape(pooled(v, 'rel_rms_percent', '.3g'))} %{flag}; {html.escape(number_text(r.seconds, '.3g'))} s"
        "</summary>"
    )
    lines = ["<details open>" if best else "<details>", headline, "", f"{r.description}.", ""]
    consistent = "physically consistent" if r.physically_consistent else "**not physically consistent**"
    lines.append(
        f"- {consistent} ({r.standard_source}); cond(W_b) {number_text(r.condition_number, '.4g')}; "
        f"{number_text(r.seconds, '.3g')} s; status {r.status}"
    )
    for prob in (r.consistency.get("problems") or [])[:4]:
        lines.append(f"- problem: {prob}")
    lines += ["", markdown_table(*_method_table(r, _unit(ident))), "", "</details>", ""]
    return lines


def _choices_section(ident, figures: dict[str, str]) -> list[str]:
    """ "Chosen by cross-validation": the cut-off and terms chosen (``--cutoff auto``, ``--terms auto``), the
    curve they were chosen on, and its figure; nothing when neither was asked for."""
    choices = _choices(ident)
    if not choices:
        return []
    lines = ["", "### Chosen by cross-validation", ""]
    if "cutoff" in choices:
        c = choices["cutoff"]
        curve = ", ".join(
            f"{f:g} Hz {v:.3g} %" for f, v in zip(c["candidates_hz"], c["cv_rel_rms_percent"]) if v is not None
        )
        lines.append(
            f"- low-pass cut-off **{c['cutoff_hz']:g} Hz**, chosen by {c['chosen_by']}; held-out relative RMS: {curve}"
        )
    if "terms" in choices:
        c = choices["terms"]
        first, *rest = [s for s in c["steps"] if s] or [{}]
        best = [min(s, key=lambda k: s[k] if s[k] is not None else np.inf) for s in rest]
        lines.append(
            f"- terms **{', '.join(c['terms']) or 'none'}**, chosen by {c['chosen_by']}: from "
            f"{next(iter(first), 'none')}, each step's best candidate {', '.join(best) or 'none'}; a candidate "
            "is added only when measurably better (two standard errors of the paired fold differences)"
        )
    lines.append(
        "- the scores are held-out errors of blocks of the training recordings against the torque as recorded; "
        "the validation recording played no part."
    )
    if "choices" in figures:
        lines += ["", f"![choices made by cross-validation]({figures['choices']})"]
    return lines


def _offsets_section(ident) -> list[str]:
    """Lines of "Torque offsets per recording" (``--offsets per-recording``): which offsets were estimated per
    recording and each method's values [N·m] per joint; nothing without them."""
    info = (ident.data or {}).get("offsets")
    if not info:
        return []
    fraction = info.get("calibrate_fraction")
    how = (
        f"calibrated on its first {100 * fraction:.3g} % (every other parameter fixed) and scored on the rest"
        if fraction
        else "given the training recordings' mean offsets (no calibration)"
    )
    lines = [
        "",
        "### Torque offsets per recording",
        "",
        f"One torque offset per joint estimated for each training recording ({len(info['per_recording'])}), the "
        f"other parameters shared; each validation recording {how}.  Values [N·m]:",
        "",
    ]
    joints = list(ident.robot["joints"])
    rows = []
    for m, r in ident.results.items():
        for role in ("training", "validation"):
            for item in (r.info.get("offsets") or {}).get(role, []):
                values = [item["offsets"].get(j) for j in joints]
                cells = ["–" if v is None else number_text(v, ".4g") for v in values]
                rows.append([m, role, f"`{display_path(item['source'])}`"] + cells)
    lines.append(markdown_table(["method", "role", "recording"] + [f"`{j}`" for j in joints], rows))
    return lines


def report_markdown(ident, figures: dict[str, str] | None = None) -> str:
    """The report text; ``figures`` maps figure keys to the file names to link (missing keys are skipped)."""
    from pinid import __version__

    figures = figures or {}
    robot = ident.robot
    data = ident.data
    lines = [f"# Identification of `{robot['name']}`", ""]
    lines.append(
        f"pinid {__version__}, {_dt.datetime.now().strftime('%Y-%m-%d %H:%M')}; total time {ident.seconds:.2f} s."
    )

    lines += ["", "## Summary", ""]
    lines.append(markdown_table(*summary_table(ident)))
    lines += ["", SUMMARY_NOTE]
    floor = floor_line(ident)
    if floor is not None:
        lines += ["", floor[0].upper() + floor[1:] + "."]
    if data.get("calibration_text"):  # a floating recording's sensor calibration (docs/floating-base.md)
        lines += ["", "Sensor calibration, applied to the training and validation recordings (value ± σ):", ""]
        lines += ["```", str(data["calibration_text"]), "```"]
    warned = [r.warning for r in ident.results.values() if r.warning]
    if warned:
        lines += [""] + [f"**{w}**" + ("" if k == len(warned) - 1 else "  ") for k, w in enumerate(warned)]
    lines.append("")
    lines.append(
        f"Best (bold): **{ident.best}** — the physically consistent result with the lowest "
        f"{'validation' if ident.validation_sources else 'training'} RMS (raw); its model is saved as "
        f"`model_{ident.best}.json`."
    )
    lines += _comparison_figures(ident, figures)
    lines += mass_section(ident)

    lines += ["", "## Robot and data", ""]
    urdf = robot.get("urdf")
    lines.append(
        f"- URDF: `{display_path(urdf) if urdf else None}`; joints {', '.join(f'`{j}`' for j in robot['joints'])}"
        + (f"; locked {', '.join(f'`{k}` = {v:g}' for k, v in robot['locked'].items())}" if robot.get("locked") else "")
    )
    lines.append(
        f"- joint terms: {', '.join(robot['terms']) or 'none'}; {len(ident.base.get('names', []))} base parameters"
    )
    lines.append(
        f"- training: {', '.join(f'`{s}`' for s in data.get('sources', []))} — {data.get('samples')} samples, "
        f"{data.get('rows')} torque rows used"
    )
    rates = [r for r in data.get("sample_rates_hz") or [] if r]
    if rates:
        lines.append(f"- sample rate(s): {', '.join(f'{r:.4g} Hz' for r in rates)}")
    if data.get("rows_dropped_at_rest") and any(data["rows_dropped_at_rest"].values()):
        rest = ", ".join(
            f"`{j}` {n} (|dq| < {number_text(data['rest_velocity'][j], '.3g')} rad/s)"
            for j, n in data["rows_dropped_at_rest"].items()
        )
        lines.append(f"- rows dropped at rest (Coulomb friction undefined there): {rest}")
    lines.append(
        f"- validation: {', '.join(f'`{s}`' for s in ident.validation_sources) or 'none (metrics are on the training data)'}"
    )
    lines += _offsets_section(ident)
    if "motion" in figures:
        lines += [
            "",
            "### The excitation",
            "",
            "The training motion as recorded (after preprocessing): it decides how well each parameter is excited.",
            "",
            f"![training motion: {'joint positions per chain' if _floating(ident) else 'q and dq per joint'}]"
            f"({figures['motion']})",
        ]

    lines += _choices_section(ident, figures)
    lines += [
        "",
        "## Methods",
        "",
        "Each method's detail, folded (click a line to open it; the best method's is open).  Torque error per "
        "joint: RMS and, in brackets, RMS % of the torque's RMS; raw: against the torque as recorded, "
        "filtered: against the low-passed torque.",
        "",
    ]
    for m in ident.results:
        lines += _method_section(ident, m)
    truth = next((r.truth_error for r in ident.results.values() if r.truth_error), None)
    lines += [
        "## Base parameters",
        "",
        "Value and relative standard deviation σ% = 100·σ/|value|, σ from the Newey–West covariance, which "
        'allows for residuals correlated in time (docs/identification.md, "How σ is computed"); – where a '
        "method gives no calibrated σ (metaheuristics, a value held on a bound); large σ% marks poorly "
        "excited parameters."
        + (
            " truth: the twin's true value; err %: 100·|value − truth|/|truth| (the absolute error where the "
            "truth is 0)."
            if truth
            else ""
        ),
        "",
    ]
    names = ident.base.get("names", [])
    exprs = ident.base.get("expressions", [""] * len(names))
    nominal = ident.base.get("nominal", [None] * len(names))
    header = ["parameter", "combination", "URDF"] + (["truth"] if truth else [])
    header += [f"{m} (σ%" + (", err %)" if truth else ")") for m in ident.results]
    rows = []
    for i, n in enumerate(names):
        cells = [f"`{n}`", exprs[i] if len(exprs[i]) < 70 else exprs[i][:67] + "…", number_text(nominal[i])]
        if truth:
            cells.append(number_text(truth["truth"].get(n)))
        for r in ident.results.values():
            cell = f"{number_text(r.base[i])} ({number_text(r.std_percent[i], '.2g')}"
            if truth and r.truth_error:
                cell += ", " + _truth_cell(r.truth_error, n)
            cells.append(cell + ")")
        rows.append(cells)
    lines.append(markdown_table(header, rows))

    best = ident.results.get(ident.best)
    if best is not None:
        lines += [
            "",
            f"## Link parameters ({ident.best}, {best.standard_source})",
            "",
            "Mass, centre of mass in the joint (child link) frame and principal moments of inertia about "
            "the centre of mass; joint friction.",
            "",
        ]
        rows = []
        joint_terms = TermSelection.from_names(robot["terms"]).joint  # the motor block follows
        # by name: a floating base's standard vector leads with its base link (base.*, no joint terms), so the
        # joints' blocks are not at 10·i (issue 47: the floating report's table was one body off)
        value = dict(zip(best.standard_names, map(float, best.standard)))
        floating = best.standard_names[:1] == ["base.m"]
        for j in (["base"] if floating else []) + list(robot["joints"]):
            m, c, I = tidy_inertial(*com_inertia(np.array([value[f"{j}.{n}"] for n in INERTIAL_NAMES])))
            ev = np.linalg.eigvalsh(0.5 * (I + I.T))
            ev[np.abs(ev) < NOISE * np.abs(ev).max()] = 0.0
            root = floating and j == "base"  # the free flyer: no joint, no joint terms
            names = [f"{j}.{n}" for n in INERTIAL_NAMES] + ([] if root else [f"{j}.{t.suffix}" for t in joint_terms])
            rows.append(
                [
                    "`base` (root link)" if root else f"`{j}`",
                    number_text(m),
                    " ".join(number_text(x, ".3g") for x in c),
                    " ".join(number_text(x, ".3g") for x in ev),
                ]
                + [
                    number_text(value[f"{j}.{t.suffix}"]) if f"{j}.{t.suffix}" in value and not root else "–"
                    for t in joint_terms
                ]
                + ([marks_summary(best.marks, names) or "–"] if best.marks else [])
            )
        units = [f"{t.name} [{t.unit}]" for t in joint_terms]  # revolute joints' units (pinid.model.terms)
        marked = ["from these data"] if best.marks else []
        lines.append(markdown_table(["joint", "mass [kg]", "c [m]", "principal I_c [kg·m²]"] + units + marked, rows))
        if best.marks:
            lines += [
                "",
                "*From these data*: which standard parameters (m, m·c, I about the joint frame, the joint terms) "
                "the recordings determine: *identified* (a base parameter by itself), *partly* (only in "
                "combinations with others: its value here is one completion of the base parameters), *not "
                "identified* (in no base parameter these recordings determine — a joint that stands still, or a σ "
                "above half the parameter's natural size: the data say nothing about it: the value is the URDF's, "
                "carried through by the completion unless physical consistency moved it, or the estimator's), *at "
                "bound* (held by the estimator on its constraint, e.g. friction ≥ 0).",
            ]

    lines += [
        "",
        "## Using the result",
        "",
        "```python",
        "from pinid.identification.identified import IdentifiedModel",
        "",
        f'model = IdentifiedModel.load("model_{ident.best}.json")',
        "tau = model.inverse_dynamics(q, dq, ddq)     # M(q) ddq + C(q, dq) dq + g(q) + friction(dq)",
        "M, C, g = model.mass_matrix(q), model.coriolis(q, dq), model.gravity(q)",
        "```",
        "",
    ]
    return "\n".join(lines)


def report_file_names(ident, *, figures: bool = True) -> list[str]:
    """The names of :func:`report_files`' files, in its order, without drawing anything."""
    names = figure_names(ident)
    return ["report.md", "report.html", *((names[key] for key in _shown_recipes(ident)) if figures else ())]


def _shown_recipes(ident) -> dict[str, Recipe]:
    """The recipes of the figures the report shows (:func:`shown_figures`), in :func:`figure_recipes`' order."""
    shown = set(shown_figures(ident))
    return {k: r for k, r in figure_recipes(ident).items() if k in shown}


def report_files(ident, *, figures: bool = True) -> dict[str, str | bytes]:
    """The report's files by name: ``report.md``, ``report.html`` (the same text, figures embedded) and the
    PNG figures (rendered once; none with ``figures=False``, which does not load matplotlib)."""
    from pinid.report.html import markdown_to_html

    pngs = {}
    if figures:
        from pinid.report.figures import figure_workers, render_pngs

        names, recipes = figure_names(ident), _shown_recipes(ident)
        drawn = render_pngs(grouped_recipes(recipes, figure_workers()))
        pngs = {names[key]: drawn[key] for key in recipes}  # in the recipes' order, whatever the groups
        text = report_markdown(ident, {k: n for k, n in names.items() if n in pngs})
    else:
        text = report_markdown(ident)
    page = markdown_to_html(text, pngs, title=f"pinid: identification of {ident.robot['name']}")
    return {"report.md": text, "report.html": page, **pngs}
