"""The report's parts of a floating base (issue 46): its figures' recipes (:mod:`pinid.report.plot_floating`), their
lines in the report, the total mass and centre of mass table.  What it draws is handed to it in the identification
(``curves``, ``info``); it imports no identification module."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pinid.report.figures import Recipe


def shown_estimates(ident) -> dict[str, dict]:
    """The base-parameter estimates a parameter figure shows: the best method's and OLS's (when run and not the
    best), each ``{"value", "std", "consistent"}``."""
    shown = [ident.best] + (["ols"] if "ols" in ident.results and ident.best != "ols" else [])
    return {
        m: {
            "value": ident.results[m].base,
            "std": ident.results[m].std,
            "consistent": ident.results[m].physically_consistent,
        }
        for m in shown
    }


def _table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table (as :func:`pinid.report.markdown.markdown_table`, which imports this module)."""

    def line(cells) -> str:
        return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"

    return "\n".join([line(header), "|" + "|".join("---" for _ in header) + "|"] + [line(r) for r in rows])


def isis_floating(ident) -> bool:
    """A floating base's identification (its figures: pinid.report.plot_floating)."""
    return (ident.data or {}).get("base") == "floating"


def floating_recipes(ident, joints: list[str], window: float) -> dict[str, Recipe]:
    """The figures of a floating base (:mod:`pinid.report.plot_floating`): the errors of the rows used per base
    axis (and joint, when joint rows were used), the determined base parameters, the base wrench measured against
    predicted, the contact phases and the base trajectory; the motion figure with positions alone beyond 8 joints."""
    from pinid.report import plot_floating as pf

    figs: dict[str, Recipe] = {}
    c = ident.curves or {}
    rows = (ident.data or {}).get("rows", "all")
    axes = {m: r.info["base_axes"] for m, r in ident.results.items() if r.info.get("base_axes")}
    on = next((a.get("on") for a in axes.values()), "validation")
    joint_err = None
    if rows != "base":
        joint_err = {}
        for m, r in ident.results.items():
            met = r.validation if r.validation is not None else r.train
            per = (met.to_dict() if hasattr(met, "to_dict") else met).get("per_joint", {})
            joint_err[m] = {
                j: {"rms": v.get("rms"), "rel_rms_percent": v.get("rel_rms_percent")}
                for j, v in per.items()
                if j != "base" and v.get("rms") is not None and np.isfinite(v.get("rms"))
            }
    if axes:
        title = (
            f"RMS error of the rows used ({on}, against the prepared wrench{'' if rows == 'base' else ' and torques'})"
        )
        figs["errors"] = (pf.wrench_errors, (axes, joint_err or None), {"title": title})
    names = ident.base.get("names") or []
    if names and ident.results:
        scale = np.asarray(ident.base.get("scale") or [1.0] * len(names), dtype=float)
        determined = determined_mask(ident)
        estimates = shown_estimates(ident)
        figs["parameters"] = (
            pf.determined_parameters,
            (names, ident.base.get("nominal") or [None] * len(names), list(scale), estimates, determined),
            {},
        )
    w = c.get("wrench")
    if w is not None and len(w["t"]):
        best_axes = ident.results[ident.best].info.get("base_axes") or {}
        span = f", first {window:g} s" if w["t"][-1] - w["t"][0] > window else ""
        title = f"base wrench, measured and predicted ({w['kind']}, {Path(str(w['source'])).name}{span}; base frame)"
        errors = {a: v for a, v in best_axes.items() if isinstance(v, dict)}
        figs["wrench"] = (
            pf.wrench_comparison,
            (w["t"], w["measured"], w["predicted"]),
            {"errors": errors, "title": title, "window": window},
        )
    k = c.get("contacts")
    if k is not None and len(k["t"]):
        span = f", first {window:g} s" if k["t"][-1] - k["t"][0] > window else ""
        weight = 9.81 * float((ident.data or {}).get("total_mass_urdf") or 0.0)
        title = f"contact phases ({k['kind']}, {Path(str(k['source'])).name}{span})"
        figs["contacts"] = (
            pf.contact_phases,
            (k["t"], k["forces"]),
            {"threshold": 0.05 * weight if weight > 0 else None, "title": title, "window": window},
        )
    if c.get("base"):
        figs["base_motion"] = (pf.base_trajectory, (c["base"],), {"title": "base trajectory (motion capture)"})
    motion = c.get("motion")
    if motion is not None and len(motion["t"]) and c.get("chains"):
        t = np.asarray(motion["t"])
        span = f", first {window:g} s" if t[-1] - t[0] > window else ""
        title = f"training motion: joint positions per chain ({Path(str(motion['source'])).name}{span})"
        figs["motion"] = (pf.chain_motion, (t, motion["q"], joints, c["chains"]), {"window": window, "title": title})
    return figs


