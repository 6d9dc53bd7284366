"""Drive gains from currents with a known payload (Gautier & Briot 2014; Mamedov & Mikhel).

When a rig records motor currents ``i`` [A] instead of torques, each torque channel is ``τ_j = k_j·i_j``
with an unknown gain ``k_j`` [N·m/A].  From one recording alone the gains cannot be told from the
parameters (``k`` and ``θ`` scaled together fit as well); a second recording with a **known payload**
fixed to a link fixes the scale.  Both recordings go into one linear least-squares problem in the base
parameters ``θ_b`` and the gains ``k``, the payload's known torque moved to the right-hand side::

    unloaded rows:  W_b·θ_b − diag(i)·k = 0
    loaded rows:    W_b·θ_b − diag(i)·k = −Y_link·φ_payload

``Y_link`` are the ten inertial regressor columns of the body the payload is fixed to and
``φ_payload`` the payload's inertial parameters in that body's joint frame.  The gains then turn every
recording's currents into torques and the usual identification runs on them
(:func:`pinid.identify` with ``payload=``/``payload_data=``; ``pinid identify --payload --payload-data``).

Gains are per torque channel as the dataset holds it (after a mapping spec's scale and transmission).
The payload TOML::

    link = "shank"               # optional: default the child link of the last joint
    mass = 2.0                   # [kg]
    com = [0.0, 0.0, -0.30]      # [m], centre of mass in the link frame
    inertia = [0.01, 0.01, 0.002, 0.0, 0.0, 0.0]   # [kg·m²] ixx iyy izz ixy ixz iyz about the CoM (default 0)
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Mapping, Sequence

import numpy as np
import pinocchio as pin

from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError
from pinid.problem.problem import IdentificationProblem
from pinid.model.base import BaseParameters
from pinid.model.regressor import regressor
from pinid.model.terms import TermSelection
from pinid.model.robot import INERTIA_TOL, RobotModel

_KEYS = ("link", "mass", "com", "inertia")
#: Payload masses accepted [kg]: from a gram (lighter ones vanish in the noise and cannot fix the gains)
#: to ten tonnes (heavier is a unit or typing error).
PAYLOAD_MASS = (1e-3, 1e4)
#: Largest distance [m] of the payload's centre of mass from its link frame, per coordinate (also its
#: radius of gyration bound: each principal moment is at most mass × PAYLOAD_DISTANCE²).
PAYLOAD_DISTANCE = 10.0


@dataclass(frozen=True)
class Payload:
    """A known rigid payload fixed to ``link``: ``mass`` [kg], ``com`` (3,) [m] in the link frame,
    ``inertia`` (3, 3) [kg·m²] about the centre of mass in link axes."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray
    link: str | None = None
    origin: str = "payload"

    @classmethod
    def from_dict(cls, d: Mapping, origin: str = "payload") -> "Payload":
        """Build from the TOML table (see the module text); SpecError naming the bad key."""
        if not isinstance(d, Mapping):
            raise SpecError(f"{origin}: got {type(d).__name__}, expected a table with mass, com, inertia (and link)")
        unknown = [k for k in d if k not in _KEYS]
        if unknown:
            raise SpecError(f"{origin}: unknown key(s) {unknown}, expected some of {list(_KEYS)}")
        if not isinstance(d, Mapping):
            raise SpecError(f"{origin}: expected a table with mass, com and inertia")
        mass = _numbers(d, "mass", 1, origin)[0] if "mass" in d else None
        if mass is None or not PAYLOAD_MASS[0] <= mass <= PAYLOAD_MASS[1]:
            raise SpecError(
                f"{origin}: mass {d.get('mass')!r}, expected a mass from {PAYLOAD_MASS[0]:g} to {PAYLOAD_MASS[1]:g} kg"
            )
        com = _numbers(d, "com", 3, origin) if "com" in d else np.zeros(3)
        if np.abs(com).max() > PAYLOAD_DISTANCE:
            raise SpecError(
                f"{origin}: com {com.tolist()}, expected each coordinate within ±{PAYLOAD_DISTANCE:g} m of the link frame"
            )
        i = _numbers(d, "inertia", 6, origin) if "inertia" in d else np.zeros(6)
        inertia = np.array([[i[0], i[3], i[4]], [i[3], i[1], i[5]], [i[4], i[5], i[2]]])
        e = np.linalg.eigvalsh(inertia)
        tol = INERTIA_TOL * np.abs(e).sum() + 1e-12
        if e[0] < -tol or e[0] + e[1] < e[2] - tol or e[2] > mass * PAYLOAD_DISTANCE**2:
            why = (
                "a negative principal moment"
                if e[0] < -tol
                else "one moment larger than the sum of the other two"
                if e[0] + e[1] < e[2] - tol
                else f"a moment above mass × ({PAYLOAD_DISTANCE:g} m)²"
            )
            raise SpecError(
                f"{origin}: inertia {i.tolist()} has principal moments {e[0]:.3g}, {e[1]:.3g}, {e[2]:.3g} kg·m² "
                f"({why}); expected a physical inertia (moments >= 0, each at most the sum of the other two)"
            )
        link = d.get("link")
        if link is not None and not isinstance(link, str):
            raise SpecError(f"{origin}: link {link!r}, expected a link name")
        return cls(float(mass), com, inertia, link, origin)

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Payload":
        """Read a payload TOML file (see the module text)."""
        from pinid.io import read_toml

        p = Path(path)
        if not p.exists():
            raise SpecError(f"{p}: payload file not found, expected a TOML file with mass, com and inertia")
        d = read_toml(p, "payload file with mass, com and inertia")  # a regular file, bounded, depth-limited
        return cls.from_dict(d, str(p))

    def body(self, model: RobotModel) -> tuple[int, np.ndarray]:
        """``(j, φ)``: index of the joint whose body carries the payload and the payload's ten inertial
        parameters in that joint's frame, in pinid's column order (m, m·c, inertia about the origin)."""
        pm = model.pin_model
        link = self.link
        if link is None:
            last = pm.njoints - 1
            frames = [f for f in pm.frames if f.parentJoint == last and f.type == pin.FrameType.BODY]
            link = frames[-1].name if frames else pm.names[last]
        if not pm.existBodyName(link):
            bodies = [f.name for f in pm.frames if f.type == pin.FrameType.BODY]
            raise SpecError(f"{self.origin}: link {link!r} is not in {model.name}, expected one of {bodies}")
        frame = pm.frames[pm.getBodyId(link)]
        if frame.parentJoint == 0:
            raise SpecError(f"{self.origin}: link {link!r} does not move (fixed to the base), expected a moving link")
        inertia = frame.placement.act(pin.Inertia(self.mass, np.asarray(self.com, dtype=float), self.inertia))
        return frame.parentJoint - 1, np.asarray(inertia.toDynamicParameters(), dtype=float)


