"""``pinid identify``: identify dynamic parameters from recordings, validate, export."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from pinid.cli.common import (add_mapping_arguments, add_method_arguments, wrote_line, add_preprocessing_arguments, add_recording_arguments,
                              add_robot_arguments, add_stribeck_arguments, add_terms_argument, methods_from_args, nonnegative_float,
                              options_from_args, positive_int, preprocess_from_args, rest_velocity_from_args,
                              mapping_from_args, robot_from_args, terms_from_args)

HELP = "identify dynamic parameters from recordings (OLS, WLS, physically consistent LMI), validate, export"
DESCRIPTION = """\
Reads a URDF and one or more training recordings (CSV; --mapping names their columns), fills missing
velocities and accelerations (zero-phase filter and differentiation with defaults chosen from the
sample rate; measured velocities are used when present), identifies the base parameters with each
method, checks every result for physical consistency, validates on --validate recordings and writes
into the output folder (-o, default results/):

  identification.json      every method: base parameters with standard deviations, standard
                           parameters, consistency, condition number, train/validation metrics, time
  model_<method>.json      the identified model for controller code (pinid.identification.identified.IdentifiedModel)
  identified_<method>.urdf the URDF with identified inertials and friction (consistent results only,
                           unless --force-export)
  identified_<method>_drives.toml  with motor terms: the drives with the identified motor friction,
                           offset and rotor inertia (URDF has no field for them; read back with --drives)
  report.md, report.html   a readable report: summary table, robot and data, the excitation (training
                           motion), per-method sections, base and link parameters; the HTML page is
                           the same text with its figures embedded (one file, opens without a server)
  errors.png, training_motion.png, torque_<method>.png   the report's figures

Rows where a joint is nearly at rest are left out of the fit when Coulomb friction is in the model
(--rest-velocity).  Methods: ols (least squares), wls (each joint weighted by 1/its residual
variance), sdp (physically consistent least squares, pseudo-inertia LMI, cvxpy + Clarabel).

example:
  pinid identify --urdf urdf/exo_leg.urdf --data run1.csv --data run2.csv --validate run3.csv -o results/
  pinid identify --urdf double_pendulum.urdf --mapping docs/examples/double_pendulum.toml \\
      --data trajectory_00.csv --validate trajectory_01.csv --terms fc,fv,armature --methods ols,sdp
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_robot_arguments(p)
    add_terms_argument(p)
    add_recording_arguments(p)
    add_method_arguments(p, "ols,wls,sdp")
    add_mapping_arguments(p)
    p.add_argument("-o", "--output", default="results", metavar="FOLDER", help="output folder; default results/")
    add_preprocessing_arguments(p)
    g = p.add_argument_group("estimation")
    g.add_argument("--regularization", type=nonnegative_float, default=None,
                   help="sdp: weight of the pull toward the URDF in unidentifiable directions (default 1e-3)")
    g.add_argument("--mass-bounds", default=None, metavar="LO,HI", help="sdp: bounds on every body's mass [kg]")
    g.add_argument("--sdp-weighting", choices=("none", "joint"), default=None,
                   help="sdp: row weighting (none: as OLS, default; joint: as WLS)")
    g.add_argument("--wls-iterations", type=positive_int, default=None, help="wls: reweighting passes (default 1)")
    g = p.add_argument_group("stage 2: the wearer (docs/wearer.md)")
    g.add_argument("--stage", choices=("robot", "wearer"), default="robot",
                   help="robot: identify the URDF's robot (default); wearer: identify only the wearer of an "
                        "exo + wearer URDF (pinid wearer), the exoskeleton fixed to --exo")
    g.add_argument("--exo", default=None, metavar="MODEL_JSON",
                   help="--stage wearer: the stage-1 exoskeleton model (model_<method>.json of pinid identify)")
    g.add_argument("--mass-range", type=float, default=None, metavar="FRACTION",
                   help="--stage wearer: each body's wearer mass within ±FRACTION of the table's; default 0.3")
    g.add_argument("--prior-weight", type=nonnegative_float, default=0.0,
                   help="--stage wearer: pull of the identifiable directions toward the tables; default 0 "
                        "(the tables decide only what the data cannot see)")
    g.add_argument("--no-passive", action="store_true",
                   help="--stage wearer: do not identify the passive-moment scale factors (keep none)")
    g.add_argument("--passive-exponents", action="store_true",
                   help="--stage wearer: also fit the passive moments' exponents (nonlinear least squares from "
                        "the published values, within 0.5-2x of them; docs/wearer.md)")
    p.add_argument("-v", "--verbose", action="store_true",
                   help="also print every method's base parameters (value, std, std %%) and torque error per joint "
                        "(without it: the summary table; the detail is in report.md/report.html)")
    p.add_argument("--force-export", action="store_true",
                   help="also write identified URDFs of physically inconsistent results")
    g = p.add_argument_group("drive gains (the recordings hold currents: docs/drives.md#drive-gains-from-currents)")
    g.add_argument("--payload", default=None, metavar="TOML",
                   help="the known payload (link, mass [kg], com [m], inertia [kg·m²]) fixed for --payload-data")
    g.add_argument("--payload-data", action="append", default=None, metavar="FILE",
                   help="recording with the payload; with --payload, the drive gains are identified first and "
                        "the currents of every recording turned into torques; repeatable")
    add_stribeck_arguments(p)
    p.add_argument("--no-report", action="store_true", help="do not write report.md, report.html and the figures")
    p.add_argument("--no-figures", action="store_true",
                   help="write report.md and report.html without figures (faster: matplotlib is not loaded)")


