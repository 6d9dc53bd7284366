"""Benchmark: does ``--cutoff auto`` pick a cut-off as good as the best fixed one?  (issue 34, item 1)

    python tests/benchmarks/bench_cutoff.py                     # twin 200 Hz, 1 kHz, 5 kHz + real recordings
    python tests/benchmarks/bench_cutoff.py --cases twin-5k     # one case
    python tests/benchmarks/bench_cutoff.py --cases twin-200,twin-5k --seconds 10,60   # short and long (issue 44)

For every case, OLS with the case's terms is run once per fixed cut-off of the candidate grid
(:data:`pinid.identification.cutoff.GRID_HZ`, those the sample rate carries) and once with ``cutoff="auto"``;
each is scored on the case's **validation** recording against the torque as recorded (pooled relative
RMS).  The best fixed cut-off is an oracle (it looks at the validation recording); auto never does.  The
table gives the best fixed cut-off, auto's choice, their ratio (the issue asks for a factor ≤ 2), and the
validation errors at the best fixed cut-off, at auto's choice and at the default (10 Hz or fs/10).

Cases: the exo_leg twin (1 % torque noise, 16-bit encoders) sampled at 200 Hz, 1 kHz and 5 kHz (training
on the designed excitation, 20 s; validation on seed 001's Table 3 trajectory, 10 s); the DFKI double
pendulum (trajectory 02 → 03, ``docs/examples/double_pendulum.toml``); the KUKA LBR Med 7 (first 70 % of
``mext.csv`` → last 30 %, ``--terms fc,fv,offset``).  Real recordings are skipped when absent.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

from conftest import shared_data  # noqa: E402

import pinid  # noqa: E402
from pinid.data.dataset import Dataset  # noqa: E402
from pinid.data.formats import read_recording  # noqa: E402
from pinid.identification.cutoff import candidate_cutoffs  # noqa: E402
from pinid.model.terms import as_terms  # noqa: E402


def twin(folder: Path, rate: int, train_seconds: float = 20) -> tuple[Path, Path]:
    """Training (``train_seconds`` long) and validation recordings of the exo_leg twin sampled at ``rate`` [Hz]."""
    out = []
    for name, exc, seconds, seed in (("train", "exo_leg", train_seconds, 0), ("val", "seed001_table3", 10, 1)):
        path = folder / f"{name}_{rate}_{seconds:g}s.csv"
        if not path.exists():
            cmd = [sys.executable, "-m", "pinid.cli", "simulate", "--urdf", "exo_leg", "--excitation", exc]
            cmd += ["--seconds", str(seconds), "--seed", str(seed), "--sample-rate", str(rate), "-o", str(path)]
            if rate > 1000:
                cmd += ["--control-rate", str(rate), "--integration-rate", str(rate)]
            subprocess.run([*cmd, "--no-progress"], check=True, stdout=subprocess.DEVNULL)
        out.append(path)
    return out[0], out[1]


def split(ds: Dataset, fraction: float) -> tuple[Dataset, Dataset]:
    """The first ``fraction`` of a recording and the rest."""
    k = int(round(fraction * ds.n))
    return ds.select(slice(0, k)), ds.select(slice(k, ds.n))


def cases(folder: Path, wanted: list[str], seconds=(20.0,)) -> list[tuple[str, str, object, object, str, object]]:
    """``(name, urdf, train, validate, terms, mapping)`` of each case asked for that can run here; the twins'
    training recordings ``seconds`` long (each length a case of its own)."""
    out = []
    for rate, name in ((200, "twin-200"), (1000, "twin-1k"), (5000, "twin-5k")):
        if name in wanted:
            for sec in seconds:
                label = name if tuple(seconds) == (20.0,) else f"{name} {sec:g} s"
                out.append((label, "exo_leg", *twin(folder, rate, sec), "fc,fv", None))
    data = shared_data()
    dp = data / "double_pendulum"
    if "double-pendulum" in wanted and dp.is_dir():
        mapping = str(ROOT / "docs/examples/double_pendulum.toml")
        out.append(
            (
                "double-pendulum",
                str(dp / "double_pendulum.urdf"),
                str(dp / "trajectory_02.csv"),
                str(dp / "trajectory_03.csv"),
                "fc,fv",
                mapping,
            )
        )
    kuka = data / "kuka_med7"
    if "kuka" in wanted and kuka.is_dir():
        model = pinid.RobotModel.from_urdf(str(kuka / "robot.urdf"))
        ds = read_recording(str(kuka / "mext.csv"), model=model)
        train, val = split(ds, 0.7)
        out.append(("kuka-70/30", str(kuka / "robot.urdf"), train, val, "fc,fv,offset", None))
    return out


def score(urdf, train, val, terms, mapping, cutoff) -> tuple[float, float | None]:
    """Validation pooled relative RMS [%] against the torque as recorded, and the cut-off used."""
    ident = pinid.identify(
        pinid.Study(urdf, train, validate=val, terms=as_terms(terms), mapping=mapping, preprocess={"cutoff": cutoff}),
        methods="ols",
    )
    chosen = ident.data.get("cutoff", {}).get("cutoff_hz", cutoff)
    return float(ident.results["ols"].validation.all["rel_rms_percent"]), chosen


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    names = ["twin-200", "twin-1k", "twin-5k", "double-pendulum", "kuka"]
    ap.add_argument("--cases", default=",".join(names), help=f"comma-separated, from {', '.join(names)}")
    ap.add_argument("--folder", default=None, help="where the twin recordings are kept (default a temporary one)")
    ap.add_argument("--seconds", default="20", help="the twins' training durations [s], comma-separated (10,60)")
    args = ap.parse_args()
    seconds = tuple(float(x) for x in args.seconds.split(","))
    folder = Path(args.folder or tempfile.mkdtemp(prefix="bench_cutoff_"))
    folder.mkdir(parents=True, exist_ok=True)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; recordings in {folder}")
    rows = []
    for name, urdf, train, val, terms, mapping in cases(folder, args.cases.split(","), seconds):
        t0 = time.perf_counter()
        rate = (train if isinstance(train, Dataset) else read_recording(train, mapping=mapping)).sample_rate
        fixed = {}
        for c in candidate_cutoffs(rate):
            try:
                fixed[c] = score(urdf, train, val, terms, mapping, c)[0]
            except pinid.PinidError as exc:  # a cut-off the recording is too short for
                print(f"  {name}: {c:g} Hz skipped ({exc})")
        t1 = time.perf_counter()
        auto, chosen = score(urdf, train, val, terms, mapping, "auto")
        t_auto = time.perf_counter() - t1
        default = min(10.0, rate / 10)
        best = min(fixed, key=fixed.get)
        at_default = fixed.get(default) if default in fixed else score(urdf, train, val, terms, mapping, default)[0]
        ratio = max(chosen, best) / min(chosen, best)
        rows.append((name, rate, best, fixed[best], chosen, auto, ratio, default, at_default, t_auto, t1 - t0))
        print(f"  {name}: validation % per fixed cut-off: " + ", ".join(f"{c:g} Hz {e:.3g}" for c, e in fixed.items()))
        print(f"  {name}: done in {time.perf_counter() - t0:.0f} s", flush=True)
    print()
    print(
        "| case | fs [Hz] | best fixed [Hz] | its valid. % | auto [Hz] | its valid. % | ratio | default [Hz] "
        "| its valid. % | auto's time [s] |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, rate, best, e_best, chosen, e_auto, ratio, default, e_def, t_auto, _ in rows:
        print(
            f"| {name} | {rate:.0f} | {best:g} | {e_best:.3g} | {chosen:g} | {e_auto:.3g} | {ratio:.2g} | "
            f"{default:g} | {e_def:.3g} | {t_auto:.1f} |"
        )
    bad = [r[0] for r in rows if r[6] > 2 and r[5] > 1.05 * r[3]]
    if bad:
        print(f"auto is more than a factor 2 from the best fixed cut-off and 5 % worse on: {', '.join(bad)}")
    print(f"(valid. %: pooled relative RMS against the torque as recorded; {np.__name__} {np.__version__})")


if __name__ == "__main__":
    main()
