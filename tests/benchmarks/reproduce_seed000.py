"""Reproduce seed 000's experiment (Zha et al. 2019, RLS-PSO) on pinid's digital twin of the APAL leg.

    OPENBLAS_NUM_THREADS=1 python tests/benchmarks/reproduce_seed000.py [--realisations 5] [--iterations 1000]
        [--seconds 20] [--out /tmp/pinid_seed000] [--figures docs/img]

The paper's protocol, step by step:

* robot: ``urdf/apal_leg.urdf`` (the truth, fitted to the paper's RLS-PSO parameters, docs/robots.md);
  the identification starts from a "CAD" model — the truth perturbed by 20 % (inertia,
  :func:`pinid.simulation.twin.perturb`) and friction scaled by a factor in [0.5, 1.5] — which is also the
  controller's feed-forward model and the centre of the plain PSO's search box;
* data: Table 1 trajectories 1 and 2 (hip fixed at −10°, knee swinging) and 3 and 4 (both swinging),
  ``--seconds`` each at 1 kHz, PD control, 16-bit encoders, 1 % torque noise, Coulomb (tanh) and viscous
  friction; preprocessing with the ``seed000`` preset (zero-phase 10 Hz Butterworth, central differences);
* segmental strategy (§3.1): knee parameters X(6:10) from trajectory 1, validated on trajectory 2
  (Fig. 10); hip parameters X(1:5) from trajectory 3 with Eq. (9)'s subtraction, validated on
  trajectory 4 (Fig. 13);
* methods: LS (``ols``), pinid's LMI method (``sdp``), RLS (λ = 1), PSO in the nominal box and
  RLS-PSO, both with seed 000's fitness Σ|r| (``sae``) and, as a control, with ½Σr² (``sse``), population
  100, ``--iterations``; plus the least-absolute-deviations fit (LAD, the global minimum of Σ|r|, by
  IRLS) as the deterministic answer to the metaheuristics' Σ|r| problem;
* ``--realisations`` independent noise realisations of all four recordings (simulation seeds), each
  with its own optimiser seed; every figure is mean ± spread over them.

Prints Markdown tables (the paper's format next to the paper's numbers, the identified X next to
Tables 4 and 6, the RLS boxes next to Tables 3 and 5) and writes ``seed000_*.png`` into ``--figures``
and ``results.json`` into ``--out``.
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
from pinid.identification.compare import compare, lad
from pinid.data.preprocess import prepare
from pinid.identification.segmental import SegmentalProblem
from pinid.identification.study import Study
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.cad import perturb
from pinid.simulation.twin import simulate

# The paper's numbers.  Validation: mean ± std of |e| [N·m]; Fig. 10 knee (trajectory 2), Fig. 13 hip (trajectory 4).
PAPER_VALIDATION = {
    "knee": {"LS": (1.0427, 0.9047), "PSO": (0.5126, 0.4386), "RLS-PSO": (0.1887, 0.2475)},
    "hip": {"LS": (4.9922, 3.7366), "PSO": (4.3516, 3.3602), "RLS-PSO": (1.2128, 3.100)},
}
X_NAMES = ["M_xt", "M_yt", "J_t", "f_c1", "f_v1", "M_xs", "M_ys", "J_s", "f_c2", "f_v2"]
PAPER_X = {  # Tables 4 and 6
    "LS": [6.5124, 2.4481, 2.4996, 1.7285, 0.0245, 1.3859, -0.8267, 0.7019, 0.0943, 0.2907],
    "PSO": [7.9970, 3.4969, 2.9922, 1.5914, 0.0752, 1.2199, -0.4016, 0.5906, 0.3323, 0.1830],
    "RLS-PSO": [7.4433, 3.1788, 2.8413, 1.7285, 0.0372, 1.1822, -0.2808, 0.5655, 0.4406, 0.1020],
}
PAPER_BOX = {  # Tables 3 and 5
    "lower": [5.38, 2.34, 2.01, 0.10, 0.01, 0.79, -0.98, 0.39, 0.01, 0.02],
    "upper": [11.64, 5.20, 4.25, 7.88, 1.70, 1.79, 0.18, 0.91, 1.13, 3.15],
}
LABELS = {
    "ols": "LS",
    "sdp": "LMI (pinid)",
    "rls": "RLS (λ=1)",
    "lad": "LAD (IRLS)",
    "pso/sae": "PSO Σ|r|",
    "rls-pso/sae": "RLS-PSO Σ|r|",
    "rls-pso/sae99": "RLS-PSO Σ|r|, λ=0.99",
    "pso/sse": "PSO ½Σr²",
    "rls-pso/sse": "RLS-PSO ½Σr²",
    "pso/sse10k": "PSO ½Σr², G=10⁴",
    "rls-pso/sse10k": "RLS-PSO ½Σr², G=10⁴",
}


def md_label(key: str) -> str:
    """A method's label as a Markdown table cell (its | escaped, or it would split the cell)."""
    return LABELS.get(key, key).replace("|", "\\|")


