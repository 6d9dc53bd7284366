"""What ``pinid identify`` and ``pinid compare`` print and write, reachable from Python: an identification's
terminal summary and its files, a comparison's files.  Each set of files is planned as one
:class:`pinid.io.Artefacts` and written all or nothing (matplotlib loads only when figures are drawn)."""

from __future__ import annotations

import functools
import os
import textwrap
import warnings
from pathlib import Path

import numpy as np

from pinid.errors import ModelError, SpecError
from pinid.io import Artefacts, display_path, json_text
from pinid.report.figures import save_figure
from pinid.report.markdown import REPORT_FILES, floor_line, report_file_names, report_files, summary_table
from pinid.report.plot_compare import comparison_figures
from pinid.report.text import text_table

#: Every file an identification writes (patterns): what a ``--force`` re-run removes of an earlier run's.
IDENTIFICATION_FILES = (
    "identification.json",
    "model_*.json",
    "identified_*.urdf",
    "identified_*_drives.toml",
    "identified_*.xml",
    *REPORT_FILES,
)
#: Every file a comparison writes (patterns), likewise.
COMPARISON_FILES = ("comparison.json", "comparison.md", "compare_*.png")


# ============================================================================================ identify
def result_detail(r) -> str:
    """One method's detail (``pinid identify --verbose``): consistency, cond(W_b), time, status; the base
    parameters with standard deviations; the training and validation torque metrics."""
    if not hasattr(r, "physically_consistent"):
        raise SpecError(f"r: got {type(r).__name__}, expected an IdentificationResult")
    flag = "physically consistent" if r.physically_consistent else "NOT physically consistent"
    lines = [
        f"\n== {r.method}: {r.description}",
        f"   {flag} ({r.standard_source}); cond(W_b) {r.condition_number:.4g}; {r.seconds:.3f} s; status {r.status}",
    ]
    if not r.physically_consistent:
        lines += [f"   - {prob}" for prob in (r.consistency.get("problems") or [])[:4]]
    lines.append(_parameter_text(r, indent="   "))
    for kind, m in (
        ("train, raw (against the torque as recorded)", r.train),
        ("validation, raw", r.validation),
        ("train, filtered (against the low-passed torque)", r.train_filtered),
        ("validation, filtered", r.validation_filtered),
    ):
        if m is not None:
            lines += [
                f"   {kind}:",
                text_table(["joint", "RMS", "RMS %", "mean ± std |e|", "max |e|"], m.table(), indent="   "),
            ]
    return "\n".join(lines)


def _parameter_text(r, *, indent: str = "") -> str:
    """One method's base parameters: value, standard deviation, relative standard deviation σ% and, with a
    truth, the true value and the error (% of the truth, or the absolute error where the truth is 0)."""
    t = r.truth_error
    rows = []
    for n, v, s, sp in zip(r.base_names, r.base, r.std, r.std_percent):
        row = [n, f"{v:.6g}"] + (["—", "—"] if np.isnan(s) else [f"{s:.3g}", f"{sp:.3g}" if np.isfinite(sp) else "inf"])
        if t:
            rel = t["error_percent"].get(n)
            row += [f"{t['truth'][n]:.6g}", f"{rel:.3g}" if rel is not None else f"|e| {t['error'][n]:.2g}"]
        rows.append(row)
    head = ["parameter", "value", "std", "σ %"] + (["truth", "error %"] if t else [])
    return text_table(head, rows, indent=indent)


