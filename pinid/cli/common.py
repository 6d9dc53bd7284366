"""Subcommands of the ``pinid`` command, one module each (see :mod:`pinid.cli.main`)."""

from __future__ import annotations

import argparse
import json
import math
import textwrap
from pathlib import Path

from pinid.data.mapping import MappingSpec
from pinid.errors import SpecError
from pinid.estimators import ESTIMATORS
from pinid.identification.run import parse_methods
from pinid.model.bundled import EXAMPLE_ROBOTS
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.model.terms import TERM_GROUPS, TERMS
from pinid.resources import bundled_robots


def names_text(names, conjunction: str = "or") -> str:
    """Names as prose for help texts and messages: ``"ols, wls or sdp"``."""
    names = list(names)
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} {conjunction} {names[-1]}"


def add_robot_arguments(p: argparse.ArgumentParser, *, default: str | None = "exo_leg", base: bool = False) -> None:
    """The options every command uses to choose a robot: --urdf, --joints, --lock (and --base when ``base``)."""
    p.add_argument(
        "--urdf",
        default=default,
        required=default is None,
        help=f"URDF file, bundled robot ({', '.join(bundled_robots())}) or example-robot-data name "
        f"({', '.join(EXAMPLE_ROBOTS)}){'' if default is None else f'; default {default}'}",
    )
    p.add_argument("--joints", default=None, help="comma-separated active joints (default: all movable, unlocked)")
    p.add_argument(
        "--lock",
        action="append",
        default=[],
        metavar="JOINT=VALUE",
        help="hold a joint fixed at VALUE [rad or m]; repeatable",
    )
    p.add_argument(
        "--drives",
        default=None,
        metavar="FILE",
        help="drives TOML: [transmission] joints, motors, matrix (q_motor = matrix·q_joint) and "
        "optional [motors.NAME] fc, fv, armature, offset; replaces the URDF's <transmission> "
        "(see docs/drives.md)",
    )
    p.add_argument(
        "--repair-inertia",
        action="store_true",
        help="load a URDF whose inertias are not physical (negative principal moment, triangle inequality "
        "broken), each replaced by the nearest physical one with a warning (docs/robots.md); refused without it",
    )
    if base:
        p.add_argument(
            "--base",
            choices=("fixed", "floating"),
            default="fixed",
            help="fixed: the URDF's root link bolted to the world (default); floating: on a free flyer, "
            "with 6 base rows and contact wrenches (docs/floating-base.md)",
        )


def _term_list(names: list[str]) -> str:
    """``fc (Coulomb friction), fv (viscous friction)``: the terms with their labels (a motor term's without
    its leading "motor") and notes."""
    texts = [TERMS[n].label.removeprefix("motor ") + (f"; {TERMS[n].note}" if TERMS[n].note else "") for n in names]
    return ", ".join(f"{n} ({t})" for n, t in zip(names, texts))


def terms_help() -> str:
    """The --terms help, generated from the term registry (every registered term and plug-in, with its label,
    and the groups of :data:`pinid.model.terms.TERM_GROUPS`)."""
    TERMS.load_all()  # the plug-ins' labels (another package's terms too)
    grouped = {n for members in TERM_GROUPS.values() for n in members}
    joint = [n for n in TERMS if n not in grouped and TERMS[n].space == "joint"]
    motor = [n for n in TERMS if n not in grouped and TERMS[n].space == "motor"]
    groups = ", ".join(f"{g} ({TERMS[m[0]].label.split(',')[0]}: {', '.join(m)})" for g, m in TERM_GROUPS.items())
    return (
        f"terms in the model, comma-separated: joint side {_term_list(joint)}; motor side (needs drives: URDF "
        f"<transmission> or --drives) {_term_list(motor)}; groups: {groups}; 'none' for none; 'auto' (identify): "
        "chosen on the training recordings by forward selection, from fc,fv (with drives also motor_fc,motor_fv,"
        "motor_armature) and any terms added after it (auto,motor_offset); default fc,fv (identify: and offset when it "
        "wins on held-out blocks of the training recordings) (docs/identification.md, docs/drives.md)"
    )


def add_terms_argument(p: argparse.ArgumentParser) -> None:
    """The --terms option: which joint terms enter the model."""
    p.add_argument("--terms", default="fc,fv", help=terms_help())


def add_stribeck_arguments(p: argparse.ArgumentParser) -> None:
    """--stribeck-velocity and --stribeck-shape: the shape of the Stribeck terms (fs, motor_fs)."""
    g = p.add_argument_group("Stribeck friction (--terms fs, motor_fs; docs/drives.md, Stribeck friction)")
    g.add_argument(
        "--stribeck-velocity",
        default=None,
        metavar="V|auto",
        help="Stribeck velocity [rad/s in the term's space, > 0] of every Stribeck term, 'auto' (fitted "
        "by a 1-D search) or per term, e.g. fs=0.05,motor_fs=auto; default 0.1",
    )
    g.add_argument(
        "--stribeck-shape",
        default=None,
        metavar="D",
        help="Stribeck shape exponent (> 0; 2 Gaussian, 1 exponential), 'auto' (fitted with the velocity) "
        "or per term fs=2,motor_fs=1; default 2",
    )


