"""``pinid flex``: flexible-joint models, twins and output-error identification (seed 003)."""

from __future__ import annotations

import argparse

from pinid.cli.common import seed_int

import numpy as np

HELP = "flexible joints: simulate a twin, fit spring/damper/motor parameters by output error, rigid vs flexible"
DESCRIPTION = """\
Joints driven through belts, cables or series-elastic actuators (seed 003): a motor drives the link through
a nonlinear spring K1·Δ + K2·Δ³ and a damper C, with motor inertia Jm, damping Bm, friction fv, fc.
Everything is read from a TOML spec (URDF, drives, bounds of the free parameters, truth of the twin, its
input, fit settings): see excitation/tracker_flex_spec.toml and docs/flexible.md.

actions:
  check    print the drives, the free parameters, the RK4 step, and which parameters the spec's
           input makes observable (sensitivity of the angles at the truth); writes nothing unless --json
  twin     simulate the spec's truth under the spec's input, add seeded noise, write a CSV recording
           (t, T_<joint>, q_<joint>, qm_<joint>) and its truth (<out>.json)
  fit      fit the free parameters to a recording (default: a twin made on the fly) with a metaheuristic
           (pso, woa, ewoa, de) or least_squares; write a JSON result and optionally a figure
  compare  fit the flexible and the rigid model to the same recording (seed 003 Figs. 6-7); write a
           JSON result and optionally a figure of measured and simulated angles

examples:
  pinid flex check --spec excitation/tracker_flex_spec.toml
  pinid flex twin --spec excitation/tracker_flex_spec.toml -o tracker_twin.csv
  pinid flex fit --spec excitation/tracker_flex_spec.toml --data tracker_twin.csv --method pso -o fit.json
  pinid flex fit --spec excitation/tracker_flex_spec.toml --method least_squares --x0 fit.json -o polished.json
  pinid flex compare --spec excitation/tracker_flex_spec.toml -o cmp.json --plot cmp.png
"""

DEFAULT_SPEC = "excitation/tracker_flex_spec.toml"


