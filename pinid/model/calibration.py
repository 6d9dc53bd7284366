"""Sensor calibration terms of a floating-base recording: one registry (docs/floating-base.md, issue 46).

A real recording's sensors are not ideal: a force/torque sensor reads an offset with nothing on it, the motion
capture's vertical is not gravity's.  A *calibration term* corrects the prepared samples
(:class:`~pinid.data.contacts.FloatingSamples`) before their rows are stacked, with values that are either

* **held** by the recording itself (``held=True``): estimated from the samples alone, before any fit, with
  their σ — a sensor's offsets are what it reads in swing, where nothing touches it
  (:mod:`pinid.model.calibration_offsets`); or
* **fitted** jointly with the inertial parameters (``held=False``): a term that turns gravity in the base
  frame (``gravity``), found by Gauss-Newton with the linear least squares of the inertial parameters
  (:mod:`pinid.identification.calibration`) — gravity's direction in the motion-capture world
  (:mod:`pinid.model.calibration_tilt`).

Which terms enter is chosen by blocked cross-validation on the training recordings
(:func:`pinid.identification.calibration.choose_calibration`); the same values are applied to the validation
recordings and reported with their σ.  Adding a term is one module defining ``TERM`` (a
:class:`CalibrationTerm`) plus its line in :data:`CALIBRATION_TERMS`.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from pinid.errors import SpecError


@dataclass(frozen=True)
class Estimate:
    """Values of a calibration term: ``names`` (one per value), ``values``, ``std`` (their σ, NaN where
    unknown), ``units`` and ``info`` (what the estimate rests on: samples in swing per sensor …)."""

    names: list[str]
    values: np.ndarray
    std: np.ndarray
    units: list[str]
    info: dict


@dataclass(frozen=True)
class CalibrationTerm:
    """One kind of calibration (module text).

    ``applies(samples)``: whether the recordings have what it corrects (a local wrench; a base orientation).
    ``held``: its values come from ``estimate(model, samples) -> Estimate`` alone; otherwise ``names(samples)``
    names them, ``start`` gives the first guess, and ``gravity(values, base_q) -> (N, 3)`` is gravity's
    acceleration in the base frame at those values (the rows depend on the values only through it).
    ``apply(samples, estimate) -> samples``: the corrected samples of one recording."""

    name: str
    label: str
    held: bool
    applies: Callable[[Sequence], bool]
    apply: Callable[[object, Estimate], object]
    estimate: Callable[[object, Sequence], Estimate] | None = None
    names: Callable[[Sequence], list[str]] | None = None
    units: Callable[[Sequence], list[str]] | None = None
    start: Callable[[Sequence], np.ndarray] | None = None
    gravity: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None
    shown: Callable[[np.ndarray], np.ndarray] | None = None  # values as reported (rad → deg)
    shown_units: Callable[[Sequence], list[str]] | None = None
    negligible: float = 0.0  # values this small [their units] never make the term a candidate of "auto"
    #: ``world(values, g) -> (3,)``: gravity [m/s²] in the world the base pose is read in, when ``gravity`` is
    #: ``R_MBᵀ·world(values, g)`` (R_MB the base pose's rotation): the rows are then linear in a 3-vector that does
    #: not depend on the sample, and the calibration's fits work on precomputed Gram blocks
    world: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None


#: The calibration terms by name, in the order they are applied: name → module defining ``TERM``.
CALIBRATION_TERMS: dict[str, str] = {
    "offsets": "pinid.model.calibration_offsets",
    "tilt": "pinid.model.calibration_tilt",
}


def calibration_term(name: str) -> CalibrationTerm:
    """The registered term ``name``; SpecError naming the known ones otherwise."""
    if name not in CALIBRATION_TERMS:
        raise SpecError(f"calibration term {name!r}: expected one of {', '.join(CALIBRATION_TERMS)}")
    return importlib.import_module(CALIBRATION_TERMS[name]).TERM


def calibration_names(spec) -> list[str] | str:
    """``"auto"`` (chosen by the data), or the terms of ``"offsets,tilt"`` / a list, in registry order
    (``"none"`` or ``""``: no term).  SpecError for anything else."""
    if spec is None:
        return "auto"
    if isinstance(spec, str):
        if spec.strip() == "auto":
            return "auto"
        parts = [p.strip() for p in spec.split(",") if p.strip() and p.strip() != "none"]
    elif isinstance(spec, (list, tuple)) and all(isinstance(p, str) for p in spec):
        parts = list(spec)
    else:
        raise SpecError(f"calibration: got {spec!r}, expected 'auto', 'none' or some of {', '.join(CALIBRATION_TERMS)}")
    for p in parts:
        calibration_term(p)
    return [n for n in CALIBRATION_TERMS if n in parts]


def rotation_xy(angles: np.ndarray) -> np.ndarray:
    """``Rx(α)·Ry(β)`` of ``angles = (α, β)`` [rad]."""
    a, b = float(angles[0]), float(angles[1])
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    return np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]]) @ np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
