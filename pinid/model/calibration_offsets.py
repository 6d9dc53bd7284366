"""Calibration term ``offsets``: a force/torque sensor's constant offsets, 6 per sensor, held by its swing phases.

A six-axis sensor under a foot reads, with nothing touching it, its own offset ``o`` (fx fy fz tx ty tz [N,
N·m], sensor frame); in stance it reads the ground's wrench plus ``o``.  The offsets are **not** fitted to the
rows: a constant force along the sole's normal is indistinguishable there from weight while the sole stays
flat, and six free offsets per sensor buy accuracy with an unphysical total mass (issue 46: 6.3 % instead of
7.4 % on the iCub walk, at 16 kg instead of 33).  They are what the recording itself says: the mean reading of
each sensor over its swing samples, where the true wrench is zero, with its Newey–West σ.

Swing samples: those whose force lies within :data:`SWING_FRACTION` of the robot's (URDF) weight of the sensor's
lowest readings (the median of its 5 % smallest |f|: its offset, to a first guess, which must itself be below
:data:`OFFSET_FRACTION` of the weight: a harness's load cell is never unloaded), at least
:data:`SWING_MARGIN` s from a loaded sample (the low-pass filter smears the heel strike).  A sensor with less
than :data:`MIN_SWING` s of swing (a harness's load cell, always loaded) is left as it is; so are samples gated
by contact phases (exactly zero).  Wrenches in the world (force plates) have no offsets term.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from pinid.model.calibration import CalibrationTerm, Estimate
from pinid.model.floating import Wrench
from pinid.linalg import andrews_bandwidth, bartlett_long_run

AXES = ("fx", "fy", "fz", "tx", "ty", "tz")
#: Swing: force within this fraction of the robot's weight of the sensor's lowest readings.
SWING_FRACTION = 0.05
#: A sensor whose lowest readings exceed this fraction of the robot's weight is never unloaded: it has no swing.
OFFSET_FRACTION = 0.1
#: Swing samples are at least this far [s] from a loaded one.
SWING_MARGIN = 0.05
#: Shortest swing [s, summed over the recordings] that holds a sensor's offsets.
MIN_SWING = 0.2


def _weight(model) -> float:
    return float(sum(i.mass for i in model.ff_model.inertias)) * float(np.linalg.norm(model.ff_model.gravity.linear))


def swing_mask(values: np.ndarray, weight: float, rate: float) -> np.ndarray:
    """(N,) booleans: the swing samples of one sensor's (N, 6) wrench (module text)."""
    values = np.asarray(values, dtype=float)
    live = np.any(values != 0.0, axis=1)
    if live.sum() < 20:
        return np.zeros(len(values), bool)
    f = values[:, :3]
    norm = np.linalg.norm(f, axis=1)
    low = live & (norm <= np.percentile(norm[live], 5))
    guess = np.median(f[low], axis=0)
    if np.linalg.norm(guess) > OFFSET_FRACTION * weight:  # never unloaded (a harness's load cell): no swing
        return np.zeros(len(values), bool)
    near = live & (np.linalg.norm(f - guess, axis=1) < SWING_FRACTION * weight)
    k = int(np.ceil(SWING_MARGIN * rate))
    if k > 0:  # erode: a swing sample has no loaded (or gated) sample within k samples
        bad = np.convolve((~near).astype(float), np.ones(2 * k + 1), mode="same") > 0
        near &= ~bad
    return near


def _estimate(model, samples) -> Estimate:
    weight = _weight(model)
    names, values, std, units, info = [], [], [], [], {}
    for link in _links(samples):
        pieces = []
        for s in samples:
            w = next((w for w in s.wrenches if w.link == link and w.frame == "local"), None)
            if w is None:
                continue
            pick = swing_mask(w.values, weight, float(s.data.sample_rate))
            pieces.append((w.values[pick], float(s.data.sample_rate)))
        seconds = sum(len(v) / r for v, r in pieces)
        count = sum(len(v) for v, _ in pieces)
        if seconds < MIN_SWING:
            info[link] = {"swing_samples": count, "swing_seconds": seconds, "held": False}
            continue
        mean = np.concatenate([v for v, _ in pieces]).mean(axis=0)
        long_run = np.zeros((6, 6))
        for v, _ in pieces:  # Newey–West variance of the mean, per recording
            g = v - mean
            long_run += bartlett_long_run(g, andrews_bandwidth(g))
        sigma = np.sqrt(np.clip(np.diag(long_run), 0, None)) / count
        info[link] = {"swing_samples": count, "swing_seconds": seconds, "held": True}
        names += [f"{link}.offset_{a}" for a in AXES]
        units += ["N"] * 3 + ["N·m"] * 3
        values.append(mean)
        std.append(sigma)
    return Estimate(
        names,
        np.concatenate(values) if values else np.zeros(0),
        np.concatenate(std) if std else np.zeros(0),
        units,
        info,
    )


def _links(samples) -> list[str]:
    out: list[str] = []
    for s in samples:
        out += [w.link for w in s.wrenches if w.frame == "local" and w.link not in out]
    return out


def _apply(s, estimate: Estimate):
    by_link = {}
    for i in range(0, len(estimate.names), 6):
        by_link[estimate.names[i].rsplit(".offset_", 1)[0]] = np.asarray(estimate.values[i : i + 6], dtype=float)
    wrenches = []
    for w in s.wrenches:
        o = by_link.get(w.link) if w.frame == "local" else None
        if o is None:
            wrenches.append(w)
            continue
        live = np.any(w.values != 0.0, axis=1)[:, None]  # samples gated by contact phases stay zero
        wrenches.append(Wrench(w.link, np.where(live, w.values - o, 0.0), w.frame))
    return replace(s, wrenches=wrenches)


TERM = CalibrationTerm(
    "offsets",
    "force/torque sensor offsets, held by the swing phases",
    held=True,
    applies=lambda samples: bool(_links(samples)),
    apply=_apply,
    estimate=_estimate,
    negligible=1e-3,
)