def robot_from_args(args: argparse.Namespace, urdf: str | None = None):
    """Load the RobotModel the robot options describe (those :func:`add_robot_arguments` adds, or some of
    them); ``urdf``: the robot when an option other than --urdf names it (pinid track's --urdf-true)."""
    locked = {}
    for item in getattr(args, "lock", []):
        name, sep, value = item.partition("=")
        try:
            if not sep:
                raise ValueError
            locked[name.strip()] = float(value)
        except ValueError:
            raise SpecError(f"--lock {item!r}: expected JOINT=VALUE with a number, e.g. --lock knee=-0.5") from None
    joints = [j.strip() for j in args.joints.split(",") if j.strip()] if getattr(args, "joints", None) else None
    robot = RobotModel.from_urdf(
        args.urdf if urdf is None else urdf,
        joints=joints,
        locked=locked,
        repair_inertia=getattr(args, "repair_inertia", False),
        base=getattr(args, "base", "fixed"),
        drives=getattr(args, "drives", None) or None,
    )
    return robot


def terms_from_args(args: argparse.Namespace, *, auto: bool = False) -> TermSelection | str:
    """The TermSelection the --terms option describes (``"auto"``, ``"auto,motor_fc,…"`` and ``"default"`` as
    they are where ``auto`` allows it: identify chooses them on the training recordings)."""
    from pinid.identification.term_choice import is_default, parse_auto  # loaded on use

    try:
        if auto and (is_default(args.terms) or parse_auto(args.terms) is not None):
            return str(args.terms).strip().lower()
        if is_default(args.terms):
            return TermSelection()
        return TermSelection.from_names(args.terms)
    except ValueError as exc:
        raise SpecError(f"--terms: {exc}") from None


def add_mapping_arguments(p: argparse.ArgumentParser) -> None:
    """--mapping and --allow-outside-paths: how to read recordings not in pinid's dataset format."""
    p.add_argument("--mapping", default=None, metavar="SPEC", help="TOML mapping of the recordings' columns to joints")
    p.add_argument(
        "--allow-outside-paths",
        action="store_true",
        help="let the mapping spec's [sources.*] paths leave the recording's folder (docs/checks.md)",
    )


def mapping_from_args(args: argparse.Namespace):
    """The mapping spec of --mapping (None without it), with the --allow-outside-paths choice: a
    :class:`MappingSpec` (with ``--base floating``, its [floating] table maps the floating columns)."""
    if args.mapping is None:
        return None
    return MappingSpec.load(args.mapping, allow_outside_paths=args.allow_outside_paths)


def add_recording_arguments(p: argparse.ArgumentParser) -> None:
    """--data, --validate, --manifest, --fit-joints, --delay: the recordings of the commands that identify
    (identify, compare)."""
    p.add_argument(
        "--data",
        action="append",
        default=None,
        metavar="FILE",
        help="training recording (CSV); repeat for several (or --manifest)",
    )
    p.add_argument(
        "--validate",
        action="append",
        default=[],
        metavar="FILE",
        help="validation recording (a different trajectory); repeatable",
    )
    p.add_argument(
        "--manifest",
        default=None,
        metavar="TOML",
        help="dataset manifest instead of --data/--validate: recordings each with its own mapping spec, "
        "time or row range and role (train, validate, payload); see docs/data.md",
    )
    p.add_argument(
        "--fit-joints",
        default=None,
        metavar="J1,J2",
        help="only these joints' torque rows enter the fit (the others still move, are in the model and "
        "are predicted and validated); default all",
    )
    p.add_argument(
        "--delay",
        default=None,
        metavar="tau=SECONDS|auto|auto-per-joint",
        help="seconds by which the torque channels lag the positions (tau=0.04, per joint "
        "tau.knee=0.04), or auto: one delay estimated on the training recordings by a 1-D search in ±0.2 s, "
        "or auto-per-joint: one per torque channel (docs/data.md); applied to every recording",
    )


def recording_options(args: argparse.Namespace) -> dict:
    """The fields of the Study (identify, compare) that --manifest, --fit-joints and --delay describe."""
    if args.manifest is not None and (args.data or args.validate or getattr(args, "mapping", None)):
        raise SpecError(
            f"--manifest {args.manifest} lists the recordings and their mapping specs; "
            "expected it without --data/--validate/--mapping"
        )
    if args.manifest is None and not args.data:
        raise SpecError("no training recording: expected --data FILE (repeatable) or --manifest TOML")
    return {"fit_joints": args.fit_joints, "delay": args.delay, "manifest": args.manifest}


