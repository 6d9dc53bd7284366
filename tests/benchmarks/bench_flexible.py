"""Benchmark and docs figures for flexible joints (issue 8, seed 003): docs/flexible.md quotes its output.

    python tests/benchmarks/bench_flexible.py                 # everything, ~10 min on 2 cores
    python tests/benchmarks/bench_flexible.py --quick         # small budgets, ~1 min (a smoke run)
    python tests/benchmarks/bench_flexible.py --only recovery # one part: cost, integrator, recovery,
                                                              # observability, methods, compare

Parts (Markdown tables on stdout, figures docs/img/flexible_*.png):

1. ``cost``: seconds per simulated parameter set, batch "trig" backend vs Pinocchio ABA per particle.
2. ``integrator``: RK4 step vs the angles' error (against a 16× finer step) at the truth.
3. ``recovery``: noise-free twin, least squares from starts 10 % and 30 % off the truth: error per
   parameter (the ≤ 2 % claim), with the spec's step (2 ms) and a 0.5 ms step.
4. ``observability``: Cramér-Rao relative standard deviations at 1 mrad noise, link angles only (seed 003)
   and link + motor angles.
5. ``methods``: noisy twin (the spec's 1 mrad, seed 0), seed 003's cost Eq. (15); pso, woa, ewoa, de with the
   same budget, each polished by least squares, and least squares alone from the middle of the box: cost,
   angle RMS, errors against the truth, time; cost curves and parameter errors as figures.
6. ``compare``: rigid vs flexible on the same noisy twin (seed 003 Figs. 6-7).
"""

from __future__ import annotations

import argparse
import platform
import time
from pathlib import Path

import numpy as np

from pinid.flexible.output_error import (
    LEAST_SQUARES,
    classify,
    fit_output_error,
    make_twin,
    problem_from_spec,
    sensitivity,
)
from pinid.flexible.spec import load_flex_spec
from pinid.report.figures import save_figure
from pinid.report.plot_flexible import plot_angles, plot_cost_curves, plot_parameter_errors

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "excitation" / "tracker_flex_spec.toml"
METHODS = ("pso", "woa", "ewoa", "de")


def truth_vector(problem) -> np.ndarray:
    return np.array([problem.truth[n] for n in problem.free])


def part_cost(spec, quick: bool) -> None:
    from pinid.flexible.model import FlexibleModel

    print("\n## 1. Simulation cost per parameter set (2 s at 500 Hz, RK4 step 2 ms, 1000 steps)\n")
    print("| population P | trig backend [s per batch] | [ms per set] | pinocchio ABA [s per batch] | [ms per set] |")
    print("|---|---|---|---|---|")
    m = spec.model()
    m_trig, m_pin = (
        FlexibleModel(
            spec.robot,
            spec.drives,
            dict(zip(m.names, m.values)),
            coulomb_speed=spec.coulomb_speed,
            max_step=spec.max_step,
            backend=b,
        )
        for b in ("trig", "pinocchio")
    )
    t, u = spec.input.generate(m_trig.joint_names)
    dt = float(t[1] - t[0])
    for P in (1, 10) if quick else (1, 10, 60, 100):
        X = np.repeat(m_trig.values[None, :], P, axis=0)
        row = [str(P)]
        for m in (m_trig, m_pin):
            if m is m_pin and P > 10 and quick:
                row += ["-", "-"]
                continue
            best = np.inf
            for _ in range(2):
                s = time.perf_counter()
                m.simulate(u, dt, X, step=0.002)
                best = min(best, time.perf_counter() - s)
            row += [f"{best:.3f}", f"{1e3 * best / P:.2f}"]
        print("| " + " | ".join(row) + " |")


def part_integrator(spec) -> None:
    print("\n## 2. RK4 step vs angle error at the truth (reference: step / 16)\n")
    m = spec.model()
    t, u = spec.input.generate(m.joint_names)
    dt = float(t[1] - t[0])
    print("| step [ms] | max angle error [rad] |")
    print("|---|---|")
    ref = m.simulate(u, dt, step=0.002 / 16).q[0]
    for h in (0.002, 0.001, 0.0005):
        q = m.simulate(u, dt, step=h).q[0]
        print(f"| {1e3 * h:g} | {np.max(np.abs(q - ref)):.2e} |")


