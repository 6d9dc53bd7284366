"""Checks of the recordings that make a result misleading without making it fail (issue 33), each a one-line
:class:`~pinid.errors.DataWarning`:

* :func:`shared_excitation` — a validation recording that repeats a training trajectory (the same excitation
  run again) validates as well as it trains: it cannot show overfitting;
* :func:`flipped_torque_signs` — a torque channel anti-correlated with the URDF's own torque for the motion
  recorded: its sign is flipped (the fit then wants negative friction on that joint).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from pinid.errors import DataWarning

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