def study_from_args(args: argparse.Namespace, model: RobotModel, fields: dict):
    """The :class:`~pinid.identification.study.Study` of identify and compare: ``model`` and ``fields`` (the
    study's fields the options describe, with :func:`recording_options`'s) with ``--data``, or the recordings
    of ``--manifest`` (:meth:`~pinid.identification.study.Study.from_manifest`)."""
    from pinid.identification.study import Study  # deferred: pinid --help does not load it

    if not isinstance(args, argparse.Namespace):
        raise SpecError(f"args: got {type(args).__name__}, expected an argparse.Namespace")
    if not isinstance(model, RobotModel):
        raise SpecError(f"model: got {type(model).__name__}, expected a RobotModel")
    if not isinstance(fields, dict):
        raise SpecError(f"fields: got {type(fields).__name__}, expected a dict of the study's fields")
    fields = dict(fields)
    manifest = fields.pop("manifest", None)
    if manifest is not None:
        return Study.from_manifest(manifest, model, **fields)
    return Study(model, args.data, **fields)


def add_preprocessing_arguments(p: argparse.ArgumentParser) -> None:
    """The preprocessing options of the commands that read recordings (identify, compare)."""
    g = p.add_argument_group("preprocessing (defaults chosen from the sample rate)")
    g.add_argument(
        "--preprocess",
        choices=("auto", "always", "never"),
        default="auto",
        help="auto: only recordings without dq/ddq (default); always; never",
    )
    g.add_argument(
        "--preset",
        default=None,
        help="preprocessing preset: zha2019 (Zha et al. 2019: 1 kHz, 10 Hz) or shi2024 (Shi et al. 2024: 5 Hz); "
        "the old names seed000, seed001 still work (deprecated)",
    )
    g.add_argument(
        "--cutoff",
        type=cutoff_value,
        default=None,
        metavar="HZ",
        help="low-pass cut-off [Hz], or auto: chosen by blocked cross-validation on the training recordings "
        "(identify and compare; costs about one OLS identification per candidate)",
    )
    g.add_argument("--order", type=int, default=None, help="filter order (default 4)")
    g.add_argument("--differentiation", default=None, help="differentiation method (default savgol)")
    g.add_argument(
        "--no-measured-velocity",
        action="store_true",
        help="differentiate q even when the recording has measured velocities",
    )
    g.add_argument("--trim", type=float, default=None, metavar="SECONDS", help="seconds trimmed at each end")
    g.add_argument("--decimate", type=int, default=None, metavar="N", help="keep every N-th sample after filtering")
    g.add_argument(
        "--rest-velocity",
        default=None,  # auto; None tells that it was not given (stage 2 keeps every row unless asked)
        metavar="V",
        help="rows with |dq| below V [rad/s] are left out (Coulomb friction); a number, one per joint "
        "(comma-separated), 0 to keep all, or auto (default: max(2%% of the joint's peak speed, "
        "3 × its velocity noise))",
    )


def cutoff_value(text: str) -> float | str:
    """--cutoff's value: a number [Hz] or "auto"."""
    if text.strip().lower() == "auto":
        return "auto"
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected a frequency [Hz] or auto") from None


def preprocess_from_args(args: argparse.Namespace) -> dict | bool | None:
    """The ``preprocess`` argument of :func:`pinid.identify` the preprocessing options describe."""
    opts = {}
    for key in ("preset", "cutoff", "order", "differentiation", "trim", "decimate"):
        value = getattr(args, key)
        if value is not None:
            opts[key] = value
    if args.no_measured_velocity:
        opts["use_measured_velocity"] = False
    if args.preprocess == "never":
        if opts:
            raise SpecError("--preprocess never contradicts the preprocessing options given")
        return False
    if args.preprocess == "always" or opts:
        return opts
    return None


def rest_velocity_from_args(text: str | None):
    """The ``rest_velocity`` of :func:`pinid.identify` from the --rest-velocity option's text ("auto" when
    it was not given)."""
    if text is None or text.strip().lower() == "auto":
        return "auto"
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise SpecError(
            f"--rest-velocity {text!r}: expected auto, a number or comma-separated numbers [rad/s]"
        ) from None
    if not values:
        raise SpecError(f"--rest-velocity {text!r}: expected auto, a number or comma-separated numbers [rad/s]")
    return values[0] if len(values) == 1 else values


def add_method_arguments(p: argparse.ArgumentParser, default: str) -> None:
    """--methods (names of the estimator registry) and the generic, repeatable --option METHOD.KEY=VALUE."""
    p.add_argument(
        "--methods",
        default=default,
        help=f"comma-separated methods of the estimator registry: {', '.join(ESTIMATORS)}, or all; default {default}",
    )
    p.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="METHOD.KEY=VALUE",
        help="a setting of one method, e.g. sdp.regularization=0.01 or pso.population=50 (VALUE in JSON: "
        "numbers, true/false, null, [lists], or plain text); repeatable; every method's settings: docs/identification.md#estimators",
    )


