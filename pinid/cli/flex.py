"""``pinid flex``: flexible-joint models, twins and output-error identification (seed 003)."""

from __future__ import annotations

import argparse
import warnings
from dataclasses import replace

import numpy as np

from pinid.cli.common import seed_int
from pinid.errors import SpecError
from pinid.io import Artefacts, check_outputs, json_text
from pinid.optimizers import OPTIMIZERS

HELP = "flexible joints: simulate a twin, fit spring/damper/motor parameters by output error, rigid vs flexible"
DESCRIPTION = f"""\
Joints driven through belts, cables or series-elastic actuators (seed 003): a motor drives the link through
a nonlinear spring K1·Δ + K2·Δ³ and a damper C, with motor inertia Jm, damping Bm, friction fv, fc.
Everything is read from a TOML spec (URDF, drives, bounds of the free parameters, truth of the twin, its
input, fit settings): --spec takes a file or the name of a bundled spec (tracker_flex_spec, the default,
which documents every key: pinid/resources/excitation/tracker_flex_spec.toml); see docs/flexible.md.

actions:
  check    print the drives, the free parameters, the RK4 step, and which parameters the spec's
           input makes observable (sensitivity of the angles at the truth); writes nothing unless --json
  twin     simulate the spec's truth under the spec's input, add seeded noise, write a CSV recording
           (t, T_<joint>, q_<joint>, qm_<joint>) and its truth (<out>.json)
  fit      fit the free parameters to a recording (default: a twin made on the fly) with a metaheuristic
           ({", ".join(OPTIMIZERS)}) or least_squares; write a JSON result and optionally a figure
  compare  fit the flexible and the rigid model to the same recording (seed 003 Figs. 6-7); write a
           JSON result and optionally a figure of measured and simulated angles

examples:
  pinid flex check --spec tracker_flex_spec
  pinid flex twin --spec tracker_flex_spec -o tracker_twin.csv
  pinid flex fit --spec tracker_flex_spec --data tracker_twin.csv --method pso -o fit.json
  pinid flex fit --spec tracker_flex_spec --method least_squares --x0 fit.json -o polished.json
  pinid flex compare --spec tracker_flex_spec -o cmp.json --plot cmp.png
"""

