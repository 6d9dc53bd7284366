"""Benchmark: pinid.data.filters against scipy.signal — time and agreement (issue 17).

    python tests/benchmarks/bench_filters.py [--samples 60000] [--columns 6] [--repeat 20]

Signals: sines on offsets plus noise, ``--samples`` × ``--columns``.  Timed, best of ``--repeat``, in
this process (imports excluded): the Butterworth design, the zero-phase filter (order 4 at 10 Hz and
1 Hz for 5 kHz, padded as prepare() pads: over the settling time), Savitzky–Golay derivatives of the
windows prepare() uses at 1 kHz (61) and 5 kHz (301) and a short one (9), and prepare() itself on a
5 kHz recording (q and tau of ``--columns`` joints).  "max diff" is relative to the signal's largest
value; scipy's Savitzky–Golay weights lose digits on long windows (see pinid.data.filters).  Prints a
Markdown table with ``nproc``, the CPU model and the load average.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
from pathlib import Path

import numpy as np
from scipy import signal

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_metaheuristics import best_time  # noqa: E402

import pinid.data.preprocess as preprocess  # noqa: E402
from pinid.data.dataset import Dataset  # noqa: E402
from pinid.data.filters import butter_sos, filtfilt_sos, savgol  # noqa: E402


def scipy_prepare(ds: Dataset) -> Dataset:
    """prepare() through scipy.signal, as before issue 17."""
    saved = preprocess.butter_sos, preprocess.filtfilt_sos, preprocess.savgol
    preprocess.butter_sos = lambda order, cutoff, fs: signal.butter(order, cutoff, fs=fs, output="sos")
    preprocess.filtfilt_sos = lambda sos, a, pad: signal.sosfiltfilt(sos, a, axis=0, padlen=pad)
    preprocess.savgol = lambda a, w, p, deriv, delta: signal.savgol_filter(a, w, p, deriv=deriv, delta=delta, axis=0)
    try:
        return preprocess.prepare(ds)
    finally:
        preprocess.butter_sos, preprocess.filtfilt_sos, preprocess.savgol = saved


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=60_000)
    p.add_argument("--columns", type=int, default=6)
    p.add_argument("--repeat", type=int, default=20)
    args = p.parse_args(argv)
    n, m, fs = args.samples, args.columns, 5000.0
    rng = np.random.default_rng(0)
    t = np.arange(n) / fs
    x = np.column_stack([(j + 1) * np.sin(2 * np.pi * 0.3 * (j + 1) * t) + 0.5 * j for j in range(m)])
    x += 0.01 * rng.normal(size=x.shape)
    scale = np.max(np.abs(x))
    rows = []

    def row(name, ours, theirs):
        diff = np.max(np.abs(np.asarray(ours()) - np.asarray(theirs()))) / np.max(np.abs(np.asarray(theirs())))
        a, b = best_time(ours, args.repeat), best_time(theirs, args.repeat)
        rows.append(f"| {name} | {1e3 * a:.2f} | {1e3 * b:.2f} | {b / a:.2f} | {diff:.1e} |")

    row("butter order 4", lambda: butter_sos(4, 10.0, fs), lambda: signal.butter(4, 10.0, fs=fs, output="sos"))
    for order, cutoff in ((4, 10.0), (4, 1.0), (2, 10.0), (8, 10.0)):
        sos = signal.butter(order, cutoff, fs=fs, output="sos")
        pad = int(np.ceil(preprocess.default_trim(fs, cutoff, order) * fs))
        row(
            f"filtfilt order {order}, {cutoff:g} Hz, pad {pad}",
            lambda: filtfilt_sos(sos, x, pad),
            lambda: signal.sosfiltfilt(sos, x, axis=0, padtype="odd", padlen=pad),
        )
    for window in (9, 61, 301):
        for deriv in (1, 2):
            row(
                f"savgol window {window}, deriv {deriv}",
                lambda: savgol(x, window, 5, deriv, 1 / fs) * scale,
                lambda: signal.savgol_filter(x, window, 5, deriv=deriv, delta=1 / fs, axis=0) * scale,
            )
    ds = Dataset(t=t, q=x, joints=[f"j{j}" for j in range(m)], tau=x[:, ::-1].copy())
    row("prepare() at 5 kHz (q, tau)", lambda: preprocess.prepare(ds).ddq, lambda: scipy_prepare(ds).ddq)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"{n} samples × {m} columns; nproc {os.cpu_count()}, {platform.processor() or platform.machine()}, load {load:.2f}"
    )
    print("\n| work | pinid [ms] | scipy [ms] | scipy / pinid | max diff |\n|---|---|---|---|---|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
