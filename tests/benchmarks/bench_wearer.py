"""Benchmark: the wearer in the loop on the twin (issue 18's figures, docs/wearer.md).

    python tests/benchmarks/bench_wearer.py [--seconds 60] [--seed 0] [--seeds 1] [--wearer-torque 5]
        [--exponents-off 0.2] [--passive-exponents] [--prior-weight LAMBDA|auto]

exo_leg + a 75 kg, 1.78 m male wearer (thigh, shank, foot), the true wearer drawn away from the tables
(mass ±25 %, CoM ±20 %), passive moments on, the wearer's active torque 5 % of the gravity RMS, default
sensor noise.  Prints the validation torque RMS of exo + identified wearer, exo + table wearer and exo
alone against the floor (the true model's RMS), and the tracking RMS of both controllers with each model.
With ``--seeds K`` (K > 1) the experiment runs for seeds ``seed`` … ``seed + K − 1`` (each its own true
wearer, noise and active torque) and prints one line per seed and the median.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from pinid.control.controllers import CONTROLLERS
from pinid.excitation.trajectory import FourierTrajectory
from pinid.model.robot import RobotModel
from pinid.wearer.attach import wearer_urdf
from pinid.wearer.experiment import WearerTrial, wearer_experiment
from pinid.wearer.options import WearerOptions
from pinid.wearer.exponents import perturbed

HERE = Path(__file__).resolve().parents[2]


def tracking_ratio(row: dict) -> float:
    """Tracking RMS with the table wearer over that with the identified one (joints pooled)."""
    return float(np.sqrt(np.mean(row["table"] ** 2) / np.mean(row["identified"] ** 2)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--seeds", type=int, default=1, metavar="K", help="run K seeds from --seed, one line each")
    ap.add_argument(
        "--exponents-off",
        type=float,
        default=0.0,
        metavar="FRACTION",
        help="the true wearer's passive exponents ×(1 ± FRACTION) of the published (default 0)",
    )
    ap.add_argument("--passive-exponents", action="store_true", help="stage 2 also fits the passive exponents")
    ap.add_argument(
        "--prior-weight", default="auto", metavar="LAMBDA|auto", help="stage 2's prior weight (default auto)"
    )
    ap.add_argument("--wearer-torque", type=float, default=5.0, metavar="PCT", help="active torque, %% of gravity RMS")
    args = ap.parse_args()
    from pinid.control.tracking import sine_reference

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "exo_with_wearer.urdf"
        wearer_urdf("exo_leg", "hip:thigh,knee:shank,knee:foot", mass=75, height=1.78, sex="male", path=path)
        exc = FourierTrajectory.load(HERE / "excitation" / "exo_leg.json")
        val = FourierTrajectory.load(HERE / "excitation" / "seed001_table3.json")
        ref = sine_reference(RobotModel.from_urdf(path))
        true = perturbed(RobotModel.from_urdf(path), args.exponents_off) if args.exponents_off else None

        def experiment(seed: int) -> dict:
            return wearer_experiment(
                "exo_leg",
                path,
                exc,
                val,
                ref,
                trial=WearerTrial(
                    seconds=args.seconds, seed=seed, wearer_torque=args.wearer_torque, true_exponents=true
                ),
                options=WearerOptions(
                    passive_exponents=args.passive_exponents,
                    prior_weight="auto" if args.prior_weight == "auto" else float(args.prior_weight),
                ),
            )

        if args.seeds > 1:
            print(f"{args.seconds:g} s identification, {args.seconds / 2:g} s validation; × floor, joints pooled")
            print(
                "| seed | identified | table wearer | exo alone | tracking table/identified ("
                + ", ".join(CONTROLLERS)
                + ") |"
            )
            print("|---|---|---|---|---|")
            rows = []
            for seed in range(args.seed, args.seed + args.seeds):
                r = experiment(seed)
                track = [tracking_ratio(r["tracking"][c]) for c in CONTROLLERS]
                rows.append([r["ratio"]["identified"], r["ratio"]["table"], r["ratio"]["exo"], *track])
                cells = [f"{x:.2f}×" for x in rows[-1]]
                print(f"| {seed} | {cells[0]} | {cells[1]} | {cells[2]} | {', '.join(cells[3:])} |", flush=True)
            med = [f"{x:.2f}×" for x in np.median(rows, axis=0)]
            print(f"| median | {med[0]} | {med[1]} | {med[2]} | {', '.join(med[3:])} |")
            print(f"{time.perf_counter() - t0:.1f} s")
            return
        r = experiment(args.seed)
    j = r["joints"]
    print(
        f"validation torque RMS [N·m] ({args.seconds:g} s identification, {args.seconds / 2:g} s validation, seed {args.seed})"
    )
    print(f"  {'model':<22}" + "".join(f"{x:>10}" for x in j) + f"{'× floor':>10}")
    print(f"  {'floor (true model)':<22}" + "".join(f"{x:10.4f}" for x in r["floor"]) + f"{1.0:10.3f}")
    for w in ("identified", "table", "exo"):
        print(
            f"  {'exo + ' + w if w != 'exo' else 'exo alone':<22}"
            + "".join(f"{x:10.4f}" for x in r["rms"][w])
            + f"{r['ratio'][w]:10.3f}"
        )
    print("tracking RMS [mrad] after 2 s")
    for c in CONTROLLERS:
        row = r["tracking"][c]
        print(
            f"  {c:<16}"
            + "  ".join(f"{w} " + "/".join(f"{1e3 * x:.3g}" for x in row[w]) for w in row)
            + f"   table/identified {tracking_ratio(row):.2f}×"
        )
    print(
        "base parameters (identified | table): "
        + ", ".join(f"{n} {a:.4g}|{b:.4g}" for n, a, b in zip(r["fit"].base_names, r["fit"].base, r["fit"].base_table))
    )
    e = r["fit"].exponents
    if e is not None:
        print(
            f"passive exponents: {e.evaluations} evaluations, {e.seconds:.2f} s; training RMS {e.rms_published:.4g} -> "
            f"{e.rms_fitted:.4g} N·m; stage 2 {r['fit'].seconds:.2f} s"
        )
    print(f"{time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
