"""``pinid identify``: identify dynamic parameters from recordings, validate, export."""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

from pinid.cli.common import (
    add_floating_arguments,
    estimators_text,
    add_mapping_arguments,
    add_method_arguments,
    wrote_line,
    add_preprocessing_arguments,
    add_recording_arguments,
    add_robot_arguments,
    add_stribeck_arguments,
    add_terms_argument,
    methods_from_args,
    nonnegative_float,
    options_from_args,
    positive_int,
    preprocess_from_args,
    recording_options,
    study_from_args,
    rest_velocity_from_args,
    mapping_from_args,
    robot_from_args,
    terms_from_args,
)
from pinid.errors import DataWarning, SpecError
from pinid.identification.run import identify
from pinid.identification.study import Study
from pinid.model.terms_ripple import periods_from_text
from pinid.io import check_outputs
from pinid.report.figures import start_figure_workers

#: The default --methods and --terms of stage 1 (None in the namespace: not given, so stage 2 can refuse them).
DEFAULT_METHODS, DEFAULT_TERMS = "ols,wls,sdp", "default"

HELP = (
    f"identify dynamic parameters from recordings with the registry's estimators (default {DEFAULT_METHODS}), "
    "validate, export"
)
DESCRIPTION = f"""\
Reads a URDF and one or more training recordings (CSV; --mapping names their columns), fills missing
velocities and accelerations (zero-phase filter and differentiation with defaults chosen from the
sample rate; measured velocities are used when present), identifies the base parameters with each
method, checks every result for physical consistency, validates on --validate recordings and writes
into the output folder (-o, default results/):

  identification.json      every method: base parameters with standard deviations (and errors against
                           --truth), standard parameters, consistency, condition number, train/validation
                           torque errors (raw: against the torque as recorded; filtered: after the
                           low-pass), time
  model_<method>.json      the identified model for controller code (pinid.identification.identified.IdentifiedModel)
  identified_<method>.urdf the URDF with identified inertials and friction (consistent results only,
                           unless --force-export)
  identified_<method>_drives.toml  with motor terms: the drives with the identified motor friction,
                           offset and rotor inertia (URDF has no field for them; read back with --drives)
  report.md, report.html   a readable report: the comparison first (summary table, error, parameter
                           and torque figures), robot and data, the excitation (training motion), each
                           method's detail folded, base and link parameters; the HTML page is the same
                           text with its figures embedded (one file, opens without a server)
  errors.png, parameters.png, predictions.png, training_motion.png, torque_<best method>.png,
  cross_validation.png (with --cutoff auto or --terms auto: the held-out errors the choice was made on)
                           the report's figures

With --base floating (docs/floating-base.md) the recordings also hold the base motion (motion capture or
an IMU), contact wrenches (link-frame sensors or force plates) and contact phases; the fit uses the 6 base
rows and the joint rows (--rows), the files are the same (the URDF and MJCF with the base link's inertial
and a free joint; errors per body, "base" the 6 wrench rows).

Rows where a joint is nearly at rest are left out of the fit when Coulomb friction is in the model
(--rest-velocity; with --stage wearer only when the option is given).  Torque errors are measured against the torque as recorded ("raw", the headline)
and against the low-passed torque ("filtered", which moves with --cutoff).  A one-line warning names
the parameters the data determine poorly (cond(W_b) > 1e3 or a relative standard deviation > 10 %).

methods of the estimator registry (--methods, default {DEFAULT_METHODS}; all: every one):
{estimators_text()}

examples:
  pinid identify --urdf urdf/exo_leg.urdf --data run1.csv --data run2.csv --validate run3.csv -o results/
  pinid identify --urdf double_pendulum.urdf --mapping docs/examples/double_pendulum.toml \\
      --data trajectory_00.csv --validate trajectory_01.csv --terms fc,fv,armature --methods ols,sdp
"""


