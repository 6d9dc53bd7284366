"""``pinid excite``: design a Fourier excitation trajectory with the lowest condition number within limits."""

from __future__ import annotations

import argparse
import math

from pinid.cli.common import (
    add_robot_arguments,
    names_text,
    add_terms_argument,
    parse_option,
    positive_float,
    positive_int,
    robot_from_args,
    seed_int,
    terms_from_args,
)
from pinid.errors import SolverError, SpecError
from pinid.io import check_outputs
from pinid.optimizers import OPTIMIZERS

HELP = "design an excitation trajectory (Fourier series) that conditions the identification best"
DESCRIPTION = """\
Designs a periodic excitation — a finite Fourier series per joint (seed 001 Eq. (19)) — that minimises
the condition number of the base regressor (friction columns included, seed 001 Eq. (20)), or
maximises log det(WᵀW) with --criterion logdet, while the position, velocity and acceleration limits
(and optionally torque limits) hold at every instant of the period.

Reads: the URDF (position and velocity limits) and a spec file (.toml or .json) for what a URDF cannot
hold — acceleration limits, margins, offsets, harmonics, base frequency.  Without --spec, exo_leg uses
excitation/exo_leg_table2.toml (seed 001 Table 2); other robots use their URDF limits, 5 rad/s² and
offsets at the centres of the ranges.  Options given here override the spec.
Writes: the trajectory and the design report as JSON (-o), optionally samples as CSV for the rig's
controller (--csv: t, q_<joint>, dq_<joint>, ddq_<joint>) and a figure (--plot).
With --evaluate TRAJ it designs nothing: it reports the condition number and limit usage of TRAJ.

examples:
  pinid excite --urdf urdf/exo_leg.urdf -o excitation/exo_leg.json --csv exo_leg.csv --plot exo_leg.png
  pinid excite --urdf exo_leg --optimizer ewoa --population 100 --iterations 200 --seed 1
  pinid excite --urdf exo_leg --evaluate seed001_table3
  pinid excite --urdf panda --harmonics 5 -o panda_excitation.json
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_robot_arguments(p, base=True)
    p.add_argument(
        "--collision-margin",
        type=float,
        default=0.02,
        metavar="M",
        help="--base floating: smallest distance [m] kept between the legs' collision shapes (URDF <collision>; "
        "pairs of bodies on different branches of the base); a design closer than that is shrunk toward q0 "
        "(--evaluate: checked and reported only); default 0.02",
    )
    add_terms_argument(p)
    p.set_defaults(terms=None)
    g = p.add_argument_group("limits and trajectory (override the spec)")
    g.add_argument(
        "--spec",
        metavar="FILE",
        help="excitation spec (.toml or .json); default: the bundled one for "
        "exo_leg, else URDF limits and pinid's defaults",
    )
    g.add_argument("--harmonics", type=positive_int, help="number of harmonics N (spec default 4)")
    g.add_argument(
        "--base-frequency", type=positive_float, metavar="W", help="base frequency ωf [rad/s] (default 0.2π)"
    )
    g.add_argument("--samples", type=positive_int, help="samples per period of the regressor (default 200)")
    rest = g.add_mutually_exclusive_group()
    rest.add_argument(
        "--rest-start",
        dest="rest_start",
        action="store_true",
        default=None,
        help="start and end at rest: dq = ddq = 0 at t = 0 (the default)",
    )
    rest.add_argument("--no-rest-start", dest="rest_start", action="store_false", help="do not force a start at rest")
    g.add_argument("--optimize-offsets", action="store_true", default=None, help="also optimise the offsets q0")
    g.add_argument("--criterion", choices=["cond", "logdet"], help="cond (default) or logdet (D-optimal)")
    g.add_argument("--margin", type=float, help="fraction of every limit kept in reserve (default 0)")
    g.add_argument(
        "--comfort",
        nargs="?",
        const="",
        default=None,
        metavar="FILE",
        help="design within a wearer's comfort limits (TOML: hip, knee, ankle range [deg], speed, "
        "acceleration) intersected with the URDF's; without FILE the shipped defaults (docs/wearer.md)",
    )
    g.add_argument(
        "--torque-limits",
        action="store_true",
        help="also keep |torque| (nominal URDF parameters) within the URDF's effort limits",
    )
    o = p.add_argument_group("optimiser")
    o.add_argument(
        "--optimizer", default=None, help=f"slsqp (gradient-based multistart, default), {names_text(OPTIMIZERS)}"
    )
    o.add_argument(
        "--seed", type=seed_int, default=None, help="random seed (default 0): the same seed gives the same result"
    )
    o.add_argument("--population", type=positive_int, help=f"population of {'/'.join(OPTIMIZERS)} (default 100)")
    o.add_argument("--iterations", type=positive_int, help=f"iterations of {'/'.join(OPTIMIZERS)} (default 200)")
    o.add_argument("--starts", type=positive_int, help="local searches of slsqp (default 128 up to 4 joints, 12 above)")
    o.add_argument(
        "--option",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="any other optimiser setting, e.g. --option w_min=0.3 (VALUE in JSON: numbers, true/false, null, "
        "[lists], or plain text); repeatable",
    )
    out = p.add_argument_group("output")
    out.add_argument(
        "-o",
        "--output",
        metavar="FILE",
        help="trajectory and report as JSON (default <robot>_excitation.json; with --evaluate, only if given)",
    )
    out.add_argument("--csv", metavar="FILE", help="also write samples as CSV (t, q_*, dq_*, ddq_*)")
    out.add_argument("--rate", type=float, default=1000.0, help="CSV sample rate [Hz] (default 1000)")
    out.add_argument("--periods", type=float, default=1.0, help="CSV duration in periods (default 1)")
    out.add_argument("--plot", metavar="FILE", help="also draw q, dq, ddq with the limit bands (.png, .pdf, .svg)")
    out.add_argument("--evaluate", metavar="TRAJ", help="evaluate this trajectory JSON instead of designing one")
    out.add_argument("--quiet", action="store_true", help="print only the condition number and the files written")


def _options(args: argparse.Namespace) -> dict:
    opts: dict = {}
    name = args.optimizer.lower()
    if name == "slsqp":
        if args.population is not None or args.iterations is not None:
            raise SpecError(
                f"--population and --iterations apply to {names_text(OPTIMIZERS, 'and')}, not to slsqp (use --starts)"
            )
        if args.starts is not None:
            opts["starts"] = args.starts
    else:
        if args.starts is not None:
            raise SpecError(f"--starts applies to slsqp, not to {name} (use --population and --iterations)")
        if args.population is not None:
            opts["population"] = args.population
        if args.iterations is not None:
            opts["iterations"] = args.iterations
    for item in args.option:
        key, value = parse_option(item, "KEY=VALUE, e.g. --option w_min=0.3")
        opts[key] = value
    return opts


# pinid.excitation.design takes about 17 ms to import: the functions below import it when they run
# (deferred), so that pinid --help starts fast.


def _check(args: argparse.Namespace) -> dict:
    """Check the options that need no robot; returns the optimiser's settings (:func:`_options`)."""
    from pinid.excitation.design import design_optimizers  # deferred (see above)

    if args.evaluate:  # it designs nothing: an optimiser's option would silently do nothing
        given = [
            flag
            for flag, v in (
                ("--optimizer", args.optimizer),
                ("--seed", args.seed),
                ("--population", args.population),
                ("--iterations", args.iterations),
                ("--starts", args.starts),
                ("--option", args.option or None),
            )
            if v is not None
        ]
        if given:
            raise SpecError(
                f"{', '.join(given)}: no effect with --evaluate (it designs nothing, it evaluates "
                f"{args.evaluate}); expected none of the optimiser's options"
            )
    args.optimizer = args.optimizer or "slsqp"
    args.seed = 0 if args.seed is None else args.seed
    if args.optimizer.lower() not in design_optimizers():
        raise SpecError(f"--optimizer {args.optimizer!r}: expected one of {', '.join(design_optimizers())}")
    if not (math.isfinite(args.rate) and args.rate > 0):
        raise SpecError(f"--rate {args.rate}: expected a sample rate > 0 [Hz]")
    if not (math.isfinite(args.periods) and args.periods > 0):
        raise SpecError(f"--periods {args.periods}: expected a number of periods > 0")
    return _options(args)