def identification_text(ident, *, verbose: bool = False) -> str:
    """What ``pinid identify`` prints after the work: the drive gains and the Stribeck velocities and shapes
    (when identified), the data used, every method's detail with ``verbose`` (:func:`result_detail`), and the
    summary table."""
    if not hasattr(ident, "results"):
        raise SpecError(f"ident: got {type(ident).__name__}, expected an Identification")
    d = ident.data
    lines = []
    if "drive_gains" in d:
        g = d["drive_gains"]
        lines.append(
            "drive gains [N·m per unit of the recorded channel]: "
            + ", ".join(f"{j} {k:.6g} ± {s:.2g}" for j, k, s in zip(g["joints"], g["gains"], g["std"]))
        )
    lines += [
        f"Stribeck {name}: velocity {v['velocity']:.6g} rad/s{' (fitted)' if v['fitted'] else ''}, "
        f"shape {v['shape']:.4g}{' (fitted)' if v.get('shape_fitted') else ''}"
        for name, v in d.get("stribeck", {}).items()
    ]
    for line in _recordings_lines(d, ident.robot.get("joints") or []):  # the choices made: wrapped at 120
        lines += textwrap.wrap(line, 120, subsequent_indent="  ", break_on_hyphens=False) if len(line) > 120 else [line]
    lines.append(
        f"training: {d['samples']} samples from {len(d['sources'])} recording(s), {d['rows']} torque rows used"
        + (f"; validation: {len(ident.validation_sources)} recording(s)" if ident.validation_sources else "")
    )
    lines += _offsets_lines(ident)
    if verbose:
        lines += [result_detail(r) for r in ident] + [""]
    elif ident.results and (ident.results[ident.best].truth_error or ident.results[ident.best].warning):
        best = ident.results[ident.best]  # against the truth, or poorly determined: every parameter's σ %
        what = "against the truth" if best.truth_error else "and their relative standard deviations"
        lines += [
            f"{ident.best} (best): base parameters {what}",
            _parameter_text(best),
            "",
        ]
    header, rows = summary_table(ident, bold=lambda text: text)
    lines.append(text_table(header, rows))
    lines.append(
        "RMS raw: against the torque as recorded; RMS filtered: against the low-passed torque (moves with --cutoff)"
    )
    floor = floor_line(ident)
    if floor is not None:
        lines += textwrap.wrap(floor, 120, subsequent_indent="  ", break_on_hyphens=False)
    calibration = str(d.get("calibration_text") or "").splitlines()  # a floating base's sensor calibration
    for line in axis_lines(ident) + mass_lines(ident) + calibration:
        lines += textwrap.wrap(line, 120, subsequent_indent="  ", break_on_hyphens=False)
    best = ident.results.get(ident.best) if ident.results else None
    if best is not None and len(best.base) and not np.all(np.isnan(best.std)):
        sp = best.std_percent
        k = int(np.nanargmax(np.where(np.isnan(sp) | np.isfinite(sp), sp, np.inf)))
        text = (
            f"{ident.best}: largest relative standard deviation σ % {sp[k]:.3g} ({best.base_names[k]}); "
            "every parameter's with --verbose and in the report"
        )
        lines += textwrap.wrap(text, 120, subsequent_indent="  ", break_on_hyphens=False)
    elif best is not None and len(best.base):
        lines.append(f"{ident.best}: no calibrated standard deviation (σ —) for this method")
    if best is not None and best.warning:  # one warning, wrapped to the terminal's 120 columns
        lines += textwrap.wrap(best.warning, 120, subsequent_indent="  ", break_on_hyphens=False)
    return "\n".join(lines)


def _pm(value: float, std: float, digits: str = ".4g") -> str:
    """``value ± σ`` (σ to 2 digits; "σ —" when there is none)."""
    return f"{value:{digits}} ± {std:.2g}" if np.isfinite(std) else f"{value:{digits}} (σ —)"


def axis_lines(ident) -> list[str]:
    """A floating base's error per base axis (``info["base_axes"]``) of the best method: RMS [N, N·m] and % of the
    measured RMS, forces then moments; [] otherwise."""
    if not hasattr(ident, "results"):
        raise SpecError(f"ident: got {type(ident).__name__}, expected an Identification")
    best = ident.results.get(ident.best) if ident.results else None
    axes = (best.info.get("base_axes") if best is not None else None) or {}
    if not axes:
        return []
    cells = [
        f"{a} {v['rms']:.3g} {'N' if a.startswith('f') else 'N·m'} ({v['rel_rms_percent']:.3g} %)"
        for a, v in axes.items()
        if isinstance(v, dict)
    ]
    return [f"base wrench, {axes.get('on', 'validation')} RMS per axis ({ident.best}): " + ", ".join(cells)]


def mass_lines(ident) -> list[str]:
    """The total mass and the whole-body centre of mass of each method with σ (a floating base whose rows determine
    them: ``info["total_mass"]``, ``info["com"]``, ``info["com_std"]``), beside the URDF's; [] otherwise."""
    if not hasattr(ident, "results"):
        raise SpecError(f"ident: got {type(ident).__name__}, expected an Identification")
    have = {m: r for m, r in ident.results.items() if "total_mass" in r.info}
    if not have:
        return []
    d = ident.data
    urdf = f" (URDF {d['total_mass_urdf']:.4g} kg)" if "total_mass_urdf" in d else ""
    lines = ["total mass [kg]: " + ", ".join(f"{m} {_pm(**r.info['total_mass'])}" for m, r in have.items()) + urdf]
    com = [
        f"{m} ({', '.join(_pm(c, s, '.3g') for c, s in zip(r.info['com'], r.info.get('com_std', [np.nan] * 3)))})"
        for m, r in have.items()
        if "com" in r.info
    ]
    if com:
        urdf = f"; URDF ({', '.join(f'{c:.3g}' for c in d['com_urdf'])})" if "com_urdf" in d else ""
        lines.append("centre of mass [m] (x, y, z in the base frame, mean training posture): " + ", ".join(com) + urdf)
    return lines