def estimators_text(indent: int = 2) -> str:
    """Every method of the estimator registry with its one-line description, one per line, for the help."""
    width = max(len(name) for name in ESTIMATORS) + 2
    return "\n".join(f"{' ' * indent}{name:<{width}}{cls.description}" for name, cls in ESTIMATORS.items())


def methods_from_args(args: argparse.Namespace) -> list[str]:
    """The --methods list (:func:`pinid.identification.run.parse_methods`; SpecError naming --methods)."""
    try:
        return parse_methods(args.methods)
    except SpecError as exc:
        raise SpecError(f"--methods: {exc}") from None


def parse_option(item: str, expected: str) -> tuple[str, object]:
    """``(KEY, VALUE)`` of one ``--option KEY=VALUE`` (every command's --option): VALUE read as JSON
    (numbers, true/false, null, [lists]), ``none`` as null, anything else as plain text.  SpecError
    "expected ``expected``" (the form and an example) without "=" or without KEY."""
    lhs, sep, text = item.partition("=")
    if not sep or not lhs.strip():
        raise SpecError(f"--option {item!r}: expected {expected}")
    try:
        value = json.loads(text)
    except ValueError:
        value = None if text.strip().lower() == "none" else text
    return lhs.strip(), value


def options_from_args(args: argparse.Namespace, options: dict | None = None) -> dict:
    """Per-method settings from --option METHOD.KEY=VALUE, on top of ``options`` (the per-method flags)."""
    expected = "METHOD.KEY=VALUE, e.g. sdp.regularization=0.01"
    out = {m: dict(v) for m, v in (options or {}).items()}
    for item in args.option:
        lhs, value = parse_option(item, expected)
        method, dot, key = lhs.partition(".")
        if not dot or not method or not key:
            raise SpecError(f"--option {item!r}: expected {expected}")
        out.setdefault(method.strip().lower(), {})[key.strip()] = value
    return out


def _number(kind, test, expected):
    """An argparse ``type=`` function: parse with ``kind``, refuse values failing ``test`` (one-line error)."""

    def parse(text: str):
        try:
            value = kind(text)
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(f"{text!r}: expected {expected}") from None
        if not test(value):
            raise argparse.ArgumentTypeError(f"{text!r}: expected {expected}")
        return value

    parse.__name__ = expected
    return parse


#: argparse ``type=`` functions for numbers: they reject what no run can use, before any work.
seed_int = _number(int, lambda v: 0 <= v < 2**32, "a seed 0 ≤ n < 2³²")
positive_int = _number(int, lambda v: v > 0, "an integer > 0")
positive_float = _number(float, lambda v: math.isfinite(v) and v > 0, "a finite number > 0")
nonnegative_float = _number(float, lambda v: math.isfinite(v) and v >= 0, "a finite number ≥ 0")


def wrote_line(paths, folder) -> str:
    """``wrote N files to FOLDER/: a, b, …`` wrapped to 120 columns (continuation lines indented)."""
    names = ", ".join(Path(p).name for p in paths)
    return "\n".join(
        textwrap.wrap(
            f"wrote {len(paths)} files to {folder}/: {names}",
            120,
            subsequent_indent="  ",
            break_on_hyphens=False,
            break_long_words=False,
        )
    )


def add_floating_arguments(p: argparse.ArgumentParser) -> None:
    """The floating-base fitting options of identify and compare: --rows, --base-weight, --swing-rows."""
    g = p.add_argument_group("floating base (--base floating; docs/floating-base.md)")
    g.add_argument(
        "--rows",
        choices=("all", "base", "joints"),
        default="all",
        help="rows to fit: all (base rows + joint rows, default), base (the 6 base rows: contact wrenches and "
        "motion, no joint torque needed), joints (joint torques with the wrenches' Jᵀf on the right)",
    )
    g.add_argument(
        "--base-weight", type=float, default=1.0, help="weight of every base row (joint rows weigh 1); default 1"
    )
    g.add_argument(
        "--calibration",
        default="auto",
        help="sensor calibration (docs/floating-base.md): auto (default: the terms chosen by blocked "
        "cross-validation on the training recordings), none, or some of offsets,tilt (F/T sensor offsets held by "
        "the swing phases; gravity's direction in the motion-capture world)",
    )
    g.add_argument(
        "--swing-rows",
        action="store_true",
        help="accept contact_<link> phases without a wrench (a leg without force sensing): the rows that "
        "foot's unknown wrench enters (base rows, its leg's joints) are left out while it is in contact",
    )
