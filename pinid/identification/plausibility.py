"""Checks of the recordings that make a result misleading without making it fail (issue 33), each a one-line
:class:`~pinid.errors.DataWarning`:

* :func:`shared_excitation` — a validation recording that repeats a training trajectory (the same excitation
  run again) validates as well as it trains: it cannot show overfitting;
* :func:`flipped_torque_signs` — a torque channel anti-correlated with the URDF's own torque for the motion
  recorded: its sign is flipped (the fit then wants negative friction on that joint);
* :func:`torque_scale` — torques whose size is orders of magnitude from the URDF's torque for the motion
  recorded: their units (N·mm, kN·m) or a gear ratio (issue 47);
* :func:`position_glitches` — a joint position that jumps far faster than the URDF's velocity limit allows
  and comes back: an encoder glitch (issue 47).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from pinid.errors import DataError, DataWarning

#: RMS of the aligned position difference, relative to the training positions' spread, below which a
#: validation recording repeats a training trajectory.  The same excitation run twice differs by the
#: tracking error and the noise (exo_leg twin: 1e-3); two different excitations by the order of 1.
SAME_TRAJECTORY = 0.1
#: Grid of the comparison [s]: positions resampled at ≤ 100 Hz (an excitation has no content above).
GRID_STEP = 0.01
#: Shortest overlap of two recordings compared, as a share of the shorter one.
MIN_OVERLAP = 0.5
#: Correlation of a torque channel with the URDF's torque below which its sign is called flipped.
FLIPPED = -0.5
#: Recorded torque / the URDF's (median over the joints of their RMS ratio) outside this band is warned about:
#: unmodelled friction or payload move it by a factor of a few at most; units off move it by 1000 (N·mm or mN·m
#: for N·m) or 0.001 (kN·m), a motor-side torque by the gear ratio.
TORQUE_SCALE = (0.1, 10.0)
#: A joint's position jumps when its sample-to-sample speed exceeds this multiple of the URDF's velocity limit
#: (:data:`GLITCH_SPEED` [rad/s or m/s] where the URDF gives none) and comes back within :data:`GLITCH_SAMPLES`.
GLITCH_FACTOR = 5.0
GLITCH_SPEED = 20.0
GLITCH_SAMPLES = 20
#: ... and by at least this much [rad or m] (an encoder count flickering at a high rate is no glitch).
GLITCH_MIN = 0.01


def _uniform(t: np.ndarray, q: np.ndarray, step: float) -> np.ndarray:
    """``q`` (N, nv) linearly resampled on a grid of ``step`` from ``t[0]``."""
    grid = np.arange(t[0], t[-1], step)
    return np.column_stack([np.interp(grid, t, q[:, j]) for j in range(q.shape[1])])


def aligned_difference(a: np.ndarray, b: np.ndarray, scale: np.ndarray, min_overlap: float = MIN_OVERLAP) -> float:
    """The smallest RMS of ``(a − b) / scale`` over every time shift of ``b`` against ``a`` (both (N, nv) on
    the same uniform grid) whose overlap is at least ``min_overlap`` of the shorter; inf if none."""
    x, y = a / scale, b / scale
    n, m = len(x), len(y)
    need = max(2, int(np.ceil(min_overlap * min(n, m))))
    if min(n, m) < need:
        return float("inf")
    size = 1 << int(np.ceil(np.log2(n + m)))
    cross = np.zeros(n + m - 1)
    for j in range(x.shape[1]):  # Σ_k x[k + s] y[k] for every shift s = -(m-1) .. n-1
        c = np.fft.irfft(np.fft.rfft(x[:, j], size) * np.conj(np.fft.rfft(y[:, j], size)), size)
        cross += np.concatenate([c[size - (m - 1) :], c[:n]])
    sx, sy = np.concatenate([[0.0], np.cumsum(np.sum(x * x, 1))]), np.concatenate([[0.0], np.cumsum(np.sum(y * y, 1))])
    shifts = np.arange(-(m - 1), n)
    lo_x, hi_x = np.maximum(shifts, 0), np.minimum(n, shifts + m)
    count = hi_x - lo_x
    lo_y = lo_x - shifts
    ok = count >= need
    if not ok.any():
        return float("inf")
    sq = (sx[hi_x] - sx[lo_x]) + (sy[lo_y + count] - sy[lo_y]) - 2 * cross
    msd = np.maximum(sq[ok], 0.0) / (count[ok] * x.shape[1])
    return float(np.sqrt(msd.min()))


def shared_excitation(train: Sequence, validation: Sequence, *, threshold: float = SAME_TRAJECTORY) -> list[str]:
    """A one-line DataWarning for each validation recording whose joint positions repeat those of a training
    recording (after the best time shift: :func:`aligned_difference`); returns the warnings.  Recordings with
    ``t`` and ``q`` (N, nv) in the same joint order (Datasets as the runner checks them)."""
    said = []
    if not train or not validation:
        return said
    spread = np.std(np.concatenate([np.asarray(d.q, dtype=float) for d in train]), axis=0)
    moving = spread > 1e-6
    if not moving.any():
        return said
    grids = [_uniform(np.asarray(d.t, float), np.asarray(d.q, float)[:, moving], GRID_STEP) for d in train]
    for v in validation:
        g = _uniform(np.asarray(v.t, float), np.asarray(v.q, float)[:, moving], GRID_STEP)
        for d, tg in zip(train, grids):
            diff = aligned_difference(tg, g, spread[moving])
            if diff < threshold:
                msg = (
                    f"{v.source}: the validation recording repeats the trajectory of training recording {d.source} "
                    f"(positions {100 * diff:.2g} % apart after alignment), so it hides overfitting; validate on "
                    "another excitation"
                )
                warnings.warn(msg, DataWarning, stacklevel=2)
                said.append(msg)
                break
    return said


def flipped_torque_signs(joints: Sequence[str], recorded: np.ndarray, nominal: np.ndarray) -> list[str]:
    """The joints whose recorded torque [N·m or N] is anti-correlated (< :data:`FLIPPED`) with ``nominal``, the
    URDF's torque for the same motion (both (N, nv)); one DataWarning naming them ("check the sign of
    tau_<joint>").  Joints whose nominal torque does not vary are not judged."""
    flipped = []
    for j, name in enumerate(joints):
        a, b = recorded[:, j] - recorded[:, j].mean(), nominal[:, j] - nominal[:, j].mean()
        den = float(np.sqrt(np.dot(a, a) * np.dot(b, b)))
        if den > 0 and np.dot(a, b) / den < FLIPPED:
            flipped.append((name, float(np.dot(a, b) / den)))
    if flipped:
        warnings.warn(
            "; ".join(
                f"check the sign of tau_{n}: it is anti-correlated (r = {r:.2f}) with the URDF's torque for this "
                "motion (sign = -1 in a mapping spec flips it)"
                for n, r in flipped
            ),
            DataWarning,
            stacklevel=2,
        )
    return [n for n, _ in flipped]