def to_paper_x(base: dict) -> np.ndarray:
    """pinid's base parameters of apal_leg (axes +y, s = −1) -> seed 000's X (docs/robots.md)."""
    b = base
    return np.array(
        [
            -b["hip.mzR"],
            -b["hip.mx"],
            b["hip.IyyR"] + b["knee.Iyy"],
            b["hip.fc"],
            b["hip.fv"],
            -b["knee.mz"],
            -b["knee.mx"],
            b["knee.Iyy"],
            b["knee.fc"],
            b["knee.fv"],
        ]
    )


def cad_model(truth: RobotModel, percent: float, seed: int) -> RobotModel:
    """The truth with inertias perturbed by ``percent`` % and friction scaled by a factor in [0.5, 1.5]."""
    rng = np.random.default_rng(seed)
    cad = perturb(truth, percent, rng)
    return cad.with_inertial_parameters(
        cad.inertial_parameters(),
        coulomb=truth.coulomb * rng.uniform(0.5, 1.5, 2),
        viscous=truth.viscous * rng.uniform(0.5, 1.5, 2),
    )


def recordings(truth: RobotModel, cad: RobotModel, seconds: float, seed: int) -> tuple[dict, dict]:
    recs, truths = {}, {}
    for k in (1, 2, 3, 4):
        rec, tr = simulate(
            truth, load_trajectory(f"zha2019-{k}", truth), seconds=seconds, seed=100 * seed + k, feedforward_model=cad
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "the low-pass removes most of the hip's variance" (it is fixed)
            recs[k] = prepare(rec, {"preset": "zha2019"})
        truths[k] = tr
    return recs, truths


def lad_segmental(seg: SegmentalProblem) -> np.ndarray:
    x1 = lad(seg.first_problem)
    x2 = lad(seg.second_problem(x1))
    return seg.combine(x1, x2)


def validation_metrics(model, base_values: np.ndarray, ds, joint: str) -> tuple[float, float, float]:
    from pinid.model.base import base_parameters
    from pinid.problem.problem import check_dataset, predict_torque, recorded_torque

    bp = base_parameters(model)
    pred = predict_torque(model, model_terms(), bp, ds, base_values)
    j = model.joint_names.index(joint)
    tau = recorded_torque(check_dataset(ds, model))  # the yardstick: the torque as recorded, as compare()'s
    e = tau[:, j] - pred[:, j]
    return (
        float(np.mean(np.abs(e))),
        float(np.std(np.abs(e))),
        float(100 * np.sqrt(np.mean(e**2) / np.mean(tau[:, j] ** 2))),
    )


def model_terms():
    from pinid import TermSelection

    return TermSelection()


def run(args) -> dict:
    truth_model = RobotModel.from_urdf("apal_leg")
    cad = cad_model(truth_model, 20.0, 0)
    out: dict = {"settings": vars(args).copy(), "realisations": []}
    out["settings"].pop("func", None)
    for r in range(args.realisations):
        t0 = time.perf_counter()
        recs, truths = recordings(truth_model, cad, args.seconds, r)
        t_sim = time.perf_counter() - t0
        truth_base = dict(zip(truths[3]["base"]["names"], truths[3]["base"]["values"]))
        study = Study(
            cad,
            recs[3],
            {"traj2": recs[2], "traj4": recs[4]},
            segmental={"first": recs[1], "joints": ("knee",)},
        )
        runs = {}
        comps = {}
        for variant, fitness, iterations, rls in (
            ("sae", "sae", args.iterations, None),
            ("sae99", "sae", args.iterations, {"forgetting": 0.99}),
            ("sse", "sse", args.iterations, None),
            ("sse10k", "sse", 10_000, None),
        ):
            methods = {"sae": ["ols", "sdp", "rls", "pso", "rls-pso"], "sae99": ["rls-pso"]}.get(
                variant, ["pso", "rls-pso"]
            )
            settings = {"fitness": fitness, "population": args.population, "iterations": iterations}
            if rls:
                settings["rls"] = rls
            comp = compare(study, methods, [r], truth=truths[3], metaheuristic=settings, workers=args.workers)
            comps[variant] = comp
            for m, rs in comp.runs.items():
                key = m if m in ("ols", "sdp", "rls") else f"{m}/{variant}"
                runs[key] = rs[0]
        seg = SegmentalProblem(cad, recs[1], recs[3])
        t1 = time.perf_counter()
        x_lad = lad_segmental(seg)
        t_lad = time.perf_counter() - t1
        from pinid.estimators import make_estimator

        rls_knee = make_estimator("rls").fit(seg.first_problem)
        rls_hip = make_estimator("rls").fit(seg.second_problem(rls_knee.base_))
        rls99_knee = make_estimator("rls", forgetting=0.99).fit(seg.first_problem)
        rls99_hip = make_estimator("rls", forgetting=0.99).fit(seg.second_problem(rls99_knee.base_))
        entry = {
            "seconds_simulation": t_sim,
            "truth_base": truth_base,
            "methods": {},
            "rls_box": {
                "knee": {
                    "names": seg.first_problem.names,
                    "lower": rls_knee.box_[0].tolist(),
                    "upper": rls_knee.box_[1].tolist(),
                },
                "hip": {
                    "names": seg.second_problem(rls_knee.base_).names,
                    "lower": rls_hip.box_[0].tolist(),
                    "upper": rls_hip.box_[1].tolist(),
                },
                "knee99": {
                    "names": seg.first_problem.names,
                    "lower": rls99_knee.box_[0].tolist(),
                    "upper": rls99_knee.box_[1].tolist(),
                },
                "hip99": {
                    "names": seg.first_problem.names,
                    "lower": rls99_hip.box_[0].tolist(),
                    "upper": rls99_hip.box_[1].tolist(),
                },
            },
            "reference": comps["sae"].reference,
        }
        names = comps["sae"].base_names
        for key, run_ in list(runs.items()) + [("lad", None)]:
            if run_ is None:
                base = dict(zip(names, map(float, x_lad)))
                kv = validation_metrics(cad, x_lad, recs[2], "knee")
                hv = validation_metrics(cad, x_lad, recs[4], "hip")
                secs, hist, hist1 = t_lad, None, None
                consistent = None
            else:
                base = dict(zip(names, map(float, run_.base)))
                v2, v4 = run_.validation["traj2"]["per_joint"]["knee"], run_.validation["traj4"]["per_joint"]["hip"]
                kv = (v2["mean_abs"], v2["std_abs"], v2["rel_rms_percent"])
                hv = (v4["mean_abs"], v4["std_abs"], v4["rel_rms_percent"])
                secs, hist, hist1 = run_.seconds, run_.history, run_.history_first
                consistent = run_.physically_consistent
            entry["methods"][key] = {
                "base": base,
                "X": to_paper_x(base).tolist(),
                "knee_traj2": kv,
                "hip_traj4": hv,
                "seconds": secs,
                "history_hip": hist,
                "history_knee": hist1,
                "consistent": consistent,
                "ls_fitness_hip": None if run_ is None else (run_.info.get("second_stage") or {}).get("ls_fitness"),
                "ls_fitness_knee": None if run_ is None else (run_.info.get("first_stage") or {}).get("ls_fitness"),
                "min_fitness_hip": None if run_ is None else (run_.info.get("second_stage") or {}).get("min_fitness"),
                "min_fitness_knee": None if run_ is None else (run_.info.get("first_stage") or {}).get("min_fitness"),
            }
        entry["X_truth"] = to_paper_x(truth_base).tolist()
        out["realisations"].append(entry)
        print(
            f"realisation {r}: simulated in {t_sim:.1f} s, compared in {time.perf_counter() - t0 - t_sim:.1f} s",
            file=sys.stderr,
        )
    return out


# --------------------------------------------------------------------------------------------- reporting
def aggregate(out: dict) -> dict:
    keys = list(out["realisations"][0]["methods"])
    agg = {}
    for k in keys:
        ms = [e["methods"][k] for e in out["realisations"]]
        a = {}
        for what in ("knee_traj2", "hip_traj4"):
            v = np.array([m[what] for m in ms])
            a[what] = {
                "mean_abs": (v[:, 0].mean(), v[:, 0].std()),
                "std_abs": (v[:, 1].mean(), v[:, 1].std()),
                "rel_rms": (v[:, 2].mean(), v[:, 2].std()),
            }
        X = np.array([m["X"] for m in ms])
        a["X"] = (X.mean(axis=0), X.std(axis=0))
        Xt = np.array([e["X_truth"] for e in out["realisations"]])
        a["X_err_percent"] = np.mean(100 * np.abs(X - Xt) / np.abs(Xt), axis=0)
        a["seconds"] = float(np.mean([m["seconds"] for m in ms]))
        a["consistent"] = [m["consistent"] for m in ms]
        agg[k] = a
    return agg


def markdown(out: dict, agg: dict) -> str:
    lines = []
    R = len(out["realisations"])
    lines.append(
        f"Validation torque error, mean ± std of |e| [N·m] (the paper's format), averaged over {R} noise "
        "realisations (± spread of the mean over them); relative RMS [%]:\n"
    )
    lines.append(
        "| method | knee, trajectory 2 (Fig. 10) | knee rel. RMS % | hip, trajectory 4 (Fig. 13) | "
        "hip rel. RMS % | time [s] |"
    )
    lines.append("|---|---|---|---|---|---|")
    for k, a in agg.items():
        kn, hp = a["knee_traj2"], a["hip_traj4"]
        lines.append(
            f"| {md_label(k)} | {kn['mean_abs'][0]:.4f} ± {kn['std_abs'][0]:.4f} (±{kn['mean_abs'][1]:.1g}) "
            f"| {kn['rel_rms'][0]:.2f} | {hp['mean_abs'][0]:.4f} ± {hp['std_abs'][0]:.4f} "
            f"(±{hp['mean_abs'][1]:.1g}) | {hp['rel_rms'][0]:.2f} | {a['seconds']:.2f} |"
        )
    for name, v in PAPER_VALIDATION["knee"].items():
        h = PAPER_VALIDATION["hip"][name]
        lines.append(f"| paper: {name} | {v[0]:.4f} ± {v[1]:.4f} | | {h[0]:.4f} ± {h[1]:.4f} | | |")
    lines.append("")
    lines.append(
        "Identified parameters in the paper's X (mean over realisations), the truth (apal_leg.urdf) "
        "and the paper's Tables 4 and 6:\n"
    )
    keys = list(agg)
    lines.append("| X | truth | " + " | ".join(md_label(k) for k in keys) + " | paper LS | paper PSO | paper RLS-PSO |")
    lines.append("|---" * (len(keys) + 5) + "|")
    Xt = np.mean([e["X_truth"] for e in out["realisations"]], axis=0)
    for i, n in enumerate(X_NAMES):
        row = [n, f"{Xt[i]:.4f}"] + [f"{agg[k]['X'][0][i]:.4f}" for k in keys]
        row += [f"{PAPER_X[p][i]:.4f}" for p in ("LS", "PSO", "RLS-PSO")]
        lines.append("| " + " | ".join(row) + " |")
    lines.append("")
    lines.append("Error against the truth, |X − X_true|/|X_true| [%], mean over realisations:\n")
    lines.append("| X | " + " | ".join(md_label(k) for k in keys) + " |")
    lines.append("|---" * (len(keys) + 1) + "|")
    for i, n in enumerate(X_NAMES):
        lines.append("| " + " | ".join([n] + [f"{agg[k]['X_err_percent'][i]:.2f}" for k in keys]) + " |")
    lines.append("")
    e0 = out["realisations"][0]
    lines.append(
        "RLS boxes (λ = 1, first 10 % of the rows left out), realisation 0, in the paper's X, next to Tables 3 and 5:\n"
    )
    lines.append("| X | RLS box, λ = 1 | RLS box, λ = 0.99 | truth | paper's box |")
    lines.append("|---|---|---|---|---|")
    boxes, boxes99 = {}, {}
    for stage in ("knee", "hip"):
        for target, key in ((boxes, stage), (boxes99, stage + "99")):
            b = e0["rls_box"][key]
            names = b["names"] if stage == "knee" else e0["rls_box"]["hip"]["names"]
            for n, lo, hi in zip(names, b["lower"], b["upper"]):
                target[n] = (lo, hi)
    # map the boxes of pinid's parameters to X where the map is a sign flip (J_t is a sum: not shown)
    sign_map = {
        "M_xt": ("hip.mzR", -1),
        "M_yt": ("hip.mx", -1),
        "f_c1": ("hip.fc", 1),
        "f_v1": ("hip.fv", 1),
        "M_xs": ("knee.mz", -1),
        "M_ys": ("knee.mx", -1),
        "J_s": ("knee.Iyy", 1),
        "f_c2": ("knee.fc", 1),
        "f_v2": ("knee.fv", 1),
    }
    for i, n in enumerate(X_NAMES):
        if n not in sign_map:
            cells = [f"(hip.IyyR {b['hip.IyyR'][0]:.4f}~{b['hip.IyyR'][1]:.4f})" for b in (boxes, boxes99)]
        else:
            p, s = sign_map[n]
            cells = ["{:.4f}~{:.4f}".format(*sorted((s * b[p][0], s * b[p][1]))) for b in (boxes, boxes99)]
        lines.append(
            f"| {n} | {cells[0]} | {cells[1]} | {Xt[i]:.4f} | {PAPER_BOX['lower'][i]}~{PAPER_BOX['upper'][i]} |"
        )
    return "\n".join(lines)


def figures(out: dict, agg: dict, folder: Path) -> list[Path]:
    from pinid.report.figures import new_figure, save_figure

    folder.mkdir(parents=True, exist_ok=True)
    written = []
    keys = [k for k in agg if k != "rls"]
    for joint, what, fig_no in (("knee", "knee_traj2", 10), ("hip", "hip_traj4", 13)):
        fig, ax = new_figure(figsize=(8.5, 3.8))
        labels = [LABELS.get(k, k) for k in keys] + [f"paper {p}" for p in PAPER_VALIDATION[joint]]
        means = [agg[k][what]["mean_abs"][0] for k in keys] + [v[0] for v in PAPER_VALIDATION[joint].values()]
        stds = [agg[k][what]["std_abs"][0] for k in keys] + [v[1] for v in PAPER_VALIDATION[joint].values()]
        colors = ["tab:blue"] * len(keys) + ["lightgrey"] * len(PAPER_VALIDATION[joint])
        x = np.arange(len(labels))
        bars = ax.bar(x, means, 0.7, yerr=stds, capsize=3, color=colors, edgecolor="black", lw=0.5)
        for b, v in zip(bars, means):
            ax.annotate(
                f"{v:.3g}",
                (b.get_x() + b.get_width() / 2, v),
                ha="center",
                va="bottom",
                fontsize="x-small",
                xytext=(0, 1),
                textcoords="offset points",
            )
        ax.set_xticks(x, labels, rotation=30, ha="right", fontsize="small")
        ax.set_ylabel("|τ error|, mean ± std [N·m]")
        ax.set_title(
            f"{joint}: validation on trajectory {2 if joint == 'knee' else 4} (format of seed 000 Fig. {fig_no}); "
            "grey: the paper",
            fontsize="small",
        )
        ax.grid(axis="y", alpha=0.3)
        fig.tight_layout()
        path = folder / f"seed000_errors_{joint}.png"
        save_figure(fig, path)
        written.append(path)
    for joint, fig_no in (("knee", 8), ("hip", 11)):
        fig, axes = new_figure(1, 2, figsize=(10, 3.8))
        for ax, fitness in zip(axes, ("sae", "sse")):
            ls_excess = []
            for k, color in (
                (f"pso/{fitness}", "tab:blue"),
                (f"rls-pso/{fitness}", "tab:cyan"),
                (f"pso/{fitness}10k", "tab:purple"),
                (f"rls-pso/{fitness}10k", "tab:pink"),
            ):
                if k not in LABELS or k not in out["realisations"][0]["methods"]:
                    continue
                for e in out["realisations"]:
                    m = e["methods"][k]
                    h, low, ls = m[f"history_{joint}"], m[f"min_fitness_{joint}"], m[f"ls_fitness_{joint}"]
                    if h and low:
                        ax.plot(np.maximum(np.asarray(h) / low - 1, 1e-12), color=color, lw=0.7, alpha=0.6)
                        ls_excess.append(ls / low - 1)
                ax.plot([], [], color=color, label=LABELS[k])
            if fitness == "sae" and ls_excess:
                ax.axhline(np.median(ls_excess), color="black", ls="--", lw=1, label="least squares")
            ax.set_yscale("log")
            ax.set_xscale("symlog", linthresh=100)
            ax.set_xlim(0, None)
            ax.set_xlabel("iteration")
            ax.set_ylabel(("Σ|r|" if fitness == "sae" else "½Σr²") + " of the best particle / its minimum − 1")
            ax.set_title(
                "minimum: " + ("least absolute deviations" if fitness == "sae" else "least squares"), fontsize="small"
            )
            ax.grid(alpha=0.3, which="both")
            ax.legend(fontsize="x-small")
        fig.suptitle(
            f"{joint} parameters: convergence of the best particle's fitness (cf. seed 000 Fig. {fig_no}); "
            "one line per noise realisation",
            fontsize="small",
        )
        fig.tight_layout()
        path = folder / f"seed000_convergence_{joint}.png"
        save_figure(fig, path)
        written.append(path)
    return written


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--realisations", type=int, default=5)
    p.add_argument("--workers", type=int, default=None, help="local processes per comparison (default: every core)")
    p.add_argument("--seconds", type=float, default=20.0)
    p.add_argument("--population", type=int, default=100)
    p.add_argument("--iterations", type=int, default=1000)
    p.add_argument("--out", default="/tmp/pinid_seed000")
    p.add_argument("--figures", default=None, help="folder for seed000_*.png (e.g. docs/img)")
    p.add_argument("--replot", action="store_true", help="redo tables and figures from --out/results.json")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    if args.replot:
        out = json.loads((Path(args.out) / "results.json").read_text())
    else:
        out = run(args)
    agg = aggregate(out)
    md = markdown(out, agg)
    print(md)
    folder = Path(args.out)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "results.json").write_text(json.dumps(out, indent=1, default=float))
    (folder / "results.md").write_text(md + "\n")
    if args.figures:
        for path in figures(out, agg, Path(args.figures)):
            print(f"wrote {path}", file=sys.stderr)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