def _held_out_lines(curve: str) -> list[str]:
    """A cross-validation curve's text (``"5 Hz 3.9 %, …"``), wrapped at 120 columns under its choice."""
    return textwrap.wrap(
        f"held-out relative RMS against the torque as recorded: {curve}",
        120,
        initial_indent="  ",
        subsequent_indent="    ",
        break_on_hyphens=False,
    )


def _recordings_lines(d: dict, joints: list[str]) -> list[str]:
    """The torque delay and the joints left out of the fit (issue 28), one line each, when there are any."""
    lines = []
    if d.get("delay"):
        per = d["delay"]["per_joint"]
        values = sorted(set(per.values()))
        said = (
            f"{1e3 * values[0]:.4g} ms"
            if len(values) == 1
            else ", ".join(f"{j} {1e3 * v:.4g} ms" for j, v in per.items())
        )
        how = (
            f" (estimated on the training recordings in [{d['delay']['bounds'][0]:g}, {d['delay']['bounds'][1]:g}] s)"
            if d["delay"].get("estimated")
            else ""
        )
        lines.append(f"torque delay behind the positions: {said}{how}")
    if d.get("cutoff"):
        c = d["cutoff"]
        curve = ", ".join(
            f"{f:g} Hz {s:.3g} %" for f, s in zip(c["candidates_hz"], c["cv_rel_rms_percent"]) if s is not None
        )
        lines.append(f"low-pass cut-off {c['cutoff_hz']:g} Hz, chosen by {c['chosen_by']}")
        lines += _held_out_lines(curve)
    if d.get("terms_choice"):
        c = d["terms_choice"]
        lines.append(f"terms {', '.join(c['terms']) or 'none'}, chosen by {c['chosen_by']}")
        for k, step in enumerate(c["steps"]):
            said = ", ".join(f"{n} {v:.3g} %" for n, v in step.items() if v is not None)
            lines.append(f"  {'start' if k == 0 else f'step {k}'}: held-out relative RMS {said}")
    if d.get("default_terms"):
        c = d["default_terms"]
        said = ", ".join(f"{n} {v:.3g} %" for step in c["steps"] for n, v in step.items() if v is not None)
        said = said or "; ".join(f"{k} {v}" for k, v in (c.get("rejected") or {}).items())
        kept = "offset" in c["terms"]
        lines.append(
            f"terms {', '.join(c['terms'])}: the default, the offset {'kept: it wins' if kept else 'left out: it does not win'}"
            f" on held-out blocks of the training recordings ({said}); --terms sets them"
        )
    if d.get("ripple_periods"):
        c = d["ripple_periods"]
        curve = ", ".join(f"{r:g} {v:.3g} %" for r, v in zip(c["candidates"], c["cv_rel_rms_percent"]) if v is not None)
        lines.append(
            f"ripple periods per revolution {c['periods']:g}, chosen by {c['chosen_by']} "
            f"({'measurably better than' if c['measurably_better'] else 'not measurably better than'} no ripple, "
            f"{c['without_ripple_percent']:.3g} %{'' if c['measurably_better'] else ': the ripple terms are left out'})"
        )
        lines += _held_out_lines(curve)
    fit = d.get("fit_joints")
    if fit is not None and len(fit) < len(joints):
        left = [j for j in joints if j not in fit]
        lines.append(f"fit joints: {', '.join(fit)} (torque rows of {', '.join(left)} left out; still predicted)")
    return lines


