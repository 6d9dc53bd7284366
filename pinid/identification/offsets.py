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
from pinid.problem.problem import base_regressor, check_dataset, predict_torque, recorded_torque


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


# ====================================================================== in pinid identify (the Study's option)
#: The values of ``Study.offsets`` (``--offsets``): None, the terms' own (a shared ``offset`` term or none).
OFFSET_MODES = ("per-recording",)
#: Largest ``calibrate_offsets`` fraction: at least half of each validation recording is scored.
CALIBRATE_MAX = 0.5


def check_offset_options(offsets, calibrate, terms: TermSelection, recordings: int, validated: bool) -> str | None:
    """``offsets`` as a mode of :data:`OFFSET_MODES` (or None), checked with the rest of the study: SpecError
    (one line) for an unknown mode, a fraction outside (0, 0.5], a fraction without per-recording offsets or
    without validation recordings, the ``offset`` term besides, and one training recording without calibration
    (that is the ``offset`` term)."""
    if offsets is not None:
        if not isinstance(offsets, str) or offsets.strip().lower().replace("_", "-") not in OFFSET_MODES:
            raise SpecError(f"offsets {offsets!r}: expected {' or '.join(OFFSET_MODES)} (or none)")
        offsets = offsets.strip().lower().replace("_", "-")
    if calibrate is not None:
        if isinstance(calibrate, bool) or not isinstance(calibrate, (int, float)) or not 0 < calibrate <= CALIBRATE_MAX:
            raise SpecError(
                f"calibrate offsets {calibrate!r}: expected a fraction 0 < f ≤ {CALIBRATE_MAX:g} of each validation "
                "recording (its first f calibrates its offsets, the rest is scored), e.g. 0.1"
            )
        if offsets is None:
            raise SpecError(
                "calibrate offsets: the offsets calibrated are per recording; expected offsets per-recording"
            )
        if not validated:
            raise SpecError("calibrate offsets: no validation recording to calibrate; expected validation recordings")
    if offsets is None:
        return None
    if "offset" in terms.names:
        raise SpecError(
            f"offsets per-recording with the terms {','.join(terms.names)}: the 'offset' term is one offset shared "
            "by every recording, collinear with the per-recording ones; expected the terms without offset"
        )
    if recordings < 2 and calibrate is None:
        raise SpecError(
            "offsets per-recording with one training recording and no offset calibration: that is the model of "
            "the 'offset' term; expected two or more training recordings, calibrate offsets, or --terms …,offset"
        )
    return offsets


@dataclass
class ProfiledOffsets:
    """The offsets per recording of a training problem, profiled out (:func:`profile_offsets`).

    Groups are (recording, joint), recording-major: ``mean_W`` ``(groups, nb)`` and ``mean_tau`` ``(groups,)``
    are the weighted means of each group's rows of the regressor and torque before they were subtracted,
    ``rows`` the number of rows of each group (0: that joint's offset in that recording is not estimated)."""

    sources: list[str]
    joints: list[str]
    mean_W: np.ndarray
    mean_tau: np.ndarray
    rows: np.ndarray
    calibrate: float | None = None

    def offsets(self, base: np.ndarray) -> np.ndarray:
        """``(recordings, nv)`` [N·m] offsets of base parameters ``base``: each group's mean torque residual
        (NaN for a joint without rows in a recording)."""
        o = self.mean_tau - self.mean_W @ np.asarray(base, dtype=float)
        return np.where(self.rows > 0, o, np.nan).reshape(len(self.sources), len(self.joints))

    def assumed(self, base: np.ndarray) -> np.ndarray:
        """(nv,) [N·m] offsets of a recording of another day without calibration: the mean over the training
        recordings (0 where none is estimated)."""
        o = self.offsets(base)
        known = np.isfinite(o)
        return np.where(known, o, 0.0).sum(axis=0) / np.maximum(known.sum(axis=0), 1)