def part_recovery(spec) -> dict:
    print("\n## 3. Noise-free recovery (least squares, squared error, link angles only)\n")
    from dataclasses import replace

    results = {}
    twin = make_twin(spec.model(), spec.input, noise=0.0)
    rng = np.random.default_rng(1)
    cols = []
    for max_step in (spec.max_step, 0.0005):
        s = replace(spec, max_step=max_step)
        prob = problem_from_spec(s, twin, cost="sq")
        xt = truth_vector(prob)
        for spread in (0.1, 0.3):
            signs = rng.choice([-1.0, 1.0], xt.size)
            x0 = np.clip(
                xt * (1 + spread * signs) + (xt == 0) * spread * (prob.upper - prob.lower), prob.lower, prob.upper
            )
            res = fit_output_error(prob, LEAST_SQUARES, x0=x0, max_nfev=60)
            key = f"step {1e3 * prob.step:g} ms, start ±{int(100 * spread)} %"
            results[key] = res
            cols.append(key)
            rms = max(mm["rms"] for mm in res.metrics.values())
            print(
                f"- {key}: {res.nfev} simulations, {res.seconds:.1f} s, angle RMS {rms:.2g} rad, integrator "
                f"tolerance {res.extra['integrator_error']:.2g} rad; {res.message}"
            )
    print("\n| parameter | truth | " + " | ".join(f"error % ({c})" for c in cols) + " |")
    print("|---|---|" + "---|" * len(cols))
    first = results[cols[0]]
    for n in first.names:
        cells = [f"{100 * results[c].rel_error[n]:+.3f}" for c in cols]
        print(f"| {n} | {first.truth[n]:g} | " + " | ".join(cells) + " |")
    return results


def part_observability(spec, noise: float) -> None:
    print(f"\n## 4. Observability: relative standard deviation at {1e3 * noise:g} mrad angle noise (Cramér-Rao)\n")
    twin = make_twin(spec.model(), spec.input, noise=0.0)
    cols = {}
    for outputs in (("link",), ("link", "motor")):
        prob = problem_from_spec(spec, twin, cost="sq", outputs=outputs)
        cols["+".join(outputs)] = sensitivity(prob, noise=noise)
    keys = list(cols)
    print("| parameter | " + " | ".join(f"{k} angles: σ/|x| % | class" for k in keys) + " |")
    print("|---|" + "---|---|" * len(keys))
    for n in cols[keys[0]]["names"]:
        cells = []
        for k in keys:
            rs = cols[k]["rel_std"][n]
            cells += [f"{100 * rs:.3g}", classify(rs)]
        print(f"| {n} | " + " | ".join(cells) + " |")
    print("\ncondition numbers of the sensitivity: " + ", ".join(f"{k}: {cols[k]['condition']:.3g}" for k in keys))


