"""Benchmark (issue 28): the real-data estimators against the truth (twin) and on real recordings.

    python tests/benchmarks/bench_real_data_estimators.py                  # both parts, 20 seeds
    python tests/benchmarks/bench_real_data_estimators.py --seeds 5 --twin # the Monte-Carlo part only
    python tests/benchmarks/bench_real_data_estimators.py --real           # the double pendulum only

1. **Monte Carlo on the twin.**  ``pinid.simulation.twin.simulate`` runs the exo_leg (URDF inertias, Coulomb
   0.3 N·m and viscous 0.05 N·m·s/rad per joint) in closed loop (PD, 4 Hz, model feed-forward, 1 kHz
   control) on the bundled ``exo_leg`` excitation, recorded at 200 Hz for 10 s: 16-bit encoder plus
   Gaussian position noise ``σ_q``, torque noise 1 % of each joint's peak.  Two noise levels on q:
   "realistic" (σ_q = 2e-5 rad, the twin's default) and "noisy q" (σ_q = 1e-3 rad: a potentiometer, or a
   motor encoder behind a compliant gear) — in closed loop the PD feeds that noise back into the
   recorded torque (K_p·σ_q ≈ 0.5 N·m at the hip); and "open-loop noisy q": the exact motion of the same
   trajectory, exact inverse-dynamics torque plus 1 % noise, σ_q = 1e-3 rad on the recorded q only (the
   errors-in-variables case IV and DIDIM are meant for).  Each seed is a new recording (same trajectory); the default
   preprocessing (10 Hz zero-phase low-pass, Savitzky–Golay derivatives) makes dq and ddq.  Every
   estimator runs on the same problem.  Bias and spread of each base parameter, relative to its natural
   magnitude (the errors of tests/identification/test_identification.py::relative_errors), over the seeds.  Validation:
   the seed001_table3 trajectory (another seed, same noise), scored against the *raw recorded* torque:
   predictions on the prepared samples (same grid as the recording, trimmed ends left out) compared with
   the torque as recorded at those instants.
2. **Real double pendulum** (``../shared/data/double_pendulum``, ``$PINID_SHARED_DATA``): trains on
   trajectory_02, validates on trajectory_03 (as tests/identification/test_identification.py::test_real_double_pendulum_recordings),
   mapping docs/examples/double_pendulum.toml, default preprocessing.  Scored against the raw measured
   torque: the prediction (on the prepared, resampled grid) is interpolated linearly onto the recorded
   time stamps inside the prepared span, and compared with the torque as recorded there.

Prints Markdown tables (and writes docs/img/real_data_estimators_bias.png with ``--plot``).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from pinid import TermSelection, RobotModel, base_parameters, standard_parameters
from pinid.data.dataset import Dataset
from pinid.data.formats import read_recording
from pinid.estimators import make_estimator
from pinid.problem.problem import IdentificationProblem, predict_torque
from pinid.problem.recordings import free_angles, prepare_dataset
from pinid.model.physical import parameter_scale
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import simulate

ROOT = Path(__file__).resolve().parents[2]
METHODS = ["ols", "wls", "sdp", "iv", "didim", "tls", "irls"]
#: scenario -> (σ_q [rad], closed loop?)
SCENARIOS = {"realistic": (2e-5, True), "noisy q": (1e-3, True), "open-loop noisy q": (1e-3, False)}


def shared_data() -> Path:
    for c in (os.environ.get("PINID_SHARED_DATA"), ROOT.parent / "shared" / "data", "/work/shared/data"):
        if c and (Path(c) / "double_pendulum").is_dir():
            return Path(c)
    raise SystemExit("double pendulum recordings not found (set PINID_SHARED_DATA)")


def raw_score(pred_t, pred, raw_t, raw_tau) -> tuple[np.ndarray, np.ndarray]:
    """Per joint: RMS [N·m] and % of the raw torque's RMS, the prediction interpolated onto the raw samples."""
    inside = (raw_t >= pred_t[0]) & (raw_t <= pred_t[-1])
    p = np.column_stack([np.interp(raw_t[inside], pred_t, pred[:, j]) for j in range(pred.shape[1])])
    err = raw_tau[inside] - p
    rms = np.sqrt(np.mean(err**2, axis=0))
    return rms, 100 * rms / np.sqrt(np.mean(raw_tau[inside] ** 2, axis=0))


def fit_all(problem, methods):
    out, seconds = {}, {}
    for m in methods:
        t0 = time.perf_counter()
        try:
            out[m] = make_estimator(m).fit(problem)
        except Exception as exc:  # a failing method is reported, not fatal
            out[m] = exc
        seconds[m] = time.perf_counter() - t0
    return out, seconds