def profile_offsets(problem, calibrate: float | None = None) -> ProfiledOffsets:
    """Profile one offset per joint per training recording out of ``problem`` (made by
    :meth:`~pinid.problem.problem.IdentificationProblem.from_datasets`), in place.

    The offsets are columns of the regressor (1 on the rows of their recording and joint) with no constraint,
    so for any base parameters the best offsets are each group's mean residual, and what remains to fit is
    the regressor and torque with each group's (weighted) mean subtracted (Frisch–Waugh–Lovell): every
    estimator that minimises a weighted squared residual (ols, wls, sdp, …) then fits exactly the base
    parameters of the regressor with the offset columns, the LMI of sdp unchanged.  ``problem.offset_shift``
    keeps each row's subtracted mean torque, so that the training errors are against the torque as recorded."""
    rows = getattr(problem, "regressor_rows", None)
    if rows is None:
        raise SpecError(
            "offsets per recording: expected a problem made from recordings (IdentificationProblem.from_datasets)"
        )
    nv, nb = problem.nv, problem.nb
    sizes = np.array([ds.n for ds in rows.datasets])
    sources = [ds.source for ds in rows.datasets]
    groups = len(sizes) * nv
    g = np.searchsorted(np.cumsum(sizes), problem.sample, side="right") * nv + problem.joint
    w = np.broadcast_to(np.asarray(problem.weights, dtype=float), g.shape)
    count = np.bincount(g, minlength=groups)
    sw = np.bincount(g, weights=w, minlength=groups)
    inv = np.divide(1.0, sw, out=np.zeros(groups), where=sw > 0)
    W = problem.W
    mean_W = np.column_stack([np.bincount(g, weights=w * W[:, k], minlength=groups) for k in range(nb)]) * inv[:, None]
    mean_tau = np.bincount(g, weights=w * problem.tau, minlength=groups) * inv
    shift = mean_tau[g]
    recorded = problem.recorded_tau if problem.recorded_tau is not None else problem.tau
    demeaned = W - mean_W[g]
    del W
    problem.W = demeaned  # the recordings' rows let go; samples and recording sizes kept
    problem.recorded_tau = recorded - shift
    problem.tau = problem.tau - shift
    problem.offset_shift = shift
    problem.check()  # a column constant within every recording and joint has nothing left
    return ProfiledOffsets(sources, list(problem.model.joint_names), mean_W, mean_tau, count, calibrate)


def head_samples(n: int, fraction: float) -> int:
    """The samples of a recording's first ``fraction`` (at least 1, at most ``n − 1``)."""
    return int(min(max(1, round(fraction * n)), n - 1))


def offset_validation(profiled: ProfiledOffsets, model, terms, base, datasets: Sequence[Dataset], values: dict):
    """``(scored, predictions, offsets)`` of checked validation ``datasets`` for the base parameters
    ``values`` ``{method: base}``: calibrated (``profiled.calibrate``: each recording's offsets are the mean
    torque residual of its first fraction, the rest scored) or not (the training recordings' mean offsets,
    every sample scored).  ``scored``: the datasets scored; ``predictions``: one ``{method: (N, nv)}`` per
    scored dataset; ``offsets``: ``{method: [(nv,) per dataset]}``."""
    scored, preds, offsets = [], [], {m: [] for m in values}
    for ds in datasets:
        if profiled.calibrate is None:
            rest, o = ds, {m: profiled.assumed(v) for m, v in values.items()}
        else:
            k = head_samples(ds.n, profiled.calibrate)
            head, rest = ds.select(slice(0, k)), ds.select(slice(k, ds.n))
            p = predict_torque(model, terms, base, head, values)
            o = {m: np.mean(head.tau - p[m], axis=0) for m in values}
        p = predict_torque(model, terms, base, rest, values)
        scored.append(rest)
        preds.append({m: p[m] + o[m] for m in values})
        for m in values:
            offsets[m].append(o[m])
    return scored, preds, offsets


def offsets_summary(profiled: ProfiledOffsets, train: np.ndarray, validation: Sequence[np.ndarray], sources) -> dict:
    """The offsets of one result as saved (``info["offsets"]``): ``{"training": [{"source", "offsets": {joint:
    N·m}}], "validation": [...]}`` (NaN as None)."""

    def one(src, o):
        return {
            "source": src,
            "offsets": {j: None if not np.isfinite(v) else float(v) for j, v in zip(profiled.joints, o)},
        }

    return {
        "training": [one(s, o) for s, o in zip(profiled.sources, train)],
        "validation": [one(s, o) for s, o in zip(sources, validation)],
    }