#: Options of stage 1 that stage 2 (--stage wearer) does not use: (dest, option); stage 2 refuses them
#: rather than ignore them (its terms, method and drives come from the stage-1 model and the wearer URDF).
STAGE1_ONLY = (
    ("methods", "--methods"),
    ("terms", "--terms"),
    ("option", "--option"),
    ("payload", "--payload"),
    ("payload_data", "--payload-data"),
    ("regularization", "--regularization"),
    ("mass_bounds", "--mass-bounds"),
    ("sdp_weighting", "--sdp-weighting"),
    ("wls_iterations", "--wls-iterations"),
    ("force_export", "--force-export"),
    ("stribeck_velocity", "--stribeck-velocity"),
    ("stribeck_shape", "--stribeck-shape"),
    ("offsets", "--offsets"),
    ("calibrate_offsets", "--calibrate-offsets"),
    ("ripple_periods", "--ripple-periods"),
    ("sigmoid_shape", "--sigmoid-shape"),
)
#: Options of stage 2 that stage 1 does not use.
STAGE2_ONLY = (
    ("mass_range", "--mass-range"),
    ("prior_weight", "--prior-weight"),
    ("no_passive", "--no-passive"),
    ("passive_exponents", "--passive-exponents"),
)


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_robot_arguments(p, base=True)
    add_terms_argument(p)
    add_recording_arguments(p)
    add_method_arguments(p, DEFAULT_METHODS)
    add_mapping_arguments(p)
    p.add_argument("-o", "--output", default="results", metavar="FOLDER", help="output folder; default results/")
    p.add_argument(
        "--truth",
        default=None,
        metavar="FILE",
        help="the truth JSON pinid simulate writes beside its recording (run.truth.json): every base "
        "parameter's error against it in the table, report and JSON",
    )
    add_preprocessing_arguments(p)
    g = p.add_argument_group("estimation")
    g.add_argument(
        "--regularization",
        type=nonnegative_float,
        default=None,
        help="sdp: weight of the pull toward the URDF in unidentifiable directions (default 1e-3)",
    )
    g.add_argument("--mass-bounds", default=None, metavar="LO,HI", help="sdp: bounds on every body's mass [kg]")
    g.add_argument(
        "--sdp-weighting",
        choices=("none", "joint"),
        default=None,
        help="sdp: row weighting (none: as OLS, default; joint: as WLS)",
    )
    g.add_argument("--wls-iterations", type=positive_int, default=None, help="wls: reweighting passes (default 1)")
    add_floating_arguments(p)
    g = p.add_argument_group("stage 2: the wearer (docs/wearer.md)")
    g.add_argument(
        "--stage",
        choices=("robot", "wearer"),
        default="robot",
        help="robot: identify the URDF's robot (default); wearer: identify only the wearer of an "
        "exo + wearer URDF (pinid wearer), the exoskeleton fixed to --exo",
    )
    g.add_argument(
        "--exo",
        default=None,
        metavar="MODEL_JSON",
        help="--stage wearer: the stage-1 exoskeleton model (model_<method>.json of pinid identify)",
    )
    g.add_argument(
        "--mass-range",
        type=float,
        default=None,
        metavar="FRACTION",
        help="--stage wearer: each body's wearer mass within ±FRACTION of the table's; default 0.3",
    )
    g.add_argument(
        "--prior-weight",
        type=_prior_weight,
        default="auto",
        metavar="LAMBDA|auto",
        help="--stage wearer: pull of the identifiable directions toward the tables (0: the tables decide "
        "only what the data cannot see); default auto: chosen by 5-fold blocked cross-validation",
    )
    g.add_argument(
        "--no-passive",
        action="store_true",
        help="--stage wearer: do not identify the passive-moment scale factors (keep none)",
    )
    g.add_argument(
        "--passive-exponents",
        action="store_true",
        help="--stage wearer: also fit the passive moments' exponents (nonlinear least squares from "
        "the published values, within 0.5-2x of them; docs/wearer.md)",
    )
    p.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        help="also print every method's base parameters (value, std, std %%) and torque error per joint "
        "(without it: the summary table; the detail is in report.md/report.html)",
    )
    p.add_argument(
        "--force-export", action="store_true", help="also write identified URDFs of physically inconsistent results"
    )
    g = p.add_argument_group("drive gains (the recordings hold currents: docs/drives.md#drive-gains-from-currents)")
    g.add_argument(
        "--payload",
        default=None,
        metavar="TOML",
        help="the known payload (link, mass [kg], com [m], inertia [kg·m²]) fixed for --payload-data",
    )
    g.add_argument(
        "--payload-data",
        action="append",
        default=None,
        metavar="FILE",
        help="recording with the payload; with --payload, the drive gains are identified first and "
        "the currents of every recording turned into torques; repeatable",
    )
    add_stribeck_arguments(p)
    g = p.add_argument_group("torque offsets per recording (docs/identification.md#torque-offsets-per-recording)")
    g.add_argument(
        "--offsets",
        default=None,
        choices=("per-recording",),
        help="per-recording: one torque offset per joint per training recording (sensor offsets that move from "
        "one recording day to the next), the inertial and friction parameters shared; not with --terms …,offset",
    )
    g.add_argument(
        "--calibrate-offsets",
        type=float,
        default=None,
        metavar="FRACTION",
        help="with --offsets per-recording: each validation recording's offsets are fitted on its first FRACTION "
        "(0 < FRACTION ≤ 0.5) with every other parameter fixed, and it is scored on the rest; without it a "
        "validation recording gets the training recordings' mean offsets",
    )
    p.add_argument(
        "--ripple-periods",
        default=None,
        metavar="R|JOINT=R,…|auto",
        help="position ripple (--terms ripple): ripple periods per joint revolution, one number or per joint "
        "(A1=160,A2=100), or auto (chosen by blocked cross-validation on the training recordings); default the "
        "drives' reduction ratio; saved with the model (docs/identification.md)",
    )
    p.add_argument(
        "--sigmoid-shape",
        default=None,
        metavar="PHI2,PHI3|JOINT=PHI2:PHI3,…|auto",
        help="sigmoid friction (--terms fsig): steepness φ2 [s/rad] > 0 and velocity offset φ3 [rad/s] of every "
        "joint, per joint (A1=40:0.01,A2=60:0), or auto (fitted per joint by a 2-D search around the linear "
        "fit); default 40,0; saved with the model (docs/identification.md)",
    )
    p.set_defaults(methods=None, terms=None, prior_weight=None)  # given or not (STAGE1_ONLY, STAGE2_ONLY)
    p.add_argument("--no-report", action="store_true", help="do not write report.md, report.html and the figures")
    p.add_argument(
        "--no-figures",
        action="store_true",
        help="write report.md and report.html without figures (faster: matplotlib is not loaded)",
    )
    p.add_argument(
        "--workers",
        type=positive_int,
        default=1,
        metavar="N",
        help="local processes fitting the methods in parallel (default 1: one after the other; worth it with "
        "several slow methods, e.g. the metaheuristics); the numbers do not depend on it",
    )