def _options(args, methods) -> dict:
    from pinid.errors import SpecError

    opts: dict = {}
    if "sdp" in methods:
        sdp = {}
        if args.regularization is not None:
            sdp["regularization"] = args.regularization
        if args.sdp_weighting is not None:
            sdp["weighting"] = args.sdp_weighting
        if args.mass_bounds is not None:
            try:
                lo, hi = (float(x) for x in args.mass_bounds.split(","))
            except ValueError:
                raise SpecError(f"--mass-bounds {args.mass_bounds!r}: expected LO,HI in kg, e.g. 0.1,20") from None
            if not 0 <= lo <= hi:
                raise SpecError(f"--mass-bounds {args.mass_bounds!r}: expected 0 ≤ LO ≤ HI")
            sdp["mass_bounds"] = (lo, hi)
        if sdp:
            opts["sdp"] = sdp
    if "wls" in methods and args.wls_iterations is not None:
        opts["wls"] = {"iterations": args.wls_iterations}
    return opts


def print_result(r) -> None:
    """One method's detail (``--verbose``): base parameters with standard deviations, then torque metrics."""
    from pinid.report.text import text_table

    flag = "physically consistent" if r.physically_consistent else "NOT physically consistent"
    print(f"\n== {r.method}: {r.description}")
    print(f"   {flag} ({r.standard_source}); cond(W_b) {r.condition_number:.4g}; {r.seconds:.3f} s; status {r.status}")
    if not r.physically_consistent:
        for prob in (r.consistency.get("problems") or [])[:4]:
            print(f"   - {prob}")
    rows = [[n, f"{v:.6g}", f"{s:.3g}", f"{sp:.3g}" if np.isfinite(sp) else "inf"]
            for n, v, s, sp in zip(r.base_names, r.base, r.std, r.std_percent)]
    print(text_table(["parameter", "value", "std", "std %"], rows, indent="   "))
    for kind, m in (("train", r.train), ("validation", r.validation)):
        if m is not None:
            print(f"   {kind}:")
            print(text_table(["joint", "RMS", "RMS %", "mean ± std |e|", "max |e|"], m.table(), indent="   "))


def run(args: argparse.Namespace) -> int:
    import sys

    from pinid.errors import ModelError, SpecError
    from pinid.identification.core import identify
    from pinid.io import Artefacts
    from pinid.report.markdown import REPORT_FILES, summary_table
    from pinid.report.text import text_table

    out = Path(args.output)
    early = Artefacts()
    early.add(out / "identification.json", "")
    early.check()  # fail before the work (creates nothing)
    if (args.stage == "wearer") != (args.exo is not None):
        raise SpecError("--stage wearer and --exo MODEL_JSON go together (stage 2: the wearer, the exo fixed)")
    if args.stage == "wearer":
        return _run_wearer(args, out)
    methods = methods_from_args(args)
    model = robot_from_args(args)
    terms = terms_from_args(args)
    print(f"identifying {model.name} ({', '.join(model.joint_names)}) with {', '.join(methods)}; "
          f"terms {', '.join(terms.names) or 'none'}")
    ident = identify(
        model, args.data, methods=methods, validate=args.validate or None, terms=terms, mapping=mapping_from_args(args),
        preprocess=preprocess_from_args(args), rest_velocity=rest_velocity_from_args(args.rest_velocity),
        options=options_from_args(args, _options(args, methods)), show_progress=None,
        payload=args.payload, payload_data=args.payload_data,
        stribeck_velocity=args.stribeck_velocity, stribeck_shape=args.stribeck_shape,
    )
    d = ident.data
    if "drive_gains" in d:
        g = d["drive_gains"]
        print("drive gains [N·m per unit of the recorded channel]: " + ", ".join(
            f"{j} {k:.6g} ± {s:.2g}" for j, k, s in zip(g["joints"], g["gains"], g["std"])))
    for name, v in d.get("stribeck", {}).items():
        print(f"Stribeck {name}: velocity {v['velocity']:.6g} rad/s{' (fitted)' if v['fitted'] else ''}, "
              f"shape {v['shape']:.4g}{' (fitted)' if v.get('shape_fitted') else ''}")
    print(f"training: {d['samples']} samples from {len(d['sources'])} recording(s), {d['rows']} torque rows used"
          + (f"; validation: {len(ident.validation_sources)} recording(s)" if ident.validation_sources else ""))
    if args.verbose:
        for r in ident:
            print_result(r)
        print()
    header, rows = summary_table(ident, bold=lambda text: text)
    print(text_table(header, rows))
    # everything is computed before any file is written
    urdfs, drives, refused = {}, {}, []
    for m, r in ident.results.items():
        if r.physically_consistent or args.force_export:
            try:
                urdfs[m] = r.export_urdf(force=args.force_export)
            except ModelError as exc:  # consistent within tolerance, yet not a URDF pinid reads back
                print(f"pinid identify: warning: no URDF for {m}: {exc}", file=sys.stderr)
                refused.append(m)
                continue
            text = r.model.export_drives()
            if text is not None:
                drives[m] = text
        else:
            refused.append(m)
    models = {m: r.model.to_dict() for m, r in ident.results.items()}
    report = {}
    if not args.no_report:
        from pinid.report.markdown import report_files

        report = report_files(ident, figures=not args.no_figures)
    from pinid.io import json_text as as_json

    arts = Artefacts()  # all or nothing: checked, written to a temporary folder, moved into place
    arts.add(out / "identification.json", as_json(ident.to_dict()))
    for m, dm in models.items():
        arts.add(out / f"model_{m}.json", as_json(dm))
    for m, text in urdfs.items():
        arts.add(out / f"identified_{m}.urdf", text)
    for m, text in drives.items():
        arts.add(out / f"identified_{m}_drives.toml", text)
    for name, content in report.items():
        arts.add(out / name, content)
    # a --force re-run into an earlier run's folder leaves none of that run's outputs behind
    arts.clean(out, ["identification.json", "model_*.json", "identified_*.urdf", "identified_*_drives.toml",
                     *REPORT_FILES])
    written = arts.write()
    print(f"\nbest: {ident.best}" + (f"; no URDF for inconsistent result(s) {', '.join(refused)} "
                                       "(--force-export writes them)" if refused else ""))
    print(wrote_line(written, out))
    return 0


