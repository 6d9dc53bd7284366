"""Benchmark: excitation design (issue 3's figures for docs/excitation.md).

    python tests/benchmarks/bench_excitation.py            # everything, about 15 minutes on 2 cores
    python tests/benchmarks/bench_excitation.py --quick    # no deep search, no arms: about 4 minutes

Prints Markdown tables:

1. seed 001 Table 3 on urdf/exo_leg.urdf (condition number, limit usage);
2. pinid's default design (start at rest on / off): condition number, ratio to Table 3, time — targets
   ≤ 0.70 and ≤ 0.62 of Table 3, ≤ 30 s;
3. the best found by a deep search (512 starts, 16 polished), to say how close the default comes, and
   the effect of also optimising the offsets;
4. the optimisers on the same problem and seed: default (slsqp) vs PSO vs WOA vs EWOA vs DE, population
   100 and 200 iterations (seed 001's setting), with convergence curves (docs/img/excitation_convergence.png);
5. more harmonics (N = 4, 5, 6, 8);
6. the same design on a 6-DOF (UR5) and a 7-DOF (Panda) arm of example-robot-data, limits from the URDF.

The condition number is always that of the base regressor (friction columns included, unscaled) over
200 samples of one period, computed by :func:`pinid.excitation.evaluation.condition_number`.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from pinid import RobotModel
from pinid.blas import single_threaded_blas
from pinid.excitation.design import design_excitation
from pinid.excitation.evaluation import evaluate_trajectory, limit_violations
from pinid.excitation.problem import DesignProblem
from pinid.excitation.spec import spec_for
from pinid.excitation.trajectory import FourierTrajectory

ROOT = Path(__file__).resolve().parents[2]
TABLE3 = ROOT / "excitation" / "seed001_table3.json"
EXO = ROOT / "urdf" / "exo_leg.urdf"


def header(title: str) -> None:
    print(f"\n### {title}\n", flush=True)


def table3(model) -> float:
    header("Seed 001 Table 3 on urdf/exo_leg.urdf")
    spec = spec_for(model)
    tr = FourierTrajectory.load(TABLE3)
    ev = evaluate_trajectory(model, tr, spec)
    print(
        f"condition number {ev['condition_number']:.4f}; limits: "
        + ("; ".join(limit_violations(ev["extremes"], spec)) or "inside")
    )
    for j, u in ev["usage"].items():
        e = ev["extremes"][j]
        print(
            f"- {j}: q ∈ [{e['q_min']:.4f}, {e['q_max']:.4f}], |dq| ≤ {e['dq_abs_max']:.3f} ({100 * u['dq']:.0f}%), "
            f"|ddq| ≤ {e['ddq_abs_max']:.3f} ({100 * u['ddq']:.0f}%)"
        )
    return ev["condition_number"]


def default_designs(model, c3: float) -> dict:
    header("Default design (`pinid excite --urdf urdf/exo_leg.urdf`), seed 0")
    print(
        "| start at rest | condition number | ratio to Table 3 | target | time [s] | criterion evaluations | "
        "regressor samples |"
    )
    print("|---|---|---|---|---|---|---|")
    out = {}
    for rest, target in ((True, 0.70), (False, 0.62)):
        res = design_excitation(model, spec_for(model, rest_start=rest), seed=0)
        ratio = res.condition_number / c3
        out[rest] = res
        print(
            f"| {'on' if rest else 'off'} | {res.condition_number:.3f} | {ratio:.4f} | ≤ {target} "
            f"{'✓' if ratio <= target else '✗'} | {res.seconds:.1f} {'✓' if res.seconds <= 30 else '✗'} | {res.nfev} | "
            f"{res.details['regressor_samples'] / 1e6:.2f} M |",
            flush=True,
        )
    return out


def deep_search(model, c3: float, defaults: dict) -> None:
    header("How close to the best found (deep search: 512 starts, 16 polished; and free offsets)")
    print("| start at rest | offsets | starts | condition number | ratio to Table 3 | default / best | time [s] |")
    print("|---|---|---|---|---|---|---|")
    for rest in (True, False):
        res = design_excitation(model, spec_for(model, rest_start=rest), seed=1, options={"starts": 512, "polish": 16})
        print(
            f"| {'on' if rest else 'off'} | fixed | 512 | {res.condition_number:.3f} | {res.condition_number / c3:.4f} | "
            f"{defaults[rest].condition_number / res.condition_number:.4f} | {res.seconds:.0f} |",
            flush=True,
        )
    for rest in (True, False):
        res = design_excitation(model, spec_for(model, rest_start=rest, optimize_offsets=True), seed=0)
        print(
            f"| {'on' if rest else 'off'} | optimised | 128 | {res.condition_number:.3f} | "
            f"{res.condition_number / c3:.4f} | – | {res.seconds:.1f} |",
            flush=True,
        )


def optimizers(model, c3: float, default, img_dir: Path | None) -> None:
    header(
        "Optimisers on the same problem (default spec, start at rest), seed 0; metaheuristics: population 100, "
        "200 iterations"
    )
    print("| optimiser | condition number | ratio to Table 3 | criterion evaluations | regressor samples | time [s] |")
    print("|---|---|---|---|---|---|")
    print(
        f"| slsqp (default) | {default.condition_number:.3f} | {default.condition_number / c3:.4f} | {default.nfev} | "
        f"{default.details['regressor_samples'] / 1e6:.2f} M | {default.seconds:.1f} |"
    )
    histories = {}
    for name in ("pso", "woa", "ewoa", "de"):
        res = design_excitation(
            model, spec_for(model), optimizer=name, options={"population": 100, "iterations": 200}, seed=0
        )
        histories[name.upper()] = res.history
        print(
            f"| {name} | {res.condition_number:.3f} | {res.condition_number / c3:.4f} | {res.nfev} | "
            f"{res.details['regressor_samples'] / 1e6:.2f} M | {res.seconds:.1f} |",
            flush=True,
        )
    if img_dir is not None:
        from pinid.report.figures import save_figure
        from pinid.report.plot_excitation import plot_convergence

        fig = plot_convergence(
            histories, references={"slsqp (default)": default.condition_number, "seed 001 Table 3": c3}, log=False
        )
        fig.axes[0].set_title("exo_leg, N = 4, ωf = 0.2π, start at rest (population 100, seed 0)")
        save_figure(fig, img_dir / "excitation_convergence.png")
        print(f"\nconvergence curves: {img_dir / 'excitation_convergence.png'}")


def harmonics(model, c3: float) -> None:
    header("More harmonics (default optimiser, start at rest, ωf = 0.2π, Table 2 limits)")
    print("| N | variables | condition number | ratio to Table 3 | time [s] |")
    print("|---|---|---|---|---|")
    for n in (4, 5, 6, 8):
        spec = spec_for(model, harmonics=n)
        res = design_excitation(model, spec, seed=0)
        d = DesignProblem(model, spec).d
        print(
            f"| {n} | {d} | {res.condition_number:.3f} | {res.condition_number / c3:.4f} | {res.seconds:.1f} |",
            flush=True,
        )


def arms() -> None:
    header("Arms of example-robot-data (limits from the URDF, 5 rad/s², offsets at the range centres, start at rest)")
    print(
        "| robot | DOF | base parameters | variables | random feasible start | default design | "
        "time [s] | 16 starts | time [s] |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name in ("ur5", "panda"):
        model = RobotModel.from_urdf(name)
        spec = spec_for(model)
        problem = DesignProblem(model, spec)
        rng = np.random.default_rng(0)
        lo, up = problem.box()
        with single_threaded_blas():
            rand = np.median(problem.evaluate(problem.scale_into_limits(lo + rng.random((16, problem.d)) * (up - lo))))
        full = design_excitation(model, spec, seed=0)
        short = design_excitation(model, spec, seed=0, options={"starts": 16})
        print(
            f"| {name} | {model.nv} | {problem.base.count} | {problem.d} | {rand:.1f} (median of 16) | "
            f"{full.condition_number:.2f} | {full.seconds:.0f} | {short.condition_number:.2f} | {short.seconds:.0f} |",
            flush=True,
        )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="skip the deep search, harmonics and the arms")
    p.add_argument("--img-dir", default=str(ROOT / "docs" / "img"), help="where the figures go ('' for none)")
    args = p.parse_args()
    img_dir = Path(args.img_dir) if args.img_dir else None
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"python {platform.python_version()}, numpy {np.__version__}"
    )
    print("command: python " + " ".join(sys.argv))
    started = time.perf_counter()
    model = RobotModel.from_urdf(EXO)
    c3 = table3(model)
    defaults = default_designs(model, c3)
    if img_dir is not None:
        from pinid.report.figures import save_figure
        from pinid.report.plot_excitation import plot_excitation

        res = defaults[True]
        save_figure(
            plot_excitation(
                res.trajectory,
                res.spec,
                title=f"exo_leg default design (start at rest): condition number "
                f"{res.condition_number:.2f}, Table 3: {c3:.2f}",
            ),
            img_dir / "excitation_exo_leg.png",
        )
        save_figure(
            plot_excitation(
                FourierTrajectory.load(TABLE3),
                res.spec,
                title=f"seed 001 Table 3 (read in degrees): condition number {c3:.2f}",
            ),
            img_dir / "excitation_table3.png",
        )
    if not args.quick:
        deep_search(model, c3, defaults)
    optimizers(model, c3, defaults[True], img_dir)
    if not args.quick:
        harmonics(model, c3)
        arms()
    print(f"\ntotal {time.perf_counter() - started:.0f} s")


if __name__ == "__main__":
    main()