def add_arguments(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="action", metavar="ACTION", required=True)

    def common(q: argparse.ArgumentParser) -> None:
        q.add_argument("--spec", default=None, help=f"flexible-joint spec (TOML); default {DEFAULT_SPEC} of pinid")

    def data_opts(q: argparse.ArgumentParser) -> None:
        q.add_argument("--data", default=None, metavar="CSV",
                       help="recording (t, T_<joint> or V_<joint>, q_<joint>[, qm_<joint>]); default: a twin of the "
                            "spec made on the fly with its [fit] noise and seed")
        q.add_argument("--noise", type=float, default=None, help="noise of the on-the-fly twin [rad] (default: the spec's)")

    def fit_opts(q: argparse.ArgumentParser) -> None:  # no import here: `pinid --help` stays light
        q.add_argument("--method", default=None,
                       help="pso, woa, ewoa, de (pinid.optimizers) or least_squares; default: the spec's [fit] method")
        q.add_argument("--cost", default=None, choices=("abs", "sq"),
                       help="abs = seed 003 Eq. (15), Σ|e|; sq = Σe²; default: the spec's")
        q.add_argument("--outputs", default=None, help="compared angles: link, or link,motor; default: the spec's")
        q.add_argument("--population", type=int, default=None, help="metaheuristic population (default: the spec's)")
        q.add_argument("--iterations", type=int, default=None, help="metaheuristic iterations (default: the spec's)")
        q.add_argument("--seed", type=seed_int, default=None, help="random seed (default: the spec's)")
        q.add_argument("--max-nfev", type=int, default=60, help="least_squares: residual evaluations (default 60)")

    c = sub.add_parser("check", help="drives, free parameters, step and observability of a spec",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    common(c)
    data_opts(c)
    c.add_argument("--json", metavar="FILE", help="also write the description as JSON")

    t = sub.add_parser("twin", help="simulate the spec's truth and write a recording")
    common(t)
    _output(t, "CSV", "recording to write (CSV or NPZ); the truth goes to CSV.json")
    t.add_argument("--noise", type=float, default=None, help="noise on every angle [rad] (default: the spec's)")
    t.add_argument("--seed", type=seed_int, default=None, help="noise seed (default: the spec's)")
    t.add_argument("--no-motor", action="store_true", help="do not record motor angles")
    t.add_argument("--force", action="store_true", help="overwrite the output")

    f = sub.add_parser("fit", help="fit the free parameters by output error")
    common(f)
    data_opts(f)
    fit_opts(f)
    f.add_argument("--rigid", action="store_true", help="fit the rigid-joint model of the spec instead")
    f.add_argument("--x0", default=None, metavar="middle|truth|JSON",
                   help="start: least_squares' start point, or a member of the initial population (default: middle "
                        "of the box for least_squares, none otherwise); a JSON result of an earlier fit")
    _output(f, "JSON", "result to write")
    f.add_argument("--plot", default=None, metavar="PNG", help="also plot measured and simulated angles")
    f.add_argument("--force", action="store_true", help="overwrite outputs")

    m = sub.add_parser("compare", help="rigid vs flexible on one recording (seed 003 Figs. 6-7)")
    common(m)
    data_opts(m)
    fit_opts(m)
    m.add_argument("--no-polish", action="store_true", help="do not refine each metaheuristic result with least_squares")
    _output(m, "JSON", "result to write")
    m.add_argument("--plot", default=None, metavar="PNG", help="also plot measured and simulated angles")
    m.add_argument("--force", action="store_true", help="overwrite outputs")


# ---------------------------------------------------------------------------------------------- helpers
class _DeprecatedOut(argparse.Action):
    """``--out``: the old spelling of ``-o/--output`` (as every other command has it), kept for one release."""

    def __call__(self, parser, namespace, values, option_string=None):
        import warnings

        warnings.warn("pinid flex --out is deprecated, use -o/--output", DeprecationWarning, stacklevel=1)
        setattr(namespace, self.dest, values)


def _output(p: argparse.ArgumentParser, metavar: str, text: str) -> None:
    """-o/--output (required), with --out as a deprecated alias."""
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("-o", "--output", dest="out", metavar=metavar, help=text)
    g.add_argument("--out", dest="out", metavar=metavar, action=_DeprecatedOut, help="deprecated alias of -o/--output")


def _spec(args):
    from pinid.errors import SpecError
    from pinid.flexible.output_error import load_flex_spec
    from pinid.model.bundled import BUNDLED_URDF_DIR

    path = args.spec
    if path is None:
        path = BUNDLED_URDF_DIR.parent / DEFAULT_SPEC
        if not path.is_file():
            raise SpecError(f"no --spec given and the default {DEFAULT_SPEC} is not installed; give --spec")
    return load_flex_spec(path)


def _recording(args, spec):
    from pinid.errors import SpecError
    from pinid.flexible.output_error import FlexRecording, make_twin

    if getattr(args, "data", None):
        return FlexRecording.load(args.data)
    noise = spec.fit.noise if args.noise is None else args.noise
    if noise < 0:
        raise SpecError(f"--noise {noise:g}, expected ≥ 0 [rad]")
    seed = spec.fit.seed if getattr(args, "seed", None) is None else args.seed
    return make_twin(spec.model(), spec.input, noise=noise, rng=seed)


def _fit_options(args, spec) -> tuple[str, dict, int]:
    from pinid.errors import SpecError

    from pinid.flexible.output_error import methods

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
    from pinid.errors import SpecError
    from pinid.flexible.output_error import OUTPUTS

    if args.outputs is None:
        return spec.fit.outputs
    out = tuple(o.strip() for o in args.outputs.split(",") if o.strip())
    if not out or any(o not in OUTPUTS for o in out):
        raise SpecError(f"--outputs {args.outputs!r}, expected link or link,motor")
    return out


def _x0(args, spec, problem):
    from pinid.errors import SpecError
    from pinid.flexible.output_error import OutputErrorResult

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


def _print_result(res) -> None:
    rows = [["parameter", "fitted", "truth", "error %", "lower", "upper"]] + res.table()
    w = [max(len(r[i]) for r in rows) for i in range(6)]
    for r in rows:
        print("  " + "  ".join(c.rjust(w[i]) if i else c.ljust(w[i]) for i, c in enumerate(r)))
    print(f"  cost ({res.cost_kind}) {res.cost:.6g}; "
          + "; ".join(f"{j}: RMS {1e3 * m['rms']:.4g} mrad" for j, m in res.metrics.items())
          + f"; {res.nfev} simulations in {res.seconds:.1f} s (RK4 step {1e3 * res.step:.3g} ms, integrator "
          f"tolerance {res.extra.get('integrator_error', float('nan')):.2g} rad)")


# ---------------------------------------------------------------------------------------------- actions
def run(args: argparse.Namespace) -> int:
    return {"check": _check, "twin": _twin, "fit": _fit, "compare": _compare}[args.action](args)


def _check(args) -> int:
    from pinid.io import Artefacts, check_outputs, json_text
    from pinid.flexible.output_error import classify, problem_from_spec, sensitivity

    if args.json:
        check_outputs(args.json)
    spec = _spec(args)
    rec = _recording(args, spec)
    prob = problem_from_spec(spec, rec)
    model = prob.model
    print(f"robot {spec.robot.name} ({spec.robot.urdf_path}); backend: {model.backends}; "
          f"Coulomb smoothing {model.coulomb_speed:g} rad/s")
    for d in model.drives:
        print(f"  {d.joint:<12} {'flexible' if d.flexible else 'rigid':<9} ratio {d.ratio:g}")
    print(f"recording: {rec.source}, {rec.n} samples at {1 / rec.dt:g} Hz, input {rec.input}; "
          f"RK4 step {1e3 * prob.step:.3g} ms ({int(round(rec.dt / prob.step))} per sample)")
    noise = max(spec.fit.noise, 1e-4)
    sens = sensitivity(prob, noise=noise)
    print(f"observability at {'the truth' if prob.truth else 'the nominal values'} "
          f"(relative std for {1e3 * noise:g} mrad angle noise; condition {sens['condition']:.3g}):")
    for n, lo, hi in zip(prob.free, prob.lower, prob.upper):
        rs = sens["rel_std"][n]
        flag = classify(rs)
        print(f"  {n:<16} [{lo:>9.4g}, {hi:>9.4g}]  rel. std {100 * rs:>10.3g} %  {flag}")
    if args.json:
        arts = Artefacts()
        arts.add(args.json, json_text({"spec": spec.to_dict(), "step": prob.step, "sensitivity": sens}))
        arts.write()
        print(f"wrote {args.json}")
    return 0


def _twin(args) -> int:
    from pinid.errors import SpecError
    from dataclasses import replace

    from pinid.io import Artefacts, json_text
    from pinid.flexible.output_error import make_twin

    arts = Artefacts()  # the recording and its truth, all or nothing; checked before the work
    arts.add(args.out, lambda p: replace(rec, meta={}).save(p))
    arts.add(str(args.out) + ".json", lambda p: p.write_text(json_text(rec.meta), encoding="utf-8"))
    arts.check()
    spec = _spec(args)
    noise = spec.fit.noise if args.noise is None else args.noise
    if noise < 0:
        raise SpecError(f"--noise {noise:g}, expected ≥ 0 [rad]")
    seed = spec.fit.seed if args.seed is None else args.seed
    rec = make_twin(spec.model(), spec.input, noise=noise, rng=seed, motor=not args.no_motor)
    rec.meta["spec"] = str(spec.source)
    rec.meta["seed"] = seed
    arts.write()
    print(f"wrote {args.out} ({rec.n} samples at {1 / rec.dt:g} Hz, noise {noise:g} rad, seed {seed}) "
          f"and {args.out}.json (truth)")
    return 0


def _fit(args) -> int:
    from pinid.io import Artefacts, check_outputs
    from pinid.flexible.output_error import LEAST_SQUARES, fit_output_error, problem_from_spec

    check_outputs(args.out, *([args.plot] if args.plot else []))  # before the work, creating nothing
    spec = _spec(args)
    method, options, seed = _fit_options(args, spec)
    rec = _recording(args, spec)
    prob = problem_from_spec(spec, rec, rigid=args.rigid, cost=args.cost, outputs=_outputs(args, spec))
    x0 = _x0(args, spec, prob)
    print(f"fitting {prob.d} parameters of the {prob.label} model to {rec.source} ({rec.n} samples) with {method}")
    res = fit_output_error(prob, method, rng=seed, x0=x0, options=None if method == LEAST_SQUARES else options,
                           f_scale=spec.fit.f_scale, max_nfev=args.max_nfev)
    res.extra["recording"] = rec.source
    res.extra["spec"] = spec.source
    _print_result(res)
    arts = Artefacts()
    arts.add(args.out, lambda p: res.save(p))
    if args.plot:
        from pinid.report.figures import save_figure
        from pinid.report.plot_flexible import plot_angles

        sim = prob.simulate(res.x).q[0]
        fig = plot_angles(rec.t, prob.recording.q, {prob.label: sim}, prob.model.joint_names,
                          title=f"{prob.label} model, {method}")
        arts.add(args.plot, lambda p: save_figure(fig, p))
    print("wrote " + " and ".join(map(str, arts.write())))
    return 0


def _compare(args) -> int:
    from pinid.io import Artefacts, check_outputs, json_text
    from pinid.flexible.output_error import compare_rigid_flexible

    check_outputs(args.out, *([args.plot] if args.plot else []))  # before the work, creating nothing
    spec = _spec(args)
    method, options, seed = _fit_options(args, spec)
    if args.cost or args.outputs:
        from dataclasses import replace

        spec = replace(spec, fit=replace(spec.fit, cost=args.cost or spec.fit.cost, outputs=_outputs(args, spec)))
    rec = _recording(args, spec)
    out = compare_rigid_flexible(spec, rec, method=method, options=options, rng=seed, polish=not args.no_polish)
    for label in ("flexible", "rigid"):
        print(f"{label} model ({out[label].method}):")
        _print_result(out[label])
    f, r = out["flexible"], out["rigid"]
    print("RMS angle error [mrad]: " + "; ".join(
        f"{j}: flexible {1e3 * f.metrics[j]['rms']:.4g}, rigid {1e3 * r.metrics[j]['rms']:.4g}" for j in f.metrics))
    arts = Artefacts()
    arts.add(args.out, json_text({"recording": rec.source, "spec": spec.source,
                                  "flexible": f.to_dict(), "rigid": r.to_dict()}))
    if args.plot:
        from pinid.report.figures import save_figure
        from pinid.report.plot_flexible import plot_angles

        fig = plot_angles(out["t"], out["measured"], out["simulated"], spec.robot.joint_names,
                          title="rigid vs flexible joints (seed 003 Figs. 6-7)")
        arts.add(args.plot, lambda p: save_figure(fig, p))
    print("wrote " + " and ".join(map(str, arts.write())))
    return 0