def _run_wearer(args: argparse.Namespace, out: Path) -> int:
    """Stage 2: the wearer of ``--urdf`` identified with the exoskeleton fixed to ``--exo``."""
    from pinid.identification.problem import load_datasets
    from pinid.io import Artefacts, json_text
    from pinid.wearer.prior import MASS_RANGE
    from pinid.report.wearer import WEARER_REPORT_FILES
    from pinid.wearer.stage import identify_wearer, stack

    robot = robot_from_args(args)
    pre = preprocess_from_args(args)
    mapping = mapping_from_args(args)
    train = load_datasets(args.data, robot, mapping, pre, "training")
    val = load_datasets(args.validate or None, robot, mapping, pre, "validation")
    fit = identify_wearer(args.exo, robot, *stack(train), passive=not args.no_passive,
                          mass_range=MASS_RANGE if args.mass_range is None else args.mass_range,
                          prior_weight=args.prior_weight, passive_exponents=args.passive_exponents)
    result = {"stage": "wearer", "exo": args.exo, "urdf": str(robot.urdf_path), **fit.to_dict(),
              "train_rms": fit.rms(train), "validation_rms": fit.rms(val) if val else None}
    print(f"stage 2 (wearer) of {robot.name}: status {fit.status}, {fit.seconds:.2f} s")
    if fit.exponents is not None:
        e = fit.exponents
        print(f"   passive exponents: {len(e.free)} fitted in {e.evaluations} evaluations ({e.seconds:.2f} s); "
              f"torque RMS {e.rms_published:.4g} N·m at the published, {e.rms_fitted:.4g} at the fitted")
    width = max(len(n) for n in fit.base_names)
    print(f"   {'base parameter':<{width}} {'identified':>13} {'table':>13}")
    for n, v, t in zip(fit.base_names, fit.base, fit.base_table):
        print(f"   {n:<{width}} {v:13.6g} {t:13.6g}")
    for kind in ("train_rms", "validation_rms"):
        if result[kind]:
            print(f"   {kind.replace('_', ' ')} [N·m]: " + "; ".join(
                f"{w} " + ", ".join(f"{j} {v:.4g}" for j, v in r.items()) for w, r in result[kind].items()))
    report = {}
    if not args.no_report:
        from pinid.report.wearer import wearer_report_files

        shown, kind = (val, "validation") if val else (train, "training")
        q, dq, ddq, tau = stack(shown[:1])
        curves = {"t": shown[0].t, "measured": tau, "joints": robot.joint_names, "kind": kind,
                  "source": Path(str(shown[0].source)).name,
                  "predicted": {w: fit.model(w).inverse_dynamics(q, dq, ddq) for w in ("identified", "table", "exo")}}
        report = wearer_report_files(result, curves, figures=not args.no_figures)
    arts = Artefacts()  # all or nothing
    arts.add(out / "identification.json", json_text(result))
    arts.add(out / "model_wearer.json", json_text(fit.model("identified").to_dict()))
    arts.add(out / "model_table.json", json_text(fit.model("table").to_dict()))
    for name, content in report.items():
        arts.add(out / name, content)
    arts.clean(out, WEARER_REPORT_FILES)  # a --force re-run leaves no stale report or figure
    written = arts.write()
    print(wrote_line(written, out))
    return 0