DEFAULT_SPEC = "tracker_flex_spec"


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", metavar="ACTION", required=True)

    def common(q: argparse.ArgumentParser) -> None:
        q.add_argument(
            "--spec",
            default=None,
            help=f"flexible-joint spec: a TOML file or a bundled spec's name; default {DEFAULT_SPEC} (bundled)",
        )

    def data_opts(q: argparse.ArgumentParser) -> None:
        q.add_argument(
            "--data",
            default=None,
            metavar="CSV",
            help="recording (t, T_<joint> or V_<joint>, q_<joint>[, qm_<joint>]); default: a twin of the "
            "spec made on the fly with its [fit] noise and seed",
        )
        q.add_argument(
            "--noise", type=float, default=None, help="noise of the on-the-fly twin [rad] (default: the spec's)"
        )

    def fit_opts(q: argparse.ArgumentParser) -> None:  # no import here: `pinid --help` stays light
        q.add_argument(
            "--method",
            default=None,
            help=f"{', '.join(OPTIMIZERS)} (pinid.optimizers) or least_squares; default: the spec's [fit] method",
        )
        q.add_argument(
            "--cost",
            default=None,
            choices=("abs", "sq"),
            help="abs = seed 003 Eq. (15), Σ|e|; sq = Σe²; default: the spec's",
        )
        q.add_argument("--outputs", default=None, help="compared angles: link, or link,motor; default: the spec's")
        q.add_argument("--population", type=int, default=None, help="metaheuristic population (default: the spec's)")
        q.add_argument("--iterations", type=int, default=None, help="metaheuristic iterations (default: the spec's)")
        q.add_argument("--seed", type=seed_int, default=None, help="random seed (default: the spec's)")
        q.add_argument("--max-nfev", type=int, default=60, help="least_squares: residual evaluations (default 60)")

    c = sub.add_parser(
        "check",
        help="drives, free parameters, step and observability of a spec",
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    common(c)
    data_opts(c)
    c.add_argument("--json", metavar="FILE", help="also write the description as JSON")

    t = sub.add_parser("twin", help="simulate the spec's truth and write a recording")
    common(t)
    _output(t, "CSV", "recording to write (CSV or NPZ); the truth goes to CSV.json")
    t.add_argument("--noise", type=float, default=None, help="noise on every angle [rad] (default: the spec's)")
    t.add_argument("--seed", type=seed_int, default=None, help="noise seed (default: the spec's)")
    t.add_argument("--no-motor", action="store_true", help="do not record motor angles")
    # --force before or after the action (pinid flex --force twin): the action's own default is left out
    t.add_argument("--force", action="store_true", default=argparse.SUPPRESS, help="overwrite the output")

    f = sub.add_parser("fit", help="fit the free parameters by output error")
    common(f)
    data_opts(f)
    fit_opts(f)
    f.add_argument("--rigid", action="store_true", help="fit the rigid-joint model of the spec instead")
    f.add_argument(
        "--x0",
        default=None,
        metavar="middle|truth|JSON",
        help="start: least_squares' start point, or a member of the initial population (default: middle "
        "of the box for least_squares, none otherwise); a JSON result of an earlier fit",
    )
    _output(f, "JSON", "result to write")
    f.add_argument("--plot", default=None, metavar="PNG", help="also plot measured and simulated angles")
    f.add_argument("--force", action="store_true", default=argparse.SUPPRESS, help="overwrite outputs")

    m = sub.add_parser("compare", help="rigid vs flexible on one recording (seed 003 Figs. 6-7)")
    common(m)
    data_opts(m)
    fit_opts(m)
    m.add_argument(
        "--no-polish", action="store_true", help="do not refine each metaheuristic result with least_squares"
    )
    _output(m, "JSON", "result to write")
    m.add_argument("--plot", default=None, metavar="PNG", help="also plot measured and simulated angles")
    m.add_argument("--force", action="store_true", default=argparse.SUPPRESS, help="overwrite outputs")


# ---------------------------------------------------------------------------------------------- helpers
class _DeprecatedOut(argparse.Action):
    """``--out``: the old spelling of ``-o/--output`` (as every other command has it), kept for one release."""

    def __call__(self, parser, namespace, values, option_string=None):
        warnings.warn("pinid flex --out is deprecated, use -o/--output", DeprecationWarning, stacklevel=1)
        setattr(namespace, self.dest, values)


def _output(p: argparse.ArgumentParser, metavar: str, text: str) -> None:
    """-o/--output (required), with --out as a deprecated alias."""
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("-o", "--output", dest="out", metavar=metavar, help=text)
    g.add_argument("--out", dest="out", metavar=metavar, action=_DeprecatedOut, help="deprecated alias of -o/--output")


# pinid.flexible takes about 30 ms to import: the functions below import it when they run (deferred),
# so that pinid --help starts fast.


def _spec(args):
    from pinid.flexible.spec import load_flex_spec

    return load_flex_spec(DEFAULT_SPEC if args.spec is None else args.spec)


def _recording(args, spec, *, motor: bool = True):
    """--data, or a twin of the spec with --noise and --seed (default: the spec's [fit] noise and seed)."""
    from pinid.flexible.recording import FlexRecording
    from pinid.flexible.output_error import make_twin

    if getattr(args, "data", None):
        return FlexRecording.load(args.data)
    noise = spec.fit.noise if args.noise is None else args.noise
    if noise < 0:
        raise SpecError(f"--noise {noise:g}, expected ≥ 0 [rad]")
    seed = spec.fit.seed if getattr(args, "seed", None) is None else args.seed
    rec = make_twin(spec.model(), spec.input, noise=noise, rng=seed, motor=motor)
    rec.meta.update(spec=str(spec.source), seed=seed)
    return rec


def _fit_options(args, spec) -> tuple[str, dict, int]:
    from pinid.flexible.spec import methods

    method = args.method or spec.fit.method
    if method not in methods():
        raise SpecError(f"--method {method!r}, expected one of {', '.join(methods())}")
    population = spec.fit.population if args.population is None else args.population
    iterations = spec.fit.iterations if args.iterations is None else args.iterations
    for name, v in (("--population", population), ("--iterations", iterations)):
        if v < 1:
            raise SpecError(f"{name} {v}, expected a positive integer")
    seed = spec.fit.seed if args.seed is None else args.seed
    return method, {"population": population, "iterations": iterations}, seed


def _outputs(args, spec):
    from pinid.flexible.output_error import OUTPUTS  # deferred (see above)

    if args.outputs is None:
        return spec.fit.outputs
    out = tuple(o.strip() for o in args.outputs.split(",") if o.strip())
    if not out or any(o not in OUTPUTS for o in out):
        raise SpecError(f"--outputs {args.outputs!r}, expected link or link,motor")
    return out


def _x0(args, spec, problem):
    from pinid.flexible.result import OutputErrorResult

    if args.x0 is None:
        return None
    if args.x0 == "middle":
        return 0.5 * (problem.lower + problem.upper)
    if args.x0 == "truth":
        truth = problem.truth or {}
        missing = [n for n in problem.free if n not in truth]
        if missing:
            raise SpecError(f"--x0 truth: no truth for {', '.join(missing)} (spec [truth] or recording)")
        return np.array([truth[n] for n in problem.free])
    prev = OutputErrorResult.load(args.x0)
    vals = prev.values
    return np.array([vals.get(n, 0.5 * (lo + hi)) for n, lo, hi in zip(problem.free, problem.lower, problem.upper)])


# ---------------------------------------------------------------------------------------------- actions
def run(args: argparse.Namespace) -> int:
    return {"check": _check, "twin": _twin, "fit": _fit, "compare": _compare}[args.action](args)


def _check(args) -> int:
    from pinid.flexible.outputs import check_spec  # deferred (see above)

    if args.json:
        check_outputs(args.json)
    spec = _spec(args)
    text, description = check_spec(spec, _recording(args, spec))
    print(text)
    if args.json:
        arts = Artefacts()
        arts.add(args.json, json_text(description))
        arts.write()
        print(f"wrote {args.json}")
    return 0


def _twin(args) -> int:
    from pinid.flexible.outputs import twin_paths, write_twin  # deferred (see above)

    check_outputs(*twin_paths(args.out))  # the recording and its truth, checked before the work
    spec = _spec(args)
    rec = _recording(args, spec, motor=not args.no_motor)
    write_twin(rec, args.out)
    print(
        f"wrote {args.out} ({rec.n} samples at {1 / rec.dt:g} Hz, noise {rec.meta['noise']:g} rad, seed "
        f"{rec.meta['seed']}) and {args.out}.json (truth)"
    )
    return 0


def _fit(args) -> int:
    # deferred (see above)
    from pinid.flexible.output_error import LEAST_SQUARES, fit_output_error, problem_from_spec
    from pinid.flexible.outputs import result_text, write_fit

    check_outputs(args.out, *([args.plot] if args.plot else []))  # before the work, creating nothing
    spec = _spec(args)
    method, options, seed = _fit_options(args, spec)
    rec = _recording(args, spec)
    prob = problem_from_spec(spec, rec, rigid=args.rigid, cost=args.cost, outputs=_outputs(args, spec))
    x0 = _x0(args, spec, prob)
    print(f"fitting {prob.d} parameters of the {prob.label} model to {rec.source} ({rec.n} samples) with {method}")
    res = fit_output_error(
        prob,
        method,
        rng=seed,
        x0=x0,
        options=None if method == LEAST_SQUARES else options,
        f_scale=spec.fit.f_scale,
        max_nfev=args.max_nfev,
    )
    res.extra.update(recording=rec.source, spec=spec.source)
    print(result_text(res))
    print("wrote " + " and ".join(map(str, write_fit(res, args.out, problem=prob, plot=args.plot))))
    return 0


def _compare(args) -> int:
    # deferred (see above)
    from pinid.flexible.output_error import compare_rigid_flexible
    from pinid.flexible.outputs import result_text, write_fit_comparison

    check_outputs(args.out, *([args.plot] if args.plot else []))  # before the work, creating nothing
    spec = _spec(args)
    method, options, seed = _fit_options(args, spec)
    if args.cost or args.outputs:
        spec = replace(spec, fit=replace(spec.fit, cost=args.cost or spec.fit.cost, outputs=_outputs(args, spec)))
    rec = _recording(args, spec)
    out = compare_rigid_flexible(spec, rec, method=method, options=options, rng=seed, polish=not args.no_polish)
    for label in ("flexible", "rigid"):
        print(f"{label} model ({out[label].method}):")
        print(result_text(out[label]))
    f, r = out["flexible"], out["rigid"]
    print(
        "RMS angle error [mrad]: "
        + "; ".join(
            f"{j}: flexible {1e3 * f.metrics[j]['rms']:.4g}, rigid {1e3 * r.metrics[j]['rms']:.4g}" for j in f.metrics
        )
    )
    written = write_fit_comparison(out, args.out, spec=spec, recording=rec, plot=args.plot)
    print("wrote " + " and ".join(map(str, written)))
    return 0