def twin_model() -> RobotModel:
    m = RobotModel.from_urdf("exo_leg")
    return m.with_inertial_parameters(m.inertial_parameters(), coulomb=np.full(m.nv, 0.3), viscous=np.full(m.nv, 0.05))


def open_loop(model, trajectory, seconds: float, seed: int, sq: float):
    """A recording of the exact motion of ``trajectory`` at 200 Hz: q + N(0, σ_q) quantised to 16 bits, exact
    inverse-dynamics torque (sign friction) + 1 % of each joint's peak as Gaussian noise; no controller, so
    the position noise does not enter the torque."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * 200)) / 200
    q, dq, ddq = trajectory.for_joints(model.joint_names, model.name).evaluate(t)
    tau = model.rnea(q, dq, ddq) + model.coulomb * np.sign(dq) + model.viscous * dq
    tau = tau + rng.normal(size=tau.shape) * 0.01 * np.abs(tau).max(axis=0)
    res = 2 * np.pi / 2**16
    qm = np.round((q + rng.normal(0, sq, q.shape)) / res) * res
    return Dataset(t, qm, model.joint_names, tau=tau, source=f"open loop {seed}")


def monte_carlo(seeds: int, methods, scenarios, seconds: float = 10.0):
    model = twin_model()
    train_tr, valid_tr = load_trajectory("exo_leg", model), load_trajectory("seed001_table3", model)
    unwrap = free_angles(model)
    truth_base = base_parameters(model, TermSelection()).from_standard(standard_parameters(model, TermSelection()))
    results = {}
    for scen in scenarios:
        sq, closed = SCENARIOS[scen]
        errs = {m: [] for m in methods}
        val = {m: [] for m in methods}
        secs = {m: 0.0 for m in methods}
        fails = {m: 0 for m in methods}
        for s in range(seeds):
            opts = dict(seconds=seconds, sample_rate=200, control_rate=1000, position_noise=sq)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if closed:
                    rec, truth = simulate(model, train_tr, seed=s, **opts)
                    vrec, _ = simulate(model, valid_tr, seed=10_000 + s, **opts)
                else:
                    rec, vrec = (
                        open_loop(model, train_tr, seconds, s, sq),
                        open_loop(model, valid_tr, seconds, 10_000 + s, sq),
                    )
                    truth = {"base": {"names": base_parameters(model, TermSelection()).names, "values": truth_base}}
                train = prepare_dataset(rec, {}, unwrap=unwrap)
                valid = prepare_dataset(vrec, {}, unwrap=unwrap)
            problem = IdentificationProblem.from_datasets(model, train)
            true = np.array(truth["base"]["values"])
            assert truth["base"]["names"] == problem.names
            scale = np.abs(problem.base.P) @ parameter_scale(problem.nominal, model.nv, len(problem.terms))
            norm = np.maximum(np.abs(true), scale)
            fits, sec = fit_all(problem, methods)
            for m in methods:
                secs[m] += sec[m]
                if isinstance(fits[m], Exception):
                    fails[m] += 1
                    continue
                errs[m].append((fits[m].base_ - true) / norm)
                pred = predict_torque(model, problem.terms, problem.base, valid, fits[m].base_)
                val[m].append(raw_score(valid.t, pred, vrec.t, vrec.tau)[1])
            print(f"  {scen} seed {s} done", file=sys.stderr, flush=True)
        results[scen] = (errs, val, secs, fails, problem.names)
    return results


def print_monte_carlo(results, seeds):
    for scen, (errs, val, secs, fails, names) in results.items():
        print(f"\n### Twin, {scen} (σ_q = {SCENARIOS[scen][0]:g} rad), {seeds} seeds\n")
        print(
            "| method | mean abs bias [%] | max abs bias [%] | mean spread [%] | max spread [%] | RMSE [%] "
            "| validation vs raw τ [%] (joints) | fit time [s] | failed |"
        )
        print("|---|---|---|---|---|---|---|---|---|")
        for m, e in errs.items():
            if not e:
                print(f"| {m} | – | – | – | – | – | – | {secs[m] / seeds:.2f} | {fails[m]} |")
                continue
            E = 100 * np.array(e)
            bias, spread = np.abs(E.mean(axis=0)), E.std(axis=0, ddof=1) if len(E) > 1 else np.zeros(E.shape[1])
            rmse = np.sqrt(np.mean(E**2))
            v = np.mean(val[m], axis=0)
            print(
                f"| {m} | {bias.mean():.3f} | {bias.max():.3f} | {spread.mean():.3f} | {spread.max():.3f} | "
                f"{rmse:.3f} | {' / '.join(f'{x:.3f}' for x in v)} | {secs[m] / seeds:.2f} | {fails[m]} |"
            )
        print("\nPer base parameter, bias ± spread [% of its natural magnitude]:\n")
        print("| method | " + " | ".join(names) + " |")
        print("|---|" + "---|" * len(names))
        for m, e in errs.items():
            if e:
                E = 100 * np.array(e)
                cells = [f"{b:+.2f} ± {s:.2f}" for b, s in zip(E.mean(axis=0), E.std(axis=0, ddof=1))]
                print(f"| {m} | " + " | ".join(cells) + " |")


def plot(results, path):
    from pinid.report.figures import new_figure, save_figure

    fig, axes = new_figure(len(results), 1, figsize=(9, 3.2 * len(results)))
    axes = np.atleast_1d(axes)
    for ax, (scen, (errs, _, _, _, names)) in zip(axes, results.items()):
        ms = [m for m in errs if errs[m]]
        x = np.arange(len(names))
        for i, m in enumerate(ms):
            E = 100 * np.array(errs[m])
            off = (i - (len(ms) - 1) / 2) * 0.8 / len(ms)
            ax.errorbar(x + off, E.mean(axis=0), yerr=E.std(axis=0, ddof=1), fmt="o", ms=3, capsize=2, label=m)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xticks(x, names, rotation=30, fontsize=7)
        ax.set_ylabel("error [% of magnitude]")
        ax.set_title(f"twin, {scen} (σ_q = {SCENARIOS[scen][0]:g} rad): bias ± spread over seeds", fontsize=9)
        ax.legend(fontsize=7, ncol=len(ms))
    fig.tight_layout()
    save_figure(fig, path)


def real(methods):
    data = shared_data() / "double_pendulum"
    spec = ROOT / "docs" / "examples" / "double_pendulum.toml"
    model = RobotModel.from_urdf(data / "double_pendulum.urdf")
    unwrap = free_angles(model)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        raw_train = read_recording(data / "trajectory_02.csv", mapping=spec, model=model)
        raw_valid = read_recording(data / "trajectory_03.csv", mapping=spec, model=model)
        train = prepare_dataset(raw_train, {}, unwrap=unwrap)
        valid = prepare_dataset(raw_valid, {}, unwrap=unwrap)
    problem = IdentificationProblem.from_datasets(model, train)
    fits, secs = fit_all(problem, methods)
    print("\n### Real double pendulum: train trajectory_02, validate trajectory_03, against the raw torque\n")
    print(
        "| method | train RMS vs raw τ [N·m] (J1 / J2) | train [%] | validation RMS vs raw τ [N·m] | validation [%] "
        "| fit time [s] | status |"
    )
    print("|---|---|---|---|---|---|---|")
    for m in methods:
        f = fits[m]
        if isinstance(f, Exception):
            print(f"| {m} | – | – | – | – | {secs[m]:.2f} | failed: {str(f)[:80]} |")
            continue
        cells = []
        for prep, raw in ((train, raw_train), (valid, raw_valid)):
            pred = predict_torque(model, problem.terms, problem.base, prep, f.base_)
            rms, pct = raw_score(prep.t, pred, raw.t, raw.tau)
            cells += [" / ".join(f"{x:.4f}" for x in rms), " / ".join(f"{x:.1f}" for x in pct)]
        print(f"| {m} | {' | '.join(cells)} | {secs[m]:.2f} | {f.status_[:60]} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--twin", action="store_true", help="only the Monte-Carlo study on the twin")
    ap.add_argument("--real", action="store_true", help="only the real double pendulum")
    ap.add_argument("--plot", default=None, help="write the bias/spread figure here (PNG)")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--scenarios", default=",".join(SCENARIOS), help=f"some of: {', '.join(SCENARIOS)}")
    a = ap.parse_args()
    methods = a.methods.split(",")
    print(
        f"machine: {platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}, "
        f"load average at start {os.getloadavg()[0]:.2f}; command: python {' '.join(sys.argv)}"
    )
    t0 = time.perf_counter()
    if not a.real:
        res = monte_carlo(a.seeds, methods, [x.strip() for x in a.scenarios.split(",")])
        print_monte_carlo(res, a.seeds)
        if a.plot:
            plot(res, a.plot)
    if not a.twin:
        real(methods)
    print(f"\nwall time {time.perf_counter() - t0:.0f} s, load average at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