def _numbers(d: Mapping, key: str, n: int, origin: str) -> np.ndarray:
    v = d[key]
    v = [v] if n == 1 and not isinstance(v, (list, tuple)) else v
    ok = isinstance(v, (list, tuple)) and all(
        isinstance(x, (int, float)) and not isinstance(x, bool) for x in v
    )  # true is not 1 kg, "2" is not a number
    a = np.asarray(v, dtype=float).reshape(-1) if ok else np.array([])
    if a.size != n or not np.all(np.isfinite(a)):
        raise SpecError(f"{origin}: {key} = {d[key]!r}, expected {n} finite number{'s' if n > 1 else ''}")
    return a


@dataclass
class DriveGains:
    """Identified drive gains: ``gains`` [N·m per unit of the recorded channel], their standard deviations
    ``std`` (same unit, from the residual), per joint; ``condition`` of the joint problem."""

    joints: list[str]
    gains: np.ndarray
    std: np.ndarray
    condition: float
    rows: int
    residual_rms: float

    def apply(self, ds: Dataset) -> Dataset:
        """The recording with its currents turned into torques (``tau · gains``)."""
        if ds.tau is None:
            raise DataError(f"{ds.source}: no current (tau) columns, expected currents to scale by the drive gains")
        out = ds.reorder(self.joints) if list(ds.joints) != self.joints else ds
        return Dataset(
            out.t,
            out.q,
            list(out.joints),
            out.dq,
            out.ddq,
            out.tau * self.gains,
            out.source,
            {
                **out.meta,
                "drive_gains": self.gains.tolist(),
                **(
                    {"recorded": self.apply(out.meta["recorded"])}
                    if isinstance(out.meta.get("recorded"), Dataset)
                    else {}
                ),
            },
        )

    def summary(self) -> dict:
        """JSON-ready figures."""
        return {
            "joints": self.joints,
            "gains": self.gains.tolist(),
            "std": self.std.tolist(),
            "condition": self.condition,
            "rows": self.rows,
            "residual_rms": self.residual_rms,
        }


#: A payload lighter than this fraction of the robot's moving mass cannot fix the gains' scale.
PAYLOAD_MIN_FRACTION = 1e-3
#: ... and one heavier than this multiple of it is a unit or typing error.
PAYLOAD_MAX_MULTIPLE = 1e3
#: A payload's centre of mass lies within this multiple of the robot's reach from its link's origin.
PAYLOAD_REACH_MULTIPLE = 10.0


