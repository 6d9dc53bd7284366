"""One study: the robot, its recordings with their roles and ranges, the preprocessing, the rows and the terms.

:class:`Study` is what :func:`pinid.identification.run.identify` and
:func:`pinid.identification.compare.compare` identify from; the CLI builds one from its arguments and a
dataset manifest (:mod:`pinid.data.manifest`) is its file form (:meth:`Study.from_manifest`).  Each piece of
information is given once: the methods, seeds and per-method settings are the runs' arguments, not the
study's.
"""

from __future__ import annotations

import dataclasses
import inspect
import numbers
import os
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from pinid.data.dataset import Dataset
from pinid.data.preprocess import Preprocessing
from pinid.errors import SpecError
from pinid.model.robot import RobotModel
from pinid.model.terms import TermSelection
from pinid.problem.problem import REST_FRACTION

__all__ = ["Study"]

_PATH = (str, os.PathLike)


def _recording(value: Any) -> bool:
    """A recording as the study takes it: a Dataset, a path, or a floating base's prepared samples."""
    from pinid.data.contacts import FloatingSamples  # deferred: the floating base's reader

    return isinstance(value, (Dataset, *_PATH, FloatingSamples))


def _recordings(value: Any) -> bool:
    """One recording or a list (tuple) of them."""
    return _recording(value) or (isinstance(value, (list, tuple)) and all(_recording(v) for v in value))


def _real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def _optional(*kinds) -> callable:
    return lambda v: v is None or isinstance(v, kinds)


#: ``{field: (accepts, what is expected)}``: the type check of each field of :class:`Study`.
_CHECKS: dict[str, tuple] = {
    "data": (_recordings, "a Dataset, a recording's path, or a list of them"),
    "validate": (
        lambda v: v is None or _recordings(v) or (isinstance(v, Mapping) and all(_recordings(x) for x in v.values())),
        "recordings, or {label: recordings}",
    ),
    "terms": (
        lambda v: isinstance(v, (TermSelection, str, list, tuple)),
        'a TermSelection, "fc,fv", a list, "auto" (or "auto,motor_fc,…") or "default"',
    ),
    "mapping": (lambda v: v is None or not isinstance(v, (bool, numbers.Number)), "a mapping spec, its TOML or dict"),
    "preprocess": (
        _optional(bool, Mapping, Preprocessing),
        "a Preprocessing, a dict of its options, True, False or None",
    ),
    "rest_velocity": (
        lambda v: v is None or _real(v) or isinstance(v, (str, list, tuple, np.ndarray)),
        'a speed [rad/s], one per joint, "auto" or None',
    ),
    "rest_fraction": (_real, "a fraction in [0, 1)"),
    "payload": (lambda v: v is None or isinstance(v, (*_PATH, Mapping)) or hasattr(v, "mass"), "a Payload or its TOML"),
    "payload_data": (lambda v: v is None or _recordings(v), "recordings with the payload"),
    "stribeck_velocity": (
        lambda v: v is None or _real(v) or isinstance(v, (str, Mapping)),
        'a speed [rad/s] or "auto"',
    ),
    "stribeck_shape": (lambda v: v is None or _real(v) or isinstance(v, (str, Mapping)), 'a shape or "auto"'),
    "fit_joints": (
        lambda v: (
            v is None or isinstance(v, str) or (isinstance(v, (list, tuple)) and all(isinstance(j, str) for j in v))
        ),
        '"J1,J2" or a list of joint names',
    ),
    "delay": (lambda v: v is None or _real(v) or isinstance(v, (str, Mapping)), 'seconds, "tau.knee=0.04" or "auto"'),
    "floating": (
        lambda v: v is None or isinstance(v, Mapping) or type(v).__name__ == "FloatingOptions",
        "pinid.identification.floating.FloatingOptions or None",
    ),
    "segmental": (_optional(Mapping), "{'first': recordings, 'joints': first joints}"),
    "offsets": (_optional(str), '"per-recording" or None (the terms\' offset, if any)'),
    "calibrate_offsets": (lambda v: v is None or _real(v), "a fraction 0 < f ≤ 0.5 or None"),
    "manifest": (_optional(*_PATH), "the path of the manifest the study was read from"),
}


