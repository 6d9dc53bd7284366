"""The stage-2 (wearer) report: ``report.md`` and ``report.html`` next to stage 2's identification.json.

From the stage-2 result (the identification.json dict of ``pinid identify --stage wearer``): the torque
RMS of exo + identified wearer, exo + table wearer and exo alone on the training and validation
recordings, the wearer's base parameters (identified vs table), its standard parameters per body, the
passive moments' scale factors and, when fitted, their exponents; and the figures ``torque_wearer.png``,
measured vs predicted torque of the three models (:func:`pinid.report.plot_identification.torque_comparison`),
``attachment_wearer.png``, where the segments attach (:func:`pinid.report.plot_wearer.attachment_figure`),
and ``segments_wearer.png``, the identified masses and centres of mass against the tables
(:func:`pinid.report.plot_wearer.segment_masses_figure`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pinid.errors import SpecError
from pinid.io import display_path
from pinid.report.markdown import WINDOW, markdown_table, number_text

#: Every file the stage-2 report writes (``pinid identify --stage wearer`` removes an earlier run's).
WEARER_REPORT_FILES = ("report.md", "report.html", "torque_wearer.png", "attachment_wearer.png", "segments_wearer.png")

#: The three models of stage 2, in the report's order, and what to call them.
MODELS = {"identified": "exo + identified wearer", "table": "exo + table wearer", "exo": "exo alone"}
#: Their colours in torque_wearer.png, one each (issue 47: the method colours chosen from the names drew two of the
#: three in the same green), none a grey of the measurements.
MODEL_COLORS = {"identified": "tab:blue", "table": "tab:orange", "exo": "tab:purple"}


def _rms_table(rms: Mapping[str, Mapping[str, float]]) -> str:
    joints = list(next(iter(rms.values())))
    rows = [
        [MODELS[w]]
        + [number_text(rms[w][j]) for j in joints]
        + [number_text(float(np.sqrt(np.mean(np.square(list(rms[w].values()))))))]
        for w in MODELS
        if w in rms
    ]
    return markdown_table(["model"] + [f"{j} [N·m]" for j in joints] + ["all joints [N·m]"], rows)


def _prior_weight_line(result: Mapping) -> str:
    """How far the identifiable directions were pulled toward the tables, and how λ was chosen."""
    cv = result.get("prior_weight_cross_validation")
    lam = result.get("prior_weight", 0.0)
    if not cv:
        return f"Prior weight λ = {lam:g} (given)."
    cells = ", ".join(f"{w:g}: {number_text(r)}" for w, r in zip(cv["weights"], cv["heldout_rms"]))
    return (
        f"Prior weight λ = {lam:g}, chosen by {cv['folds']}-fold blocked cross-validation on the recording "
        f"(held-out torque RMS [N·m] per λ: {cells})."
    )


def _wearer_markdown(result: Mapping, figures: Mapping[str, str] | None = None) -> str:
    """The report text of stage-2 ``result``; ``figures`` maps ``"torque"``, ``"attachment"`` and
    ``"segments"`` to the file names to link."""
    from pinid import __version__

    figures = figures or {}
    exo = f"`{display_path(result['exo'])}`" if result.get("exo") else "a stage-1 model given in Python"
    lines = [
        f"# Stage 2: the wearer of `{display_path(result['urdf'])}`",
        "",
        f"pinid {__version__}; the exoskeleton fixed to {exo} (stage 1); "
        f"solver status {result['status']}, {result['seconds']:.2f} s.",
        "",
        _prior_weight_line(result),
        "",
        "Bodies carrying wearer segments: "
        + ", ".join(f"`{j}` ({', '.join(s)})" for j, s in result["bodies"].items())
        + ".",
        "",
    ]
    if "attachment" in figures:
        lines += [
            "Where the segments attach (the robot in its zero pose; each segment's exo link frame and its "
            "centre of mass, from the tables):",
            "",
            f"![where the wearer's segments attach]({figures['attachment']})",
            "",
        ]
    lines += [
        "## Torque RMS",
        "",
    ]
    for kind, title in (("train_rms", "Training"), ("validation_rms", "Validation")):
        if result.get(kind):
            lines += [f"{title}:", "", _rms_table(result[kind]), ""]
    if not result.get("validation_rms"):
        lines += ["No validation recording (`--validate`): the training figures favour the identified wearer.", ""]
    if "torque" in figures:
        lines += [f"![measured and predicted torque of the three models]({figures['torque']})", ""]
    base, table = result["base"], result["base_table"]
    lines += [
        "## The wearer's base parameters",
        "",
        "What the data determine (identified) against the anthropometric tables; the rest of the "
        "standard parameters follow the tables (stage 2's null-space pull).",
        "",
        markdown_table(
            ["base parameter", "identified", "table", "difference %"],
            [
                [
                    f"`{n}`",
                    number_text(v, ".6g"),
                    number_text(table[n], ".6g"),
                    number_text(100 * (v - table[n]) / table[n], "+.3g") if table[n] else "–",
                ]
                for n, v in base.items()
            ],
        ),
        "",
    ]
    if "segments" in figures:
        lines += [
            "",
            "## The wearer's masses and centres of mass against the tables",
            "",
            "Per body, the wearer's share identified (bars) and the tables' (black lines): mass [kg] and centre "
            "of mass about the joint frame [m] (m·c / m).",
            "",
            f"![identified segment masses and centres of mass against the tables]({figures['segments']})",
        ]
    lines += [
        "",
        "## The wearer's standard parameters",
        "",
        "Per body (about the joint frame: m [kg], m·c [kg·m], inertia [kg·m²]; kp: scale of the "
        "published passive moment).  *From these data*: identified (a base parameter by itself), partly (only "
        "in combinations), not identified (the data say nothing about it: the value comes from the tables and the "
        "consistency constraints).",
        "",
        markdown_table(
            ["parameter", "identified", "table"] + (["from these data"] if result.get("marks") else []),
            [
                [f"`{n}`", number_text(v, ".6g"), number_text(result["table"][n], ".6g")]
                + ([result["marks"].get(n, "–")] if result.get("marks") else [])
                for n, v in result["parameters"].items()
                if v or result["table"][n]
            ],
        ),
    ]
    exp = result.get("passive_exponents")
    if exp:
        rows = []
        for name in exp["free"]:
            joint, rest = name.split("[", 1)
            k, col = int(rest.split("]")[0]), " HKA".index(name[-1])
            pub, fit = exp["published"][joint][k][col], exp["fitted"][joint][k][col]
            rows.append([f"`{name}`", number_text(pub, ".6g"), number_text(fit, ".6g"), number_text(fit / pub, ".4g")])
        lines += [
            "",
            "## Passive-moment exponents",
            "",
            f"Fitted by nonlinear least squares from the published values (Riener & Edrich 1999), within "
            f"0.5–2× of them: {len(exp['free'])} coefficients [1/deg], {exp['evaluations']} evaluations, "
            f"{exp['seconds']:.2f} s. Torque RMS of the unconstrained fit: {number_text(exp['rms_published'])} N·m "
            f"at the published exponents, {number_text(exp['rms_fitted'])} N·m at the fitted ones.",
            "",
            markdown_table(["coefficient", "published", "fitted", "fitted / published"], rows),
        ]
    lines += [
        "",
        "## Using the result",
        "",
        "```python",
        "from pinid.identification.identified import IdentifiedModel",
        "",
        'model = IdentifiedModel.load("model_wearer.json")   # exo + identified wearer (model_table.json: the tables)',
        "tau = model.inverse_dynamics(q, dq, ddq)",
        "g = model.gravity(q)                               # passive moments included",
        "```",
        "",
    ]
    return "\n".join(lines)


def torque_figure(curves: Mapping):
    """``torque_wearer.png``'s figure: the measured torque of ``curves`` (:func:`wearer_report_files`' form)
    and the three models' predictions per joint, the first :data:`~pinid.report.markdown.WINDOW` seconds."""
    from pinid.report.plot_identification import torque_comparison  # loads matplotlib: on use only

    if not isinstance(curves, Mapping) or not all(k in curves for k in ("t", "measured", "predicted", "joints")):
        raise SpecError(
            "curves: expected the dict of pinid.wearer.stage.torque_curves (t, measured, predicted, joints)"
        )
    t = np.asarray(curves["t"], dtype=float)
    span = f", first {WINDOW:g} s" if len(t) and t[-1] - t[0] > WINDOW else ""
    return torque_comparison(
        t,
        curves["measured"],
        {MODELS[w]: p for w, p in curves["predicted"].items()},
        list(curves["joints"]),
        window=WINDOW,
        colors={MODELS[w]: MODEL_COLORS[w] for w in curves["predicted"] if w in MODEL_COLORS},
        title=f"measured and predicted torque ({curves.get('kind', 'training')}, {curves.get('source', '')}{span})",
    )


