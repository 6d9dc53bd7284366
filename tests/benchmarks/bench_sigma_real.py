"""Benchmark: the printed σ against the spread over disjoint segments of real recordings (issue 33).

    python tests/benchmarks/bench_sigma_real.py [--segments 5]

For each real recording (the DFKI double pendulum's trajectories 00–03 and 11–13, the KUKA LBR Med 7's
mext.csv), ols is fitted on the whole recording (σ as pinid prints it) and on each of K disjoint, contiguous
segments.  A segment holds 1/K of the samples, so if σ is right the spread (standard deviation) of the
segment estimates is about √K·σ.  Printed per recording: the median over the base parameters of
σ_printed / (spread / √K), for the Newey–West σ and for the white-noise σ — 1 is calibrated, below 1
optimistic.  The segments differ in motion, so their spread also holds model error that a stationary noise
model does not: a ratio somewhat below 1 is expected even of a right σ.
"""

from __future__ import annotations

import argparse
from pinid.identification.study import Study
import functools
import os
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from conftest import shared_data  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def recordings():
    from pinid import RobotModel
    from pinid.data.formats import read_recording

    dp = shared_data() / "double_pendulum"
    model = RobotModel.from_urdf(dp / "double_pendulum.urdf")
    spec = ROOT / "docs" / "examples" / "double_pendulum.toml"
    for nn in ("00", "01", "02", "03", "11", "12", "13"):
        yield f"double pendulum {nn}", model, read_recording(dp / f"trajectory_{nn}.csv", mapping=spec, model=model)
    kuka = shared_data() / "kuka_med7"
    model = RobotModel.from_urdf(kuka / "robot.urdf")
    yield "KUKA mext", model, read_recording(kuka / "mext.csv", model=model)


def ratio(model, ds, k: int, kind: str) -> float:
    import pinid.identification.result as result_module
    from pinid import identify
    from pinid.problem.statistics import base_statistics

    result_module.base_statistics = functools.partial(base_statistics, kind=kind)
    whole = identify(Study(model, ds), methods=["ols"], complete=False)["ols"]
    edges = np.linspace(0, ds.n, k + 1).astype(int)
    parts = np.array(
        [
            identify(Study(model, ds.select(slice(a, b))), methods=["ols"], complete=False)["ols"].base
            for a, b in zip(edges[:-1], edges[1:])
        ]
    )
    spread = parts.std(axis=0, ddof=1) / np.sqrt(k)
    ok = np.isfinite(whole.std) & (spread > 0)
    return float(np.median(whole.std[ok] / spread[ok]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--segments", type=int, default=5)
    a = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    print(f"median over base parameters of σ_printed / (spread of {a.segments} segment fits / √{a.segments})\n")
    print("| recording | Newey–West σ (printed) | white σ |")
    print("|---|---|---|")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for name, model, ds in recordings():
            hac, white = (ratio(model, ds, a.segments, kind) for kind in ("hac", "white"))
            print(f"| {name} | {hac:.2f} | {white:.2f} |", flush=True)


if __name__ == "__main__":
    main()