@dataclass(frozen=True)
class Study:
    """What is identified, from what: ``model`` (a RobotModel, URDF path or bundled robot's name, resolved once
    to a RobotModel), ``data`` (training recordings: Datasets, paths, a floating base's samples), ``validate``
    (recordings or ``{label: recordings}``), ``terms`` (``"default"``: Coulomb and viscous friction, and a constant
    offset when the training recordings' held-out blocks say it wins — :mod:`pinid.identification.term_choice`;
    ``"auto"``, forward selection),
    ``mapping`` (the recordings' mapping spec), ``preprocess`` (a :class:`~pinid.data.preprocess.Preprocessing`
    or its dict form, kept as the dict: :meth:`~pinid.data.preprocess.Preprocessing.normalize`), ``rest_velocity`` [rad/s] (default ``"auto"``)
    and ``rest_fraction`` (the rows at rest dropped), ``payload`` with ``payload_data`` (drive gains from
    currents), ``stribeck_velocity`` [rad/s] and ``stribeck_shape``, ``fit_joints``, ``delay`` [s],
    ``floating`` (:class:`~pinid.identification.floating.FloatingOptions` of a floating base), ``segmental``
    (``compare``'s seed-000 two-stage strategy), ``offsets`` (``"per-recording"``: one torque offset per joint
    per training recording, :mod:`pinid.identification.offsets`) with ``calibrate_offsets`` (a fraction f: each
    validation recording's offsets fitted on its first f, the rest scored) and ``manifest`` (the file the study
    was read from, set by :meth:`from_manifest`).  See :func:`pinid.identification.run.identify` for what each one does.
    A wrong type or an unknown field: SpecError (one line)."""

    model: RobotModel
    data: Any = None
    validate: Any = None
    terms: Any = "default"
    mapping: Any = None
    preprocess: Any = None
    rest_velocity: Any = "auto"
    rest_fraction: float = REST_FRACTION
    payload: Any = None
    payload_data: Any = None
    stribeck_velocity: Any = None
    stribeck_shape: Any = None
    fit_joints: Any = None
    delay: Any = None
    floating: Any = None
    segmental: Any = None
    offsets: Any = None
    calibrate_offsets: Any = None
    manifest: Any = None

    def __new__(cls, *args, **fields):
        names = [f.name for f in dataclasses.fields(cls)]
        unknown = [k for k in fields if k not in names]
        if unknown or len(args) > len(names):
            extra = ", ".join(unknown) if unknown else f"{len(args)} positional arguments"
            raise SpecError(f"Study: unknown field(s) {extra}, expected some of {', '.join(names)}")
        return super().__new__(cls)

    def __post_init__(self) -> None:
        object.__setattr__(self, "model", _resolve(self.model))
        if self.data is None:
            raise SpecError("Study data: no training recording, expected Datasets or recording paths")
        for name, (accepts, expected) in _CHECKS.items():
            value = getattr(self, name)
            if not accepts(value):
                raise SpecError(f"Study {name}: got {type(value).__name__}, expected {expected}")
        # carried as its dict form from here on (the numbers of the dict form): the one conversion
        object.__setattr__(self, "preprocess", Preprocessing.normalize(self.preprocess, "Study preprocess"))

    @classmethod
    def from_manifest(cls, manifest, model=None, **fields) -> "Study":
        """The study a dataset manifest (a TOML path or :class:`~pinid.data.manifest.Manifest`) describes:
        ``model`` (a RobotModel, URDF path or robot name) with the manifest's drives (a copy), its recordings
        by role (training, validation, payload), its payload, ``fit_joints``, ``delay``, ``offsets`` and
        ``calibrate_offsets`` where ``fields`` give none; ``fields``: the study's other fields (terms, preprocessing …).  SpecError when recordings (or a
        mapping spec: each recording of a manifest has its own) are given besides the manifest."""
        from pinid.data.manifest import Manifest
        from pinid.io import as_path

        if model is None:
            raise SpecError("Study.from_manifest: a manifest does not name the robot, expected model=")
        model = _resolve(model)  # a floating robot's recordings are read with their base and contact channels
        m = manifest if isinstance(manifest, Manifest) else Manifest.load(as_path(manifest, "manifest"))
        keys = {"data": "data", "validate": "validate", "payload": "payload", "payload_data": "payload data"}
        clash = [
            keys.get(k, k)
            for k in ("data", "validate", "payload", "payload_data", "mapping")
            if fields.get(k) is not None and not (isinstance(fields[k], (list, tuple, dict)) and not fields[k])
        ]
        if clash:
            raise SpecError(
                f"{m.path}: the manifest lists the recordings, and {', '.join(clash)} given too; "
                "expected one or the other"
            )
        for k in ("data", "validate", "payload", "payload_data", "mapping", "manifest"):
            fields.pop(k, None)
        if m.drives is not None:  # a copy: the caller's model keeps its own drives
            model = model.with_drives(m.drives)
        read = m.read(model)
        if fields.get("fit_joints") is None:
            fields["fit_joints"] = m.fit_joints
        for k in ("delay", "offsets", "calibrate_offsets"):
            if fields.get(k) is None:
                fields[k] = getattr(m, k)
        return cls(
            model,
            read.train,
            read.validate,
            payload=None if m.payload is None else m.payload,
            payload_data=read.payload_data,
            manifest=str(m.path),
            **fields,
        )


# the fields, not __new__'s (*args, **fields), in help() and docs/api.md
Study.__signature__ = inspect.Signature(list(inspect.signature(Study.__init__).parameters.values())[1:])


def _resolve(model) -> RobotModel:
    """A RobotModel as it is, or loaded from a URDF path or robot name; SpecError for anything else."""
    if isinstance(model, RobotModel):
        return model
    if isinstance(model, _PATH):
        return RobotModel.from_urdf(model)
    raise SpecError(f"Study model: got {type(model).__name__}, expected a RobotModel, URDF path or robot name")