def write_identification(
    ident,
    folder: str | os.PathLike,
    *,
    report: bool = True,
    figures: bool = True,
    force_export: bool = False,
    overwrite: bool | None = None,
) -> list[Path]:
    """Write an :class:`~pinid.identification.result.Identification` into ``folder``, all or nothing:
    ``identification.json``; ``model_<method>.json`` (:class:`~pinid.identification.identified.IdentifiedModel`)
    per method; ``identified_<method>.urdf`` (and ``identified_<method>_drives.toml`` with motor terms) per
    physically consistent method, or every method with ``force_export``; ``identified_<method>.xml`` (MuJoCo
    MJCF, :mod:`pinid.model.mjcf`) per physically consistent method MuJoCo accepts (else a warning); with ``report`` the report
    (``report.md``, ``report.html`` and, with ``figures``, the figures).  An earlier run's files in
    ``folder`` are removed.  A consistent result pinid cannot read back as a URDF gets none, with a
    warning.  ``overwrite``: replace existing files (None: the :data:`pinid.io.OVERWRITE` policy, which the
    CLI's ``--force`` sets).  Returns the paths written."""
    if not hasattr(ident, "results"):
        raise SpecError(f"ident: got {type(ident).__name__}, expected an Identification")
    urdfs, drives, mjcfs = {}, {}, {}
    for m, r in ident.results.items():  # everything is computed before any file is written
        if not (r.physically_consistent or force_export):
            continue
        try:
            urdfs[m] = r.export_urdf(force=force_export)
        except ModelError as exc:  # consistent within tolerance, yet not a URDF pinid reads back
            warnings.warn(f"no URDF for {m}: {exc}", stacklevel=2)
            continue
        text = r.model.export_drives()
        if text is not None:
            drives[m] = text
        if r.physically_consistent:
            try:
                mjcfs[m] = r.model.export_mjcf()
            except ModelError as exc:  # consistent, yet a body MuJoCo refuses (massless, a zero moment)
                warnings.warn(f"no MJCF for {m}: {exc}", stacklevel=2)
    models = {m: r.model.to_dict() for m, r in ident.results.items()}
    out = Path(folder)
    arts = Artefacts(overwrite=overwrite)
    arts.add(out / "identification.json", json_text(ident.to_dict()))
    for m, dm in models.items():
        arts.add(out / f"model_{m}.json", json_text(dm))
    for m, text in urdfs.items():
        arts.add(out / f"identified_{m}.urdf", text)
    for m, text in drives.items():
        arts.add(out / f"identified_{m}_drives.toml", text)
    for m, text in mjcfs.items():
        arts.add(out / f"identified_{m}.xml", text)
    if report:  # drawn once, when the first of its files is written (behind the others in pinid demo)
        files = functools.cache(lambda: report_files(ident, figures=figures))
        for name in report_file_names(ident, figures=figures):
            arts.add(out / name, lambda _, name=name: files()[name], behind=True)
    arts.clean(out, IDENTIFICATION_FILES)  # a --force re-run leaves none of an earlier run's outputs behind
    return arts.write()


# ============================================================================================ compare
def comparison_markdown(comp, *, command: str | None = None, figures=()) -> str:
    """``comparison.md``: the command line (when given), the comparison table, the identified values
    (mean ± spread over the seeds) and links to the ``figures`` (file names)."""
    if not hasattr(comp, "runs"):
        raise SpecError(f"comp: got {type(comp).__name__}, expected a Comparison")
    block = f"```\n{command}\n```\n\n" if command else ""
    return (
        f"# Comparison on {comp.robot['name']}\n\n{block}```\n{comp.table()}\n```\n\nIdentified base parameters "
        f"(mean ± spread over the seeds):\n\n```\n{comp.values_table()}\n```\n"
        + "".join(f"\n![{name}]({name})\n" for name in figures)
    )


def write_comparison(
    comp, folder: str | os.PathLike, *, command: str | None = None, figures: bool = True, overwrite: bool | None = None
) -> list[Path]:
    """Write a :class:`~pinid.identification.compare.Comparison` into ``folder``: ``comparison.json``,
    ``comparison.md`` (:func:`comparison_markdown`) and, with ``figures``, the ``compare_*.png`` figures;
    all or nothing, an earlier comparison's files there removed.  ``overwrite``: as in
    :func:`write_identification`.  Returns the paths written."""
    if not hasattr(comp, "runs"):
        raise SpecError(f"comp: got {type(comp).__name__}, expected a Comparison")
    out = Path(folder)
    figs = comparison_figures(comp) if figures else {}
    arts = Artefacts(overwrite=overwrite)
    arts.add(out / "comparison.json", lambda p: comp.save(p))
    arts.add(out / "comparison.md", comparison_markdown(comp, command=command, figures=figs))
    for name, fig in figs.items():
        arts.add(out / name, lambda p, fig=fig: save_figure(fig, p))
    arts.clean(out, COMPARISON_FILES)
    return arts.write()


def _offsets_lines(ident) -> list[str]:
    """With offsets per recording: the best method's offsets [N·m] of each recording, one line each."""
    info = ident.data.get("offsets")
    best = ident.results.get(ident.best) if ident.results else None
    if not info or best is None:
        return []
    fraction = info.get("calibrate_fraction")
    how = f"calibrated on the first {100 * fraction:.3g} %, scored on the rest" if fraction else "training mean"
    lines = [f"torque offsets per recording ({ident.best}, N·m; validation: {how}):"]
    for role, items in (best.info.get("offsets") or {}).items():
        for item in items:
            values = ", ".join(f"{j} {'–' if v is None else format(v, '.4g')}" for j, v in item["offsets"].items())
            lines.append(f"  {role} {display_path(item['source'])}: {values}")
    return lines