def _options(args, methods) -> dict:

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


def _model(args: argparse.Namespace):
    """The robot of the options, with the ripple terms' periods (--ripple-periods) and the sigmoid friction's
    shape (--sigmoid-shape) as its settings; each refused without its term."""
    _check_term_settings(args, terms_from_args(args, auto=True))
    model = robot_from_args(args)
    if args.sigmoid_shape is not None:
        from pinid.model.terms_sigmoid import shape_from_text  # the plug-in term, loaded on use

        model = model.with_setting("sigmoid", shape_from_text(args.sigmoid_shape))
    if args.ripple_periods is None:
        return model
    if args.ripple_periods.strip().lower() == "auto":  # chosen by cross-validation (identification.ripple_choice)
        return model.with_setting("ripple_periods", "auto")
    return model.with_setting("ripple_periods", periods_from_text(args.ripple_periods))


def _check_term_settings(args: argparse.Namespace, terms) -> None:
    """SpecError for a term's setting given without its term (it would be silently ignored): --ripple-periods
    without a ripple term, --sigmoid-shape without fsig (--terms auto chooses neither)."""
    names = [] if isinstance(terms, str) else terms.names
    given = f"--terms {args.terms}"
    if args.ripple_periods is not None and not any(n.startswith("ripple_") for n in names):
        raise SpecError(
            f"--ripple-periods {args.ripple_periods}: {given} has no ripple term, so it would be ignored; "
            "add ripple, ripple2 or ripple3 to --terms (e.g. --terms fc,fv,ripple) or leave --ripple-periods out"
        )
    if args.sigmoid_shape is not None and "fsig" not in names:
        raise SpecError(
            f"--sigmoid-shape {args.sigmoid_shape}: {given} has no fsig term, so it would be ignored; "
            "add fsig to --terms (e.g. --terms fc,fv,fsig) or leave --sigmoid-shape out"
        )


def _prior_weight(text: str) -> float | str:
    """``--prior-weight``: a number ≥ 0 or ``auto``."""
    return "auto" if text.strip().lower() == "auto" else nonnegative_float(text)


def _run_options(args: argparse.Namespace) -> dict:
    """identify()'s keywords read straight from the command line: the truth, the worker processes."""
    return {"truth": args.truth, "workers": args.workers}


def run(args: argparse.Namespace) -> int:
    # deferred: the report modules, ~8 ms that pinid --help would pay
    from pinid.identification.outputs import identification_text, write_identification

    out = Path(args.output)
    check_outputs(out / "identification.json")  # fail before the work (creates nothing)
    _check_stage(args)
    if args.stage == "wearer":
        return _run_wearer(args, out)
    args.methods = DEFAULT_METHODS if args.methods is None else args.methods
    args.terms = DEFAULT_TERMS if args.terms is None else args.terms
    methods = methods_from_args(args)
    model = _model(args)
    terms = terms_from_args(args, auto=True)

    def started() -> None:  # the inputs are read and checked: say what runs
        floating = (" on a floating base" + f" ({args.rows} rows)" * (args.rows != "all")) * (args.base == "floating")
        print(
            f"identifying {model.name}{floating} ({', '.join(model.joint_names)}) with {', '.join(methods)}; "
            f"terms {terms if isinstance(terms, str) else ', '.join(terms.names) or 'none'}",
            flush=True,
        )
        if not (args.no_report or args.no_figures):
            start_figure_workers()  # they load matplotlib while this process identifies

    study = _study(args, model, terms)
    options = options_from_args(args, _options(args, methods))
    ident = identify(study, methods, options=options, show_progress=None, started=started, **_run_options(args))
    print(identification_text(ident, verbose=args.verbose))  # with a floating base's calibration
    written = write_identification(
        ident, out, report=not args.no_report, figures=not args.no_figures, force_export=args.force_export
    )
    warn_if_unvalidated(bool(ident.validation_sources))  # after writing: a refused output is one line alone
    refused = [m for m in ident.results if out / f"identified_{m}.urdf" not in written]
    print(
        f"\nbest: {ident.best}"
        + (f"; no URDF for inconsistent result(s) {', '.join(refused)} (--force-export writes them)" if refused else "")
    )
    print(wrote_line(written, out))
    return 0