def check_payload(payload: Payload, model: RobotModel) -> None:
    """SpecError (one line, naming the payload file and the key) when the payload's ``mass`` or ``com`` is
    out of the range a payload fixed to ``model`` can have: mass between :data:`PAYLOAD_MIN_FRACTION` and
    :data:`PAYLOAD_MAX_MULTIPLE` times the robot's moving mass, centre of mass within
    :data:`PAYLOAD_REACH_MULTIPLE` times the robot's reach (joint offsets plus the farthest link centre of
    mass; at least 1 m) of the link's origin.  Checked before any fit, so that ``com = [1e200, 0, 0]`` is
    not reported as NaN torques, nor ``mass = 1e-300`` as a wrong current sign."""
    pm = model.pin_model
    robot_mass = float(sum(pm.inertias[i].mass for i in range(1, pm.njoints)))
    lo, hi = PAYLOAD_MIN_FRACTION * robot_mass, PAYLOAD_MAX_MULTIPLE * robot_mass
    if robot_mass > 0 and not lo <= payload.mass <= hi:
        raise SpecError(
            f"{payload.origin}: mass = {payload.mass:g} kg, expected between {lo:.3g} and {hi:.3g} kg "
            f"({PAYLOAD_MIN_FRACTION:g} to {PAYLOAD_MAX_MULTIPLE:g} × the {robot_mass:.3g} kg that "
            f"{model.name}'s joints move): a lighter payload cannot fix the gains' scale"
        )
    reach = sum(float(np.linalg.norm(pm.jointPlacements[i].translation)) for i in range(1, pm.njoints))
    reach += max((float(np.linalg.norm(pm.inertias[i].lever)) for i in range(1, pm.njoints)), default=0.0)
    limit = max(1.0, PAYLOAD_REACH_MULTIPLE * reach)
    big = float(np.abs(payload.com).max(initial=0.0))
    distance = big * float(np.linalg.norm(np.asarray(payload.com) / big)) if big > 0 else 0.0  # no overflow
    if not distance <= limit:
        raise SpecError(
            f"{payload.origin}: com = {np.asarray(payload.com).tolist()} is {distance:.3g} m from the link's "
            f"origin, expected a point on or near {model.name} (within {limit:.3g} m, "
            f"{PAYLOAD_REACH_MULTIPLE:g} × its reach of {reach:.3g} m) [m]"
        )


def identify_gains(
    model: RobotModel,
    unloaded: Sequence[Dataset],
    loaded: Sequence[Dataset],
    payload: Payload,
    *,
    terms: TermSelection = TermSelection(),
    base: BaseParameters | None = None,
    rest_velocity="auto",
) -> DriveGains:
    """Drive gains from prepared recordings without and with ``payload`` (see the module text).

    The datasets' ``tau`` columns hold the currents.  DataError when the payload recording does not
    make the gains identifiable (a gain whose column the payload torque does not reach).
    """
    if not loaded:
        raise DataError("drive gains: no recording with the payload, expected at least one (--payload-data)")
    check_payload(payload, model)
    j_body, phi = payload.body(model)
    parts = []
    for datasets, with_payload in ((list(unloaded), False), (list(loaded), True)):
        if not datasets:
            continue
        p = IdentificationProblem.from_datasets(model, datasets, terms=terms, base=base, rest_velocity=rest_velocity)
        base = p.base
        rhs = np.zeros(p.rows)
        if with_payload:
            q, dq, ddq = (
                np.concatenate([getattr(ds.reorder(model.joint_names), k) for ds in datasets])
                for k in ("q", "dq", "ddq")
            )
            y = regressor(model, q, dq, ddq, TermSelection(names=[]))[:, 10 * j_body : 10 * j_body + 10] @ phi
            rhs = -y[p.sample * model.nv + p.joint]
        currents = np.zeros((p.rows, model.nv))
        currents[np.arange(p.rows), p.joint] = -p.tau
        parts.append((np.hstack([p.W, currents]), rhs))
    A = np.vstack([a for a, _ in parts])
    b = np.concatenate([r for _, r in parts])
    scale = np.linalg.norm(A, axis=0)
    scale[scale == 0] = 1.0
    x, _, rank, sv = np.linalg.lstsq(A / scale, b, rcond=None)
    nb = A.shape[1] - model.nv
    if rank < A.shape[1]:
        raise DataError(
            f"drive gains: the recordings leave {A.shape[1] - rank} combination(s) of parameters and "
            f"gains undetermined, expected a payload recording that moves every joint it loads"
        )
    x /= scale
    r = A @ x - b
    dof = max(len(b) - A.shape[1], 1)
    sigma2 = float(r @ r) / dof
    cov = sigma2 * np.linalg.inv((A / scale).T @ (A / scale)) / np.outer(scale, scale)
    gains = x[nb:]
    if np.any(gains <= 0):
        bad = [n for n, g in zip(model.joint_names, gains) if g <= 0]
        raise DataError(
            f"drive gains: non-positive gain for joint(s) {bad}, expected currents that push the joint "
            f"the way the torque does (check the sign of the current columns)"
        )
    return DriveGains(
        list(model.joint_names),
        gains,
        np.sqrt(np.diag(cov)[nb:]),
        float(sv[0] / sv[-1]),
        len(b),
        float(np.sqrt(np.mean(r * r))),
    )
