"""A chattering foot switch on the gait twin (docs/floating-base.md, "Contact phases that chatter"): held-out
RMS of OLS trained on the clean phases, on phases that chatter, and without the contact columns.

    python tests/benchmarks/floating_chatter.py [--rate 1000] [--place inside|centre] [--margin 0.5]

``--place inside``: the phase flips on and off in runs of 1–6 ms for 30–80 ms inside each contact, after the
touchdown and before the lift-off (a switch that bounces); ``centre``: the same window centred on each
transition.  ``--margin 0.5`` gates at 0.5 alone (leaves nothing out), as pinid did before.
"""

from __future__ import annotations

import argparse
import copy
import warnings

import numpy as np

import pinid.data.preprocess as preprocess
from pinid import RobotModel
from pinid.data.preprocess import prepare
from pinid.estimators import make_estimator
from pinid.model.terms import TermSelection
from pinid.problem.floating import floating_problem
from pinid.simulation.floating_twin import Noise, simulate_gait


def chatter(c: np.ndarray, rate: float, rng, place: str) -> np.ndarray:
    """``c`` with the phase flipping in runs of 1–6 ms for 30–80 ms at each transition."""
    c = c.copy()
    for e in np.flatnonzero(np.diff(c.astype(int))) + 1:
        w = int(rng.uniform(0.03, 0.08) * rate)
        k = e - w // 2 if place == "centre" else (e if c[e] else e - w)
        end, v = k + w, bool(rng.integers(2))
        while k < end:
            n = max(1, int(rng.uniform(0.001, 0.006) * rate))
            c[max(k, 0) : max(0, min(k + n, end, len(c)))] = v
            v, k = not v, k + n
    return c


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=1000.0)
    ap.add_argument("--place", choices=("inside", "centre"), default="inside")
    ap.add_argument("--margin", type=float, default=preprocess.CONTACT_MARGIN)
    args = ap.parse_args(argv)
    exo = RobotModel.from_urdf("exo_lower_body", base="floating")
    terms = TermSelection.from_names("fc,fv")
    noise = Noise(2e-5, 0.3, 2.0, 0.2)
    train = simulate_gait(exo, seconds=10, rate=args.rate, noise=noise, seed=1)
    held = simulate_gait(exo, seconds=6, rate=args.rate, noise=noise, seed=2, pattern={"period": 1.0, "speed": 0.9})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hs = prepare(held.recording)  # clean phases, no chatter: every row kept
        preprocess.CONTACT_MARGIN = args.margin
        out = {}
        for kind in ("clean", "chatter", "none"):
            rec = copy.copy(train.recording)
            rec.floating = copy.copy(rec.floating)
            if kind == "none":
                rec.floating.contacts = {}
            elif kind == "chatter":
                rng = np.random.default_rng(0)
                rec.floating.contacts = {
                    k: chatter(v, args.rate, rng, args.place) for k, v in rec.floating.contacts.items()
                }
            p = floating_problem(exo, prepare(rec), terms=terms)
            hp = floating_problem(exo, hs, terms=terms, base=p.base)
            r = hp.tau - hp.predict(make_estimator("ols").fit(p).base_)
            out[kind] = (np.sqrt(np.mean(r[hp.joint >= 1] ** 2)), np.sqrt(np.mean(r**2)), len(p.tau))
    print(f"rate {args.rate:g} Hz, chatter {args.place}, margin {args.margin:g}; held-out RMS of OLS")
    for k, (j, a, n) in out.items():
        print(
            f"{k:8s} joint rows {j:.4f} N·m ({j / out['clean'][0]:.3f} x clean), all rows {a:.4f} "
            f"({a / out['clean'][1]:.3f} x clean), {n} training rows"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
