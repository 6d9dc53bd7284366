"""Reproduce seed 001's comparison (Shi et al. 2024): PSO vs WOA vs EWOA for excitation design and identification.

    OPENBLAS_NUM_THREADS=1 python tests/benchmarks/reproduce_seed001.py [--seeds 5] [--population 100]
        [--iterations 200] [--seconds 60] [--out /tmp/pinid_seed001] [--figures docs/img]

1. **Excitation design** (its Fig. 3a): minimise the condition number of the base regressor (Eq. (20)) of
   a Fourier trajectory (Eq. (19), N = 4, ωf = 0.2π rad/s, offsets 0.6107 / −0.8727 rad) inside the
   Table 2 limits (``excitation/exo_leg_table2.toml``), on ``urdf/exo_leg.urdf``, with
   :func:`pinid.excitation.design.design_excitation` and ``optimizer`` = pso, woa, ewoa (population 100,
   200 iterations), ``--seeds`` seeds each; pinid's default gradient-based multistart (``slsqp``) and the
   paper's own Table 3 trajectory (``excitation/seed001_table3.json``) as references.
2. **Identification** (its Fig. 3b, Table 4): the twin (exo_leg as the truth, PID control as in the paper,
   16-bit encoders, 1 % torque noise, the "CAD" model — truth perturbed by 20 %, friction scaled by
   [0.5, 1.5] — as feed-forward and as the centre of the search box) runs ``--seconds`` of the trajectory
   EWOA designed with seed 0; preprocessing with the ``seed001`` preset (Butterworth, forward and
   reverse); validation on a different trajectory, the paper's Table 3 one.  :func:`pinid.identification.compare.compare`
   runs LS, the LMI method, PSO, WOA, EWOA and DE with seed 001's fitness ½Σr² (Eq. (22)), population
   100, 200 iterations, ``--seeds`` seeds.

Prints Markdown tables and writes ``seed001_*.png`` into ``--figures`` and ``results.json`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from pinid import RobotModel
from pinid.identification.study import Study
from pinid.parallel import run_parallel
from pinid.identification.compare import compare
from pinid.excitation.design import design_excitation
from pinid.excitation.evaluation import evaluate_trajectory
from pinid.excitation.spec import spec_for
from pinid.data.preprocess import prepare
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.cad import perturb
from pinid.simulation.twin import simulate

ROOT = Path(__file__).resolve().parents[2]
OPTIMIZERS = ("pso", "woa", "ewoa")
COLORS = {"pso": "tab:blue", "woa": "tab:orange", "ewoa": "tab:red", "de": "tab:purple", "slsqp": "black"}


def cad_model(truth: RobotModel, percent: float, seed: int) -> RobotModel:
    rng = np.random.default_rng(seed)
    cad = perturb(truth, percent, rng)
    return cad.with_inertial_parameters(
        cad.inertial_parameters(),
        coulomb=truth.coulomb * rng.uniform(0.5, 1.5, 2),
        viscous=truth.viscous * rng.uniform(0.5, 1.5, 2),
    )


def _design(shared: tuple, job: tuple) -> dict:
    """One metaheuristic excitation design (a job of :func:`pinid.parallel.run_parallel`)."""
    leg, spec = shared
    name, seed, population, iterations = job
    r = design_excitation(
        leg,
        spec,
        optimizer=name,
        seed=seed,
        progress=False,
        options={"population": population, "iterations": iterations},
    )
    return {
        "seed": seed,
        "cond": float(r.condition_number),
        "history": [float(h) for h in r.history],
        "seconds": float(r.seconds),
        "nfev": int(r.nfev),
        "feasible": bool(r.feasible),
        "trajectory": r.trajectory.to_dict(),
    }


def excitation_part(leg: RobotModel, args) -> dict:
    spec = spec_for(leg)
    out: dict = {"runs": {}, "spec": spec.source}
    jobs = [(name, seed, args.population, args.iterations) for name in OPTIMIZERS for seed in range(args.seeds)]
    designs = run_parallel(_design, (leg, spec), jobs, workers=args.workers, label="excitation designs")
    for (name, seed, _, _), r in zip(jobs, designs):
        out["runs"].setdefault(name, []).append(r)
        print(f"excitation {name} seed {seed}: cond {r['cond']:.3f} in {r['seconds']:.1f} s", file=sys.stderr)
    t0 = time.perf_counter()
    ref = design_excitation(leg, spec, seed=0, progress=False)
    out["slsqp"] = {"cond": float(ref.condition_number), "seconds": time.perf_counter() - t0, "nfev": int(ref.nfev)}
    paper = load_trajectory(str(ROOT / "excitation" / "seed001_table3.json"), leg)
    ev = evaluate_trajectory(leg, paper, spec)
    out["paper_table3"] = {"cond": float(ev["condition_number"]), "feasible": bool(ev["feasible"])}
    return out


def identification_part(leg: RobotModel, train_traj, args) -> dict:
    cad = cad_model(leg, 20.0, 0)
    val_traj = load_trajectory(str(ROOT / "excitation" / "seed001_table3.json"), leg)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec, truth = simulate(leg, train_traj, seconds=args.seconds, seed=11, controller="pid", feedforward_model=cad)
        val, _ = simulate(
            leg, val_traj, seconds=min(args.seconds, 30.0), seed=12, controller="pid", feedforward_model=cad
        )
        train = prepare(rec, {"preset": "shi2024"})
        valid = prepare(val, {"preset": "shi2024"})
    comp = compare(
        Study(cad, train, {"Table 3 trajectory": valid}),
        methods=["ols", "sdp", "pso", "woa", "ewoa", "de"],
        seeds=args.seeds,
        truth=truth,
        metaheuristic={"fitness": "sse", "population": args.population, "iterations": args.iterations},
        workers=args.workers,
    )
    return {"comparison": comp.to_dict(), "table": comp.table(), "values": comp.values_table(), "_comp": comp}


def markdown(exc: dict, ident: dict, args) -> str:
    L = []
    L.append(
        f"Excitation design, condition number of the base regressor (Eq. (20)), {args.seeds} seeds, population "
        f"{args.population}, {args.iterations} iterations:\n"
    )
    L.append("| optimiser | cond: mean ± sd | best | worst | evaluations | time [s] |")
    L.append("|---|---|---|---|---|---|")
    for name, runs in exc["runs"].items():
        c = np.array([r["cond"] for r in runs])
        L.append(
            f"| {name} | {c.mean():.2f} ± {c.std():.2f} | {c.min():.2f} | {c.max():.2f} | {runs[0]['nfev']} | "
            f"{np.mean([r['seconds'] for r in runs]):.1f} |"
        )
    L.append(
        f"| slsqp (pinid's default, multistart) | {exc['slsqp']['cond']:.2f} | | | {exc['slsqp']['nfev']} | "
        f"{exc['slsqp']['seconds']:.1f} |"
    )
    L.append(f"| the paper's Table 3 trajectory | {exc['paper_table3']['cond']:.2f} | | | | |")
    L.append("")
    L.append("Identification on the twin (fitness ½Σr², Eq. (22)), validation on the paper's Table 3 trajectory:\n")
    L.append("```")
    L.append(ident["table"])
    L.append("```\n")
    L.append("```")
    L.append(ident["values"])
    L.append("```")
    comp = ident["_comp"]
    neg = {
        m: sum(
            1
            for r in runs
            if r.base[comp.base_names.index("hip.fv")] < 0 or r.base[comp.base_names.index("knee.fv")] < 0
        )
        for m, runs in comp.runs.items()
    }
    L.append(
        "\nRuns with a negative viscous friction coefficient (seed 001 Table 4's Φ6 = −3.1): "
        + ", ".join(f"{m} {n}/{len(comp.runs[m])}" for m, n in neg.items())
    )
    return "\n".join(L)


def figures(exc: dict, ident: dict, folder: Path) -> list[Path]:
    from pinid.report.figures import new_figure, save_figure
    from pinid.report.plot_compare import convergence, parameter_errors, validation_errors

    folder.mkdir(parents=True, exist_ok=True)
    written = []
    fig, axes = new_figure(1, 2, figsize=(11, 3.9))
    ax = axes[0]
    for name, runs in exc["runs"].items():
        for k, r in enumerate(runs):
            ax.plot(r["history"], color=COLORS[name], lw=0.7, alpha=0.5, label=name if k == 0 else None)
        med = np.median(np.vstack([r["history"] for r in runs]), axis=0)
        ax.plot(med, color=COLORS[name], lw=2)
    ax.axhline(
        exc["slsqp"]["cond"], color="black", ls="--", lw=1, label=f"slsqp multistart ({exc['slsqp']['cond']:.1f})"
    )
    ax.axhline(
        exc["paper_table3"]["cond"],
        color="grey",
        ls=":",
        lw=1.2,
        label=f"paper's Table 3 trajectory ({exc['paper_table3']['cond']:.1f})",
    )
    ax.set_yscale("log")
    ax.set_xlabel("iteration")
    ax.set_ylabel("best condition number (Eq. (20))")
    ax.set_title("(a) excitation design (cf. seed 001 Fig. 3a)", fontsize="small")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize="x-small")
    comp = ident["_comp"]
    convergence(comp, ax=axes[1], title="(b) identification, fitness ½Σr² (cf. seed 001 Fig. 3b)")
    axes[1].title.set_fontsize("small")
    fig.tight_layout()
    path = folder / "seed001_convergence.png"
    save_figure(fig, path)
    written.append(path)
    fig = validation_errors(comp, "Table 3 trajectory", title="validation on the paper's Table 3 trajectory")
    path = folder / "seed001_errors.png"
    save_figure(fig, path)
    written.append(path)
    fig = parameter_errors(comp, title="error against the true parameters (exo_leg twin)")
    path = folder / "seed001_parameters.png"
    save_figure(fig, path)
    written.append(path)
    return written


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seeds", type=int, default=5)
    p.add_argument("--workers", type=int, default=None, help="local processes (default: every core)")
    p.add_argument("--population", type=int, default=100)
    p.add_argument("--iterations", type=int, default=200)
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--out", default="/tmp/pinid_seed001")
    p.add_argument("--figures", default=None, help="folder for seed001_*.png (e.g. docs/img)")
    p.add_argument("--replot", action="store_true", help="redo tables and figures from --out/results.json")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    if args.replot:
        from pinid.identification.compare import Comparison

        saved = json.loads((Path(args.out) / "results.json").read_text())
        exc = saved["excitation"]
        comp = Comparison.from_dict(saved["identification"])
        ident = {
            "comparison": saved["identification"],
            "table": comp.table(),
            "values": comp.values_table(),
            "_comp": comp,
        }
    else:
        leg = RobotModel.from_urdf("exo_leg")
        exc = excitation_part(leg, args)
        from pinid.excitation.trajectory import FourierTrajectory

        ewoa0 = FourierTrajectory.from_dict(exc["runs"]["ewoa"][0]["trajectory"])
        ident = identification_part(leg, ewoa0, args)
    md = markdown(exc, ident, args)
    print(md)
    folder = Path(args.out)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "results.json").write_text(
        json.dumps({"excitation": exc, "identification": ident["comparison"]}, indent=1, default=float)
    )
    (folder / "results.md").write_text(md + "\n")
    if args.figures:
        for path in figures(exc, ident, Path(args.figures)):
            print(f"wrote {path}", file=sys.stderr)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
