"""Benchmark: coverage of the printed σ on the twin (issue 33; docs/identification.md "How σ is computed").

    python tests/benchmarks/bench_coverage.py [--seeds 20] [--seconds 20] [--jobs 2]

For each seed and each loop setting — "closed" (the default: PD at 4 Hz bandwidth plus model
feed-forward) and "feedback" (``--feedforward none``: the loop alone tracks) — ``pinid simulate`` writes
an exo_leg recording with the default noise, ``pinid.identify`` fits ols, wls and sdp with the truth, and
the share of base parameters whose true value lies within ±2σ is counted: with the Newey–West σ pinid
prints, and (for contrast, the same fits) with the white-noise σ²(WᵀW)⁻¹ it printed before.
Target for ±2σ: 90–98 %.  Prints a Markdown table, then a second one that splits what σ must cover: per
method and loop, the seed-to-seed spread of the signed errors over the mean printed σ (1 = σ calibrated to the
noise) and the largest |t| of the mean signed error over the seeds (a deterministic bias, the same in every
seed, which no noise covariance can hold; |t| > 3 is a bias).
"""

from __future__ import annotations

import argparse
from pinid.identification.study import Study
import functools
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

LOOPS = {"closed": [], "feedback": ["--feedforward", "none"]}
METHODS = ["ols", "wls", "sdp"]


def one(seed: int, loop: str, seconds: float, folder: str) -> dict:
    import pinid.identification.result as result_module
    from pinid import identify
    from pinid.problem.statistics import base_statistics

    csv = Path(folder) / f"{loop}_{seed}.csv"
    cmd = [sys.executable, "-m", "pinid.cli", "simulate", "--urdf", "exo_leg", "--excitation", "exo_leg"]
    cmd += ["--seconds", str(seconds), "--seed", str(seed), "-o", str(csv), *LOOPS[loop]]
    subprocess.run(cmd, check=True, capture_output=True)
    truth = str(csv.with_suffix(".truth.json"))
    out = {}
    signed = {}
    for kind in ("hac", "white"):
        result_module.base_statistics = functools.partial(base_statistics, kind=kind)
        ident = identify(Study("exo_leg", str(csv)), methods=METHODS, truth=truth, complete=False)
        for m in METHODS:
            r = ident[m]
            err = np.array([r.truth_error["error"][n] for n in r.base_names])
            std = r.std
            ok = np.isfinite(std)
            if kind == "hac":
                truth_values = np.array([r.truth_error["truth"][n] for n in r.base_names])
                signed[m] = (np.asarray(r.base) - truth_values, std, list(r.base_names))
            out[(kind, m)] = (
                int(np.sum(np.abs(err[ok]) <= 2 * std[ok])),
                int(ok.sum()),
                float(np.median(np.abs(err[ok]) / std[ok])),
            )
    out["signed"] = signed
    return out


def _bias_table(res: dict) -> None:
    """Per loop and method: seed spread / mean σ (median over parameters) and the largest |t| of the bias."""
    print()
    print(
        "| loop | method | spread of signed errors / mean σ (median over parameters) | largest \\|t\\| of the mean error (parameter) |"
    )
    print("|---|---|---|---|")
    for loop in LOOPS:
        for m in METHODS:
            pairs = [v["signed"][m] for (s, lp), v in res.items() if lp == loop]
            err = np.array([p[0] for p in pairs])
            std = np.array([p[1] for p in pairs])
            spread = err.std(axis=0, ddof=1)
            ratio = float(np.nanmedian(spread / np.nanmean(std, axis=0)))
            t = np.abs(err.mean(axis=0)) / (spread / np.sqrt(len(err)))
            k = int(np.nanargmax(t))
            print(f"| {loop} | {m} | {ratio:.2f} | {t[k]:.1f} ({pairs[0][2][k]}) |")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args()
    t0 = time.perf_counter()
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as folder, ProcessPoolExecutor(a.jobs) as pool:
        jobs = {
            (s, loop): pool.submit(one, s, loop, a.seconds, folder) for s in range(1, a.seeds + 1) for loop in LOOPS
        }
        res = {k: f.result() for k, f in jobs.items()}
    print(
        f"{a.seeds} seeds × {len(LOOPS)} loop settings, {a.seconds:g} s each; load average at start {load:.1f}; "
        f"{time.perf_counter() - t0:.0f} s"
    )
    print(
        "| loop | method | within ±2σ, Newey–West (printed) | within ±2σ, white (before) | median \\|error\\|/σ NW | median \\|error\\|/σ white |"
    )
    print("|---|---|---|---|---|---|")
    for loop in [*LOOPS, "both"]:
        for m in METHODS:
            cells = []
            for kind in ("hac", "white"):
                vals = [v[(kind, m)] for (s, lp), v in res.items() if loop in (lp, "both")]
                hit, n = sum(v[0] for v in vals), sum(v[1] for v in vals)
                cells.append((hit, n, float(np.median([v[2] for v in vals]))))
            (h1, n1, r1), (h2, n2, r2) = cells
            print(
                f"| {loop} | {m} | {100 * h1 / n1:.1f} % ({h1}/{n1}) | {100 * h2 / n2:.1f} % ({h2}/{n2}) | {r1:.2f} | {r2:.2f} |"
            )
    _bias_table(res)


if __name__ == "__main__":
    main()