def determined_mask(ident) -> np.ndarray:
    """(nb,) booleans: the base parameters the data determine (2σ of the best method within the fraction of their
    natural scale the identification says, ``curves["determined"]``: pinid.identification.floating_checks'
    EXCITED_FRACTION); all False without it (a loaded result)."""
    names = ident.base.get("names") or []
    d = (ident.curves or {}).get("determined")
    return np.zeros(len(names), bool) if d is None or len(d) != len(names) else np.asarray(d, bool)


def undetermined(ident) -> list[str]:
    """A floating base's base parameters the parameter figure leaves out of its determined ones; [] for a fixed
    base or a loaded result."""
    if not isis_floating(ident) or not ident.results or (ident.curves or {}).get("determined") is None:
        return []
    names = ident.base.get("names") or []
    return [n for n, d in zip(names, determined_mask(ident)) if not d]


def floating_figure_lines(ident, figures: dict[str, str]) -> list[str]:
    """The report's lines of a floating base's figures (those of ``figures``' keys that exist), and the base
    parameters the parameter figure leaves out."""
    lines: list[str] = []
    if "wrench" in figures:
        lines += [
            "",
            f"### The base wrench ({ident.best})",
            "",
            "The wrench the contacts apply to the whole robot, in the base frame (the 6 base rows), as measured "
            "(grey) and as the identified model predicts it from the motion; forces [N] on the left, moments [N·m] "
            "on the right.",
            "",
            f"![base wrench: measured and predicted]({figures['wrench']})",
        ]
    if "contacts" in figures:
        lines += ["", f"![contact phases: normal force under each contact]({figures['contacts']})"]
    if "base_motion" in figures:
        lines += ["", f"![base trajectory: path, height and heading]({figures['base_motion']})"]
    left_out = undetermined(ident)
    if left_out and "parameters" in figures:
        lines += [
            "",
            f"Not determined by these data (2σ of {ident.best} above 10 % of the natural scale; the figure shows the "
            "best of them in grey): " + ", ".join(f"`{n}`" for n in left_out) + ".",
        ]
    return lines


def mass_section(ident) -> list[str]:
    """A floating base's total mass and whole-body centre of mass per method with σ, beside the URDF's (issue 46);
    nothing when the rows used do not determine them."""
    have = {m: r for m, r in ident.results.items() if "total_mass" in r.info}
    if not have:
        return []

    def pm(v, s, fmt=".4g"):
        return f"{v:{fmt}} ± {s:.2g}" if np.isfinite(s) else f"{v:{fmt}} (σ —)"

    com = any("com" in r.info for r in have.values())  # a floating base's; a fixed base has the mass alone
    rows = []
    for m, r in have.items():
        tm, c3, std = r.info["total_mass"], r.info.get("com", [np.nan] * 3), r.info.get("com_std", [np.nan] * 3)
        rows.append([m, pm(tm["value"], tm["std"]), *((pm(c, s, ".3g") for c, s in zip(c3, std)) if com else ())])
    d = ident.data
    if "total_mass_urdf" in d:
        urdf_com = (f"{c:.3g}" for c in d.get("com_urdf", [np.nan] * 3)) if com else ()
        rows.append(["URDF", f"{d['total_mass_urdf']:.4g}", *urdf_com])
    header = ["method", "total mass [kg]"] + (["CoM x [m]", "CoM y [m]", "CoM z [m]"] if com else [])
    what = "the whole-body centre of mass (base frame, at the mean training posture)" if com else "nothing else"
    return [
        "",
        "### Total mass and centre of mass" if com else "### Total mass",
        "",
        f"The total mass and {what} the rows used determine, ± 1σ (the Newey–West σ of the base parameters"
        + (", linearised for the centre of mass)." if com else ")."),
        "",
        _table(header, rows),
    ]