def _unit_guess(ratio: float) -> str:
    """The likely cause of recorded / URDF torque ``ratio`` (> 1 or < 1 by an order of magnitude or more)."""
    if 300 <= ratio <= 3000:
        return "torques in N·mm (or mN·m) instead of N·m (scale = 0.001 in a mapping spec)"
    if 3e-4 <= ratio <= 3e-3:
        return "torques in kN·m instead of N·m (scale = 1000 in a mapping spec)"
    if ratio > 1:
        return "the torque's units or scale (a motor-side torque times the gear ratio, a current read as torque)"
    return "the torque's units or scale (a motor-side torque, a torque constant missing, a current in mA)"


def torque_scale(joints: Sequence[str], recorded: np.ndarray, nominal: np.ndarray, source: str = "") -> float | None:
    """The recorded torques' scale against ``nominal``, the URDF's torque for the same motion (both (N, nv)):
    the median over the joints of RMS(recorded) / RMS(nominal) (joints whose nominal torque is ~0 left out);
    one DataWarning naming the likely units when it is outside :data:`TORQUE_SCALE` (N·mm gives ~1000, kN·m
    ~0.001).  Returns the ratio (None when no joint can be judged)."""
    from pinid.checks import as_floats

    recorded, nominal = as_floats(recorded, "recorded", finite=False), as_floats(nominal, "nominal", finite=False)
    if recorded.ndim != 2 or recorded.shape != nominal.shape or recorded.shape[1] != len(joints):
        raise DataError(f"recorded {recorded.shape}, nominal {nominal.shape}: expected (N, {len(joints)}) both")
    rms_r = np.sqrt(np.mean(recorded**2, axis=0))
    rms_n = np.sqrt(np.mean(nominal**2, axis=0))
    ok = rms_n > 1e-6 * max(float(rms_n.max(initial=0.0)), 1e-300)
    if not ok.any() or not np.all(np.isfinite(rms_r[ok])):
        return None
    ratio = float(np.median(rms_r[ok] / rms_n[ok]))
    if not TORQUE_SCALE[0] <= ratio <= TORQUE_SCALE[1]:
        named = ", ".join(f"tau_{n}" for n, k in zip(joints, ok) if k)
        warnings.warn(
            f"{source + ': ' if source else ''}the recorded joint torques are {ratio:.3g} × the URDF's torque for "
            f"this motion (median RMS ratio over {named}; expected about 1): likely cause: {_unit_guess(ratio)}",
            DataWarning,
            stacklevel=2,
        )
    return ratio