def part_methods(spec, img: Path, quick: bool) -> dict:
    pop, its = (20, 10) if quick else (spec.fit.population, spec.fit.iterations)
    noise = spec.fit.noise
    print(
        f"\n## 5. Methods on the noisy twin ({1e3 * noise:g} mrad, seed {spec.fit.seed}), cost '{spec.fit.cost}' "
        f"(seed 003 Eq. (15)), population {pop} × {its} iterations, then least squares\n"
    )
    twin = make_twin(spec.model(), spec.input, noise=noise, rng=spec.fit.seed)
    prob = problem_from_spec(spec, twin)
    xt = truth_vector(prob)
    c_truth = prob.cost(xt)
    rms_truth = prob.metrics(xt)
    print(
        f"cost at the truth: {c_truth:.4g} (angle RMS "
        + ", ".join(f"{j} {1e3 * m['rms']:.3g} mrad" for j, m in rms_truth.items())
        + ": the noise)\n"
    )
    results, polished = {}, {}
    for meth in METHODS:
        res = fit_output_error(
            prob, meth, rng=spec.fit.seed, options={"population": pop, "iterations": its}, progress=False
        )
        results[meth] = res
        ls = fit_output_error(prob, LEAST_SQUARES, x0=res.x, f_scale=spec.fit.f_scale, max_nfev=15 if quick else 40)
        polished[meth] = ls
    res = fit_output_error(prob, LEAST_SQUARES, f_scale=spec.fit.f_scale, max_nfev=15 if quick else 60)
    results[LEAST_SQUARES + " (middle)"] = res
    print(
        "| method | simulations | time [s] | cost | base RMS [mrad] | barrel RMS [mrad] | + least squares: cost | "
        "base RMS | barrel RMS | time [s] |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for meth, r in results.items():
        p = polished.get(meth)
        cells = [
            meth,
            str(r.nfev),
            f"{r.seconds:.1f}",
            f"{r.cost:.4g}",
            f"{1e3 * r.metrics['base']['rms']:.3g}",
            f"{1e3 * r.metrics['barrel']['rms']:.3g}",
        ]
        if p is not None:
            cells += [
                f"{p.cost:.4g}",
                f"{1e3 * p.metrics['base']['rms']:.3g}",
                f"{1e3 * p.metrics['barrel']['rms']:.3g}",
                f"{p.seconds:.1f}",
            ]
        else:
            cells += ["-"] * 4
        print("| " + " | ".join(cells) + " |")
    print("\nerrors against the truth [%] after least squares:\n")
    names = prob.free
    print("| parameter | truth | " + " | ".join(f"{m}+ls" for m in METHODS) + " |")
    print("|---|---|" + "---|" * len(METHODS))
    for n in names:
        print(
            f"| {n} | {prob.truth[n]:g} | "
            + " | ".join(f"{100 * polished[m].rel_error[n]:+.2f}" for m in METHODS)
            + " |"
        )
    hist = {m: r.history for m, r in results.items()}
    for m in METHODS:
        p = polished[m]
        hist[f"{m} + least squares"] = [[results[m].nfev + h[0], min(h[1], results[m].cost)] for h in p.history]
    fig = plot_cost_curves(hist, title=f"output-error fit of the tracker (cost at the truth {c_truth:.3g})")
    fig.axes[0].axhline(c_truth, color="k", lw=0.8, ls=":")
    save_figure(fig, img / "flexible_cost_curves.png")
    fig = plot_parameter_errors(
        {f"{m}+ls": polished[m].rel_error for m in METHODS},
        title="errors against the truth after least squares (1 mrad noise)",
    )
    save_figure(fig, img / "flexible_parameter_errors.png")
    best = min(polished.values(), key=lambda r: r.cost)
    return {"twin": twin, "best": best, "results": results, "polished": polished}


def part_compare(spec, img: Path, quick: bool, flexible=None) -> None:
    pop, its = (20, 10) if quick else (spec.fit.population, spec.fit.iterations)
    noise = spec.fit.noise
    twin = make_twin(spec.model(), spec.input, noise=noise, rng=spec.fit.seed)
    meth = "de"
    print(f"\n## 6. Rigid vs flexible (seed 003 Figs. 6-7): {meth} {pop} × {its} + least squares, same noisy twin\n")
    fits = {}
    for label, rigid in (("flexible", False), ("rigid", True)):
        prob = problem_from_spec(spec, twin, rigid=rigid)
        r = fit_output_error(
            prob, meth, rng=spec.fit.seed, options={"population": pop, "iterations": its}, progress=False
        )
        ls = fit_output_error(prob, LEAST_SQUARES, x0=r.x, f_scale=spec.fit.f_scale, max_nfev=15 if quick else 40)
        best = ls if ls.cost <= r.cost else r
        if label == "flexible" and flexible is not None and flexible.cost < best.cost:
            best = flexible
        fits[label] = (prob, best, r.nfev + ls.nfev, r.seconds + ls.seconds)
    print(
        "| model | free parameters | cost Eq. (15) | base RMS [mrad] | base max [mrad] | barrel RMS [mrad] | "
        "barrel max [mrad] | simulations | time [s] |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for label, (prob, r, nfev, secs) in fits.items():
        mb, mr = r.metrics["base"], r.metrics["barrel"]
        print(
            f"| {label} | {prob.d} | {r.cost:.4g} | {1e3 * mb['rms']:.3g} | {1e3 * mb['max_abs']:.3g} | "
            f"{1e3 * mr['rms']:.3g} | {1e3 * mr['max_abs']:.3g} | {nfev} | {secs:.1f} |"
        )
    prob_f, rf = fits["flexible"][0], fits["flexible"][1]
    prob_r, rr = fits["rigid"][0], fits["rigid"][1]
    sims = {"flexible": prob_f.simulate(rf.x).q[0], "rigid": prob_r.simulate(rr.x).q[0]}
    print("\nrigid model's fitted values: " + ", ".join(f"{n} = {v:.4g}" for n, v in rr.values.items()))
    fig = plot_angles(
        twin.t,
        prob_f.recording.q,
        sims,
        spec.robot.joint_names,
        title="tracker, 1 mrad noise: measured vs rigid and flexible fits (seed 003 Figs. 6-7)",
    )
    save_figure(fig, img / "flexible_rigid_vs_flexible.png")
    fig = plot_angles(
        twin.t,
        prob_f.recording.q,
        sims,
        spec.robot.joint_names,
        window=(0.9, 1.5),
        title="zoom 0.9-1.5 s: the belt's ringing after the torque steps",
    )
    save_figure(fig, img / "flexible_rigid_vs_flexible_zoom.png")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="small budgets (a smoke run)")
    ap.add_argument(
        "--only",
        default=None,
        help="comma-separated parts: cost, integrator, recovery, observability, methods, compare",
    )
    ap.add_argument("--img", default=str(ROOT / "docs" / "img"), help="folder of the figures")
    args = ap.parse_args()
    parts = (
        set(args.only.split(","))
        if args.only
        else {"cost", "integrator", "recovery", "observability", "methods", "compare"}
    )
    img = Path(args.img)
    spec = load_flex_spec(SPEC)
    start = time.perf_counter()
    print(
        f"machine: {platform.processor() or platform.machine()}, python {platform.python_version()}; "
        f"spec {SPEC.relative_to(ROOT)}"
    )
    if "cost" in parts:
        part_cost(spec, args.quick)
    if "integrator" in parts:
        part_integrator(spec)
    if "recovery" in parts:
        part_recovery(spec)
    if "observability" in parts:
        part_observability(spec, spec.fit.noise)
    flexible = None
    if "methods" in parts:
        flexible = part_methods(spec, img, args.quick)["best"]
    if "compare" in parts:
        part_compare(spec, img, args.quick, flexible)
    print(f"\ntotal {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
