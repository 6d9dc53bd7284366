"""Delays between a recording's channels: the torque channel recorded later than the positions.

A torque channel that *lags* the positions by ``d`` seconds holds at time ``t`` the torque of the motion at
``t − d``; aligned, the torque of the motion at ``t`` is the recorded one at ``t + d``.  :func:`shift_torque`
aligns a recording this way (linear interpolation of each torque channel at ``t + d_j``; the samples where
``t + d_j`` falls outside the recording are left out, so nothing is extrapolated).  ``d < 0``: the torque
leads.  A delay that is a whole number of sample steps moves the samples as they are.

A delay is given as seconds for every torque channel (``0.04``, ``"tau=0.04"``), per joint
(``"tau.knee=0.04,tau.hip=0.02"``, ``{"knee": 0.04}``), ``"auto"`` (``"tau=auto"``: one delay estimated on the
training recordings, :mod:`pinid.identification.delay`) or ``"auto-per-joint"`` (one estimated per channel).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError

#: Default bound [s] of an estimated delay: the search is over [−DELAY_RANGE, DELAY_RANGE].
DELAY_RANGE = 0.2
#: Largest given delay [s] accepted (a larger one is a unit error: milliseconds given as seconds).
MAX_DELAY = 10.0

_EXPECTED = "expected seconds by which the torque lags the positions: 0.04, tau=0.04, tau.<joint>=0.04 or auto"


def parse_delay(spec, joints: Sequence[str]) -> np.ndarray | str | None:
    """``None`` (no delay), ``"auto"``, ``"auto-per-joint"`` or per-joint delays (nv,) [s] from a number,
    ``"tau=0.04"``, ``"tau.knee=0.04,…"``, ``"auto"`` / ``"tau=auto"``, ``"auto-per-joint"`` or
    ``{joint or "tau": seconds}``; SpecError (one line)
    for anything else, an unknown joint or a value that is not a finite number of at most :data:`MAX_DELAY`."""
    if spec is None:
        return None
    joints = list(joints)
    if isinstance(spec, str):
        text = spec.strip()
        if text.lower() in ("auto", "tau=auto"):
            return "auto"
        if text.lower() in ("auto-per-joint", "tau=auto-per-joint"):
            return "auto-per-joint"
        items: dict = {}
        for part in (p.strip() for p in text.split(",") if p.strip()):
            key, sep, value = part.partition("=")
            if not sep:
                key, value = "tau", key
            key = key.strip()
            same = [k for k in items if k.removeprefix("tau.") == key.removeprefix("tau.")]  # knee is tau.knee
            if same:
                raise SpecError(
                    f"delay {spec!r}: {key} given twice ({same[0]}={items[same[0]]}, {key}={value.strip()}); "
                    "expected each channel once"
                )
            items[key] = value.strip()
        if not items:
            raise SpecError(f"delay {spec!r}: {_EXPECTED}")
    elif isinstance(spec, Mapping):
        items = {str(k): v for k, v in spec.items()}
    else:
        items = {"tau": spec}
    out = np.zeros(len(joints))
    for key, value in sorted(items.items(), key=lambda kv: kv[0] != "tau"):  # tau=… first, per joint over it
        if key == "tau":
            target = list(range(len(joints)))
        else:
            name = key[4:] if key.startswith("tau.") else key
            if name not in joints:
                raise SpecError(
                    f"delay {key!r}: no joint {name!r}; expected tau or tau.<joint>, joints {', '.join(joints)}"
                )
            target = [joints.index(name)]
        if isinstance(value, str) and value.strip().lower() == "auto":
            raise SpecError(
                f"delay {key}=auto: 'auto' estimates one delay for every torque channel; give tau=auto, or "
                "auto-per-joint for one delay per channel"
            )
        try:
            number = float(value)
        except (TypeError, ValueError):
            number = float("nan")
        if isinstance(value, bool) or not np.isfinite(number) or abs(number) > MAX_DELAY:
            raise SpecError(f"delay {key}={value!r}: {_EXPECTED} (|delay| ≤ {MAX_DELAY:g} s)")
        out[target] = number
    return out


def shift_torque(ds: Dataset, delays: np.ndarray | float) -> Dataset:
    """The recording with each torque channel ``j`` read at ``t + delays[j]`` [s] (see the module text): the
    samples whose shifted time is outside the recording are left out.  ``ds.meta["delay"]`` records the
    delays.  DataError when no sample is left."""
    d = np.broadcast_to(np.asarray(delays, dtype=float), (ds.nv,)).copy()
    if ds.tau is None or not np.any(d):
        return ds
    t = ds.t
    keep = (t + d.min() >= t[0] - 1e-9 * max(abs(t[0]), 1.0)) & (t + d.max() <= t[-1] + 1e-9 * max(abs(t[-1]), 1.0))
    if not keep.any():
        raise DataError(
            f"{ds.source}: a torque delay of {d.max():g} s leaves no sample of a {ds.duration:g} s recording"
        )
    out = ds.select(keep)
    tau = np.empty_like(out.tau)
    for j in range(ds.nv):
        tau[:, j] = shifted(t, ds.tau[:, j], out.t + d[j])
    out.tau = tau
    out.meta["delay"] = {name: float(v) for name, v in zip(ds.joints, d)}
    rec = ds.meta.get("recorded")
    if isinstance(rec, Dataset) and rec.tau is not None and rec.n >= 2 and set(ds.joints) <= set(rec.joints):
        out.meta["recorded"] = _shift_recorded(
            rec.reorder(list(ds.joints)), d
        )  # the yardstick moves with the torque: not filtered
    return out


def _shift_recorded(rec: Dataset, d: np.ndarray) -> Dataset:
    """The recording as read with each torque channel read at ``t + d[j]`` [s] (linear interpolation, no
    filter): the yardstick of torque errors aligned like the fitted torque.  Only the times the aligned
    recording keeps are ever looked up, so the ends (held at the last sample) are never used."""
    out = rec.select(slice(None))
    out.tau = np.column_stack([shifted(rec.t, rec.tau[:, j], rec.t + d[j]) for j in range(rec.nv)])
    return out


def shifted(t: np.ndarray, x: np.ndarray, at: np.ndarray) -> np.ndarray:
    """``x`` (sampled at ``t``) at the times ``at``, by linear interpolation; a time within 1e-9 of a sample
    step of a sample takes that sample exactly (whole-step delays move samples as they are)."""
    k = np.clip(np.searchsorted(t, at), 1, len(t) - 1)
    t0, t1 = t[k - 1], t[k]
    w = (at - t0) / np.where(t1 > t0, t1 - t0, 1.0)
    w = np.where(np.abs(w) < 1e-9, 0.0, np.where(np.abs(w - 1) < 1e-9, 1.0, np.clip(w, 0.0, 1.0)))
    return (1 - w) * x[k - 1] + w * x[k]
