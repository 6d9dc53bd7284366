"""Torque offsets per recording: several recording days identified together, a new day calibrated alone.

Torque sensors (and current-sensor zero points) drift between recording days: one constant offset per
joint that differs from one recording to the next.  The model here is

    τ_r(k) = W_b(q, q̇, q̈)(k) · β + o_r          (recording r, sample k)

with the base parameters ``β`` (inertial and the selected joint terms, e.g. ``fc,fv``) shared by every
recording and one offset vector ``o_r`` [N·m] (one value per joint) per training recording: the stacked
regressor gets one offset column block per recording (rows of recording r have 1 in their block, column
j of the block for joint j's rows).  The terms must not contain ``offset`` (a shared offset is collinear
with the per-recording blocks).  Fitted by ordinary least squares with unit-norm columns.

A new recording (another day) is *calibrated*: with ``β`` fixed, its offsets are fitted on its first
``fraction`` of samples only (the least-squares offset of joint j is the mean of its torque residual
there), and the model is scored on the rest (:func:`calibrate_offsets`, :func:`score_calibrated`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pinid.data.dataset import Dataset
from pinid.errors import SpecError
from pinid.identification.metrics import torque_metrics
from pinid.model.base import BaseParameters, base_parameters
from pinid.model.robot import as_robot
from pinid.model.terms import TermSelection, as_terms
from pinid.problem.problem import base_regressor, check_dataset, recorded_torque


@dataclass
class RecordingOffsets:
    """Shared base parameters and one offset vector per training recording.

    ``base``: the base parameters (columns) of ``terms``; ``values``: their fitted values; ``offsets``
    ``(recordings, nv)`` [N·m]; ``joints``: the joint order of the offset columns."""

    model: object
    terms: TermSelection
    base: BaseParameters
    values: np.ndarray
    offsets: np.ndarray
    joints: list[str]

    def predict(self, ds: Dataset, offsets: np.ndarray | None = None) -> np.ndarray:
        """Predicted torque ``(N, nv)`` [N·m] on a checked recording with ``offsets`` (nv,) [N·m] (default none)."""
        ds = check_dataset(ds, self.model)
        nv = self.model.nv
        tau = base_regressor(self.model, self.terms, self.base, ds) @ self.values
        o = np.zeros(nv) if offsets is None else np.asarray(offsets, dtype=float)
        return tau.reshape(ds.n, nv) + o


def identify_recording_offsets(
    model, datasets: Sequence[Dataset], terms: TermSelection | str = "fc,fv"
) -> RecordingOffsets:
    """Fit shared base parameters and one offset per joint per recording of checked, prepared ``datasets``."""
    model, terms = as_robot(model), as_terms(terms)
    if "offset" in terms.names:
        raise SpecError(
            f"terms: {','.join(terms.names)} has 'offset', collinear with the per-recording offsets; "
            "expected the terms without it"
        )
    datasets = [check_dataset(ds, model) for ds in datasets]
    if not datasets:
        raise SpecError("datasets: none given; expected at least one recording")
    nv, nr = model.nv, len(datasets)
    base = base_parameters(model, terms)
    blocks, taus = [], []
    for r, ds in enumerate(datasets):
        Wb = base_regressor(model, terms, base, ds)
        O = np.zeros((ds.n * nv, nr * nv))
        O[:, r * nv : (r + 1) * nv] = np.tile(np.eye(nv), (ds.n, 1))
        blocks.append(np.hstack([Wb, O]))
        taus.append(ds.tau.reshape(-1))
    W, tau = np.vstack(blocks), np.concatenate(taus)
    scale = np.linalg.norm(W, axis=0)
    scale[scale == 0] = 1.0
    x = np.linalg.lstsq(W / scale, tau, rcond=None)[0] / scale
    nb = base.count
    return RecordingOffsets(model, terms, base, x[:nb], x[nb:].reshape(nr, nv), list(model.joint_names))


def calibrate_offsets(fit: RecordingOffsets, ds: Dataset, fraction: float = 0.1) -> np.ndarray:
    """Offsets (nv,) [N·m] of a new recording from its first ``fraction`` of samples, the rest of the
    model fixed: the mean torque residual per joint there (least squares with only the offsets free)."""
    if not 0 < fraction <= 1:
        raise SpecError(f"fraction: got {fraction!r}, expected 0 < fraction ≤ 1")
    ds = check_dataset(ds, fit.model)
    m = max(1, int(round(fraction * ds.n)))
    head = ds.select(slice(0, m))
    return np.mean(head.tau - fit.predict(head), axis=0)


def relative_rms(measured: np.ndarray, predicted: np.ndarray) -> tuple[float, np.ndarray]:
    """``(pooled, per_joint)`` relative RMS error [%] of ``predicted`` against ``measured`` (N, nv): the
    ``rel_rms_percent`` of :func:`pinid.identification.metrics.torque_metrics`."""
    names = [str(j) for j in range(np.shape(measured)[1])]
    m = torque_metrics(measured, predicted, names)
    return m.all["rel_rms_percent"], np.array([m.per_joint[n]["rel_rms_percent"] for n in names])


def score_calibrated(fit: RecordingOffsets, ds: Dataset, fraction: float = 0.1) -> tuple[float, np.ndarray]:
    """Relative RMS [%] (pooled, per joint) against the torque as recorded on the last ``1 − fraction`` of
    a recording whose offsets are calibrated from its first ``fraction``."""
    ds = check_dataset(ds, fit.model)
    o = calibrate_offsets(fit, ds, fraction)
    m = max(1, int(round(fraction * ds.n)))
    rest = ds.select(slice(m, ds.n))
    return relative_rms(recorded_torque(rest), fit.predict(rest, o))