def position_glitches(ds, velocity_limit: np.ndarray, units: Sequence[str] | None = None) -> list[str]:
    """One DataWarning naming the joints of the raw recording ``ds`` (t, q (N, nv), joints, source) whose
    position jumps (by :data:`GLITCH_MIN` or more) at a speed above :data:`GLITCH_FACTOR` × ``velocity_limit``
    [rad/s or m/s] (per joint; :data:`GLITCH_SPEED` where inf or 0) and jumps back within :data:`GLITCH_SAMPLES` samples: an encoder glitch
    (a spike no filter removes, which the fit then reads as a huge acceleration).  Each named with its time
    [s], the jump (``units`` per joint, default rad), its length in samples and its speed; returns the joints
    named."""
    if not all(hasattr(ds, k) for k in ("t", "q", "joints", "source")):
        raise DataError(f"position_glitches: got {type(ds).__name__}, expected a Dataset (t, q, joints, source)")
    t, q = np.asarray(ds.t, dtype=float), np.asarray(ds.q, dtype=float)
    if q.ndim != 2 or len(t) < 3 or not np.all(np.isfinite(q)) or np.any(np.diff(t) <= 0):
        return []
    units = list(units) if units is not None else ["rad"] * q.shape[1]
    vlim = np.asarray(velocity_limit, dtype=float)
    has = np.isfinite(vlim) & (vlim > 0)
    limit = np.where(has, GLITCH_FACTOR * np.where(has, vlim, 1.0), GLITCH_SPEED)
    dt = np.diff(t)
    dq = np.diff(q, axis=0)
    found, named = [], []
    for j, name in enumerate(ds.joints):
        fast = np.flatnonzero((np.abs(dq[:, j]) > limit[j] * dt) & (np.abs(dq[:, j]) >= GLITCH_MIN))
        for a, b in zip(fast[:-1], fast[1:]):  # a jump, then the next fast step, back the other way, soon after
            if b - a <= GLITCH_SAMPLES and np.sign(dq[b, j]) != np.sign(dq[a, j]):
                u, size = units[j], float(dq[a, j])
                against = f"its velocity limit {vlim[j]:.3g} {u}/s" if has[j] else "no velocity limit in the URDF"
                found.append(
                    f"q_{name} jumps {size:+.3g} {u} at t = {t[a + 1]:.4g} s for {b - a} sample"
                    f"{'s' if b - a > 1 else ''} ({abs(size) / dt[a]:.3g} {u}/s, {against})"
                )
                named.append(name)
                break
    if found:
        warnings.warn(
            f"{ds.source}: an encoder glitch: " + "; ".join(found) + "; repair or drop those samples (rows = "
            "[start, stop] in a mapping spec): the fit reads a glitch as a huge acceleration",
            DataWarning,
            stacklevel=2,
        )
    return named
