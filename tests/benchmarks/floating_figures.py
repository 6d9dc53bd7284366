"""Figures of docs/floating-base.md: the gait twin's ground reaction (double-support split) and the noisy
identification's held-out residuals against the noise floor.

    python tests/benchmarks/floating_figures.py [--out docs/img]
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from pathlib import Path

import numpy as np

from pinid import RobotModel
from pinid.data.formats import read_recording, write_recording
from pinid.data.preprocess import prepare
from pinid.estimators import make_estimator
from pinid.problem.floating import floating_problem
from pinid.model.terms import TermSelection
from pinid.report.figures import save_figure
from pinid.simulation.floating_twin import Noise, simulate_gait


def main(argv=None) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="docs/img")
    args = p.parse_args(argv)
    out = Path(args.out)
    warnings.simplefilter("ignore")
    model = RobotModel.from_urdf("exo_lower_body", base="floating")
    noise = Noise(2e-5, 0.3, 2.0, 0.2, 0.005, 0.05)
    run = simulate_gait(model, seconds=10, rate=500, noise=noise, seed=1)
    held = simulate_gait(model, seconds=6, rate=500, noise=noise, seed=2, pattern={"period": 1.0, "speed": 0.9})
    s, rec = run.exact, run.recording
    fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    keep = s.data.t <= 2.2
    t = s.data.t[keep]
    for w, colour in zip(s.wrenches, ("tab:blue", "tab:orange")):
        axes[0].plot(t, w.values[keep, 2], colour, label=f"{w.link} (exact)")
        axes[0].plot(
            t, rec.floating.plates[w.link][keep, 2], colour, alpha=0.35, lw=0.8, label=f"{w.link} plate (noisy)"
        )
        axes[1].fill_between(
            t, 0, rec.floating.contacts[w.link][keep], step="mid", color=colour, alpha=0.3, label=f"{w.link} in contact"
        )
    axes[0].set_ylabel("vertical force [N]")
    axes[0].legend(fontsize=8, ncol=2)
    axes[0].set_title("gait twin: ground reaction, the weight moving between the feet in double support")
    axes[1].set_ylabel("contact phase")
    axes[1].set_xlabel("t [s]")
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, out / "floating_gait.png")
    terms = TermSelection.from_names("fc,fv")
    with tempfile.TemporaryDirectory() as tmp:
        samples = [
            prepare(read_recording(write_recording(Path(tmp) / f"{k}.csv", r.recording), model=model))
            for k, r in enumerate((run, held))
        ]
    train = floating_problem(model, samples[0], terms=terms)
    val = floating_problem(model, samples[1], terms=terms, base=train.base)
    sdp = make_estimator("sdp").fit(train)
    names = val.model.joint_names
    floor = [
        np.sqrt(np.mean((val.tau - val.predict(val.nominal_base))[val.joint == j] ** 2)) for j in range(len(names))
    ]
    got = [np.sqrt(np.mean((val.tau - val.predict(sdp.base_))[val.joint == j] ** 2)) for j in range(len(names))]
    fig, ax = plt.subplots(figsize=(8, 3.6))
    x = np.arange(len(names))
    ax.bar(x - 0.2, floor, 0.4, label="true parameters (noise floor)", color="0.7")
    ax.bar(x + 0.2, got, 0.4, label="identified (sdp)", color="tab:green")
    ax.set_xticks(x, names, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("held-out RMS [N·m; base: N and N·m]")
    ax.set_title("walking with force plates, held-out walk: residual per body")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, out / "floating_residuals.png")
    print(f"wrote {out / 'floating_gait.png'}, {out / 'floating_residuals.png'}")
    print("held-out RMS / floor per body:", ", ".join(f"{n} {g / f:.3f}" for n, g, f in zip(names, got, floor)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