def _spec(args: argparse.Namespace, model):
    """The ExcitationSpec of --spec and the spec options, within --comfort and --torque-limits."""
    from pinid.excitation.spec import spec_for  # deferred (see above)

    terms = None if args.terms is None else terms_from_args(args)
    spec = spec_for(
        model,
        args.spec,
        harmonics=args.harmonics,
        base_frequency=args.base_frequency,
        samples=args.samples,
        rest_start=args.rest_start,
        optimize_offsets=args.optimize_offsets,
        criterion=args.criterion,
        margin=args.margin,
        terms=terms,
    )
    if args.comfort is not None:
        from pinid.wearer.comfort import within_comfort  # deferred: pinid --help does not load it

        spec = within_comfort(spec, model, args.comfort or None)
    if args.torque_limits:
        from pinid.excitation.clamp import within_effort_limits  # deferred (see above)

        spec = within_effort_limits(spec, model)
    return spec


def _clear_of_collision(args: argparse.Namespace, model, spec, traj, report: dict):
    """--base floating: the legs kept --collision-margin apart (a design shrunk toward q0 if needed; a trajectory
    given to --evaluate is only checked)."""
    from pinid.excitation.collision import check_self_collision, shrink_to_clear  # deferred (see above)
    from pinid.excitation.outputs import evaluate_excitation  # deferred (see above)

    if args.evaluate:
        clear, factor = traj, 1.0
        check = check_self_collision(model, traj, margin=args.collision_margin)
    else:
        clear, factor, check = shrink_to_clear(model, traj, margin=args.collision_margin)
    if factor < 1.0:
        clear, ev = evaluate_excitation(model, clear, spec)
        report = clear.to_dict()
        print(
            f"the design brings the legs closer than the margin: amplitudes shrunk by {factor:.3f} toward q0, "
            f"condition number now {ev['condition_number']:.4g}"
        )
    print(check.text())
    report["self_collision"] = {
        "distance": check.distance,
        "pair": list(check.pair),
        "time": check.time,
        "margin": check.margin,
        "pairs": check.pairs,
        "shrink": factor,
    }
    return clear, report