#: The one-line warning of an identification without validation recordings (issue 33).
UNVALIDATED = (
    "no validation recording (--validate, or a manifest's validation role): the best method is picked on its "
    "training error, which cannot show overfitting; validate on a recording of another trajectory"
)


def warn_if_unvalidated(validated: bool) -> None:
    """A DataWarning (one line on stderr: ``pinid identify: warning: …``) when nothing was validated."""
    if not validated:
        warnings.warn(UNVALIDATED, DataWarning, stacklevel=2)


def _check_stage(args: argparse.Namespace) -> None:
    """--stage and --exo go together, and each stage refuses the other's options (rather than ignore them)."""
    if (args.stage == "wearer") != (args.exo is not None):
        raise SpecError("--stage wearer and --exo MODEL_JSON go together (stage 2: the wearer, the exo fixed)")
    stage = "2 (--stage wearer)" if args.stage == "wearer" else "1 (--stage robot)"
    for dest, option in STAGE1_ONLY if args.stage == "wearer" else STAGE2_ONLY:
        value = getattr(args, dest, None)
        if value is not None and value is not False and value != []:
            raise SpecError(
                f"{option} does not apply to stage {stage}"
                + (
                    ": the exo is fixed to --exo (its terms, friction, drives) and only the wearer is fitted, "
                    "from torque recordings"
                    if args.stage == "wearer"
                    else ""
                )
            )
    if args.stage == "wearer" and args.base == "floating":
        raise SpecError("--stage wearer with --base floating is not available (docs/floating-base.md)")


def _study(args: argparse.Namespace, model, terms) -> Study:
    """The :class:`~pinid.identification.study.Study` the options describe (read in this order: an error names
    the first bad option)."""
    from pinid.identification.floating import FloatingOptions  # deferred: pinid --help does not load it

    floating = args.base == "floating"
    fields = dict(
        validate=args.validate or None,
        terms=terms,
        # a floating base's mapping spec has a [floating] table: base, IMU, wrench, plate, contact columns
        mapping=mapping_from_args(args),
        preprocess=preprocess_from_args(args),
        rest_velocity=rest_velocity_from_args(args.rest_velocity),
        payload=args.payload,
        payload_data=args.payload_data,
        stribeck_velocity=args.stribeck_velocity,
        stribeck_shape=args.stribeck_shape,
        offsets=args.offsets,
        calibrate_offsets=args.calibrate_offsets,
        **recording_options(args),
        **(
            {"floating": FloatingOptions(args.rows, args.base_weight, args.swing_rows, args.calibration)}
            if floating
            else {}
        ),
    )
    return study_from_args(args, model, fields)


def _run_wearer(args: argparse.Namespace, out: Path) -> int:
    """Stage 2: the wearer of ``--urdf`` identified with the exoskeleton fixed to ``--exo``."""
    from pinid.wearer.options import WearerOptions  # deferred: pinid --help does not load the wearer's stage 2
    from pinid.wearer.prior import MASS_RANGE
    from pinid.wearer.stage import identify_wearer_stage

    if not args.data or args.manifest or args.fit_joints or args.delay:
        raise SpecError("--stage wearer: expected --data FILE (--manifest, --fit-joints and --delay are for the robot)")
    stage = identify_wearer_stage(
        args.exo,
        robot_from_args(args),
        args.data,
        validate=args.validate or None,
        preprocess=preprocess_from_args(args),
        mapping=mapping_from_args(args),
        options=WearerOptions(
            passive=not args.no_passive,
            mass_range=MASS_RANGE if args.mass_range is None else args.mass_range,
            prior_weight="auto" if args.prior_weight is None else args.prior_weight,
            passive_exponents=args.passive_exponents,
            # every row unless asked: the documented stage 2 (docs/wearer.md)
            rest_velocity=None if args.rest_velocity is None else rest_velocity_from_args(args.rest_velocity),
        ),
    )
    print(stage.text())
    print(wrote_line(stage.write(out, report=not args.no_report, figures=not args.no_figures), out))
    return 0