def wearer_report_files(
    result: Mapping, curves: Mapping | None = None, *, figures: bool = True, attachment: tuple | None = None
) -> dict[str, str | bytes]:
    """``report.md``, ``report.html`` (figures embedded) and the figures of stage-2 ``result``:
    ``segments_wearer.png`` (masses and centres of mass against the tables), ``torque_wearer.png`` with
    ``curves`` and ``attachment_wearer.png`` with ``attachment``; none with ``figures=False``, which does
    not load matplotlib.

    ``curves``: ``{"t" (N,) [s], "measured" (N, nv) [N·m], "predicted": {model: (N, nv)}, "joints",
    "source", "kind"}``; ``attachment``: ``(urdf_text, segments)``, the exo + wearer URDF and its segments
    (:func:`pinid.wearer.attach.wearer_segments`)."""
    from pinid.report.html import markdown_to_html

    pngs = {}
    linked = {}
    if figures and attachment:
        from pinid.report.figures import figure_png
        from pinid.report.plot_wearer import attachment_figure

        urdf_text, segments = attachment
        title = "where the segments attach (zero pose)"
        pngs["attachment_wearer.png"] = figure_png(attachment_figure(urdf_text, segments, title=title))
        linked["attachment"] = "attachment_wearer.png"
    if figures and curves:
        from pinid.report.figures import figure_png

        pngs["torque_wearer.png"] = figure_png(torque_figure(curves))
        linked["torque"] = "torque_wearer.png"
    if figures:
        from pinid.report.figures import figure_png
        from pinid.report.plot_wearer import segment_masses_figure

        pngs["segments_wearer.png"] = figure_png(segment_masses_figure(result))
        linked["segments"] = "segments_wearer.png"
    text = _wearer_markdown(result, linked)
    return {"report.md": text, "report.html": markdown_to_html(text, pngs, title="pinid: stage 2, the wearer"), **pngs}