def run(args: argparse.Namespace) -> int:
    from pinid.excitation.outputs import excitation_paths, spec_text, write_excitation  # deferred (see above)

    opts = _check(args)
    model = robot_from_args(args)
    floating = model.base == "floating"
    if floating:  # designed on the joints with the base held still (the base's own rows come from the gait)
        model = model.fixed_base
    output = args.output
    if output is None and not args.evaluate:
        output = f"{model.name}_excitation.json"
    check_outputs(*excitation_paths(json=output, plot=args.plot, csv=args.csv))  # before the work, creating nothing
    spec = _spec(args, model)
    say = (lambda *a: None) if args.quiet else print
    say(spec_text(model, spec))
    traj, report = _evaluate(args, model, spec) if args.evaluate else _design(args, model, spec, opts, say)
    if floating:
        traj, report = _clear_of_collision(args, model, spec, traj, report)
    write_excitation(
        traj, spec, report, json=output, plot=args.plot, csv=args.csv, rate=args.rate, periods=args.periods
    )
    if args.plot:
        say(f"wrote {args.plot}")
    if args.csv:
        say(f"wrote {args.csv} ({args.rate:g} Hz, {args.periods:g} period{'s' if args.periods != 1 else ''})")
    if output:
        print(f"wrote {output}")
    return 0


def _evaluate(args: argparse.Namespace, model, spec) -> tuple:
    """--evaluate TRAJ: ``(trajectory, report)`` of the given trajectory within ``spec``, its evaluation printed."""
    from pinid.excitation.outputs import evaluate_excitation, evaluation_text  # deferred (see above)
    from pinid.excitation.trajectory import FourierTrajectory

    given = FourierTrajectory.load(args.evaluate).for_joints(model.joint_names, model.name)
    traj, ev = evaluate_excitation(model, given, spec)
    print(evaluation_text(args.evaluate, spec, ev, traj.q0, usage=not args.quiet))
    return traj, traj.to_dict()


def _design(args: argparse.Namespace, model, spec, opts: dict, say) -> tuple:
    """``(trajectory, report)`` of a new design with --optimizer and its settings ``opts``, printed."""
    from pinid.excitation.design import design_excitation  # deferred (see above)
    from pinid.excitation.outputs import design_text

    name = args.optimizer.lower()
    say(f"optimizer {name}" + (f" {opts}" if opts else "") + f", seed {args.seed}")
    result = design_excitation(model, spec, optimizer=name, options=opts, seed=args.seed)
    if not result.feasible:
        raise SolverError(f"{name} found no trajectory within the limits (torque limits too tight?); nothing written")
    print(design_text(result, spec, usage=not args.quiet))
    return result.trajectory, result.to_dict()
