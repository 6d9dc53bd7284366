"""The wearer's table values as a prior: standard parameters per body and the bounds the table implies.

From a URDF written by :func:`pinid.wearer.attach.wearer_urdf`: each ``wearer_*`` link's mass, centre
of mass and inertia become standard parameters ``[m, m·c, I about the joint frame]`` of the body of
the joint that moves its exo link (segments on one link add up).  Bounds:

* mass within ``±mass_range`` (default 30 %) of the table value — about two standard deviations of
  Zatsiorsky's segment masses and wider than the ±25 % the twin draws;
* centre of mass inside the segment: along the axis of the body's first segment between the
  segments' proximal and distal ends, and sideways within the segments' radius (√2·longitudinal
  radius of gyration, a uniform cylinder's) — the ``<visual>`` cylinder pinid wearer writes. Linear
  in (m, m·c), so these enter the SDP as they are.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from pinid.errors import SpecError
from pinid.wearer.attach import PREFIX
from pinid.model.robot import as_robot
from pinid.model.urdf import UrdfDocument
from pinid.checks import array_like

#: Default allowed deviation of a wearer body's mass from the table value (fraction).
MASS_RANGE = 0.30


@dataclass
class BodyPrior:
    """The wearer's share of one body: table standard parameters and the CoM box (joint frame)."""

    joint: str
    index: int  # the joint's index in the robot
    theta: np.ndarray  # (10,) table [m, m·c, I about the joint frame]
    axis: np.ndarray  # (3,) unit axis of the body's first segment
    start: float  # [m] CoM lower bound along ``axis``
    end: float  # [m] CoM upper bound along ``axis``
    radius: float  # [m] CoM bound across ``axis``
    segments: list[str] = field(default_factory=list)


def _vec(text):
    return np.array([float(x) for x in (text or "0 0 0").split()])


def wearer_prior(urdf_text: str, robot) -> list[BodyPrior]:
    """The wearer priors of ``robot`` (the exo + wearer RobotModel) from its URDF text, in joint order."""
    if not isinstance(urdf_text, str):
        raise SpecError(f"urdf_text: got {type(urdf_text).__name__}, expected the text of a URDF with a wearer")
    same = urdf_text == getattr(robot, "urdf_text", None)  # the robot's own URDF: its document, read once
    document = robot.urdf_document if same else UrdfDocument.from_text(urdf_text, "urdf_text")
    moved_by = {j.find("child").get("link"): j.get("name") for j in document.joints() if j.find("child") is not None}
    fixed_to = {
        j.find("child").get("link"): j.find("parent").get("link")
        for j in document.joints()
        if j.find("child") is not None
    }
    out: dict[str, BodyPrior] = {}
    for lk in document.links():
        name = lk.get("name") or ""
        if not name.startswith(PREFIX):
            continue
        seg, link = name[len(PREFIX) :], fixed_to.get(name)
        joint = moved_by.get(link)
        if joint not in robot.joint_names:
            raise SpecError(f"wearer segment {seg} sits on link {link!r}, which no active joint of {robot.name} moves")
        i = lk.find("inertial")
        g = {k: float(i.find("inertia").get(k)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        Ic = np.array([[g["ixx"], g["ixy"], g["ixz"]], [g["ixy"], g["iyy"], g["iyz"]], [g["ixz"], g["iyz"], g["izz"]]])
        theta = pin.Inertia(
            float(i.find("mass").get("value")), _vec(i.find("origin").get("xyz")), Ic
        ).toDynamicParameters()
        vis = lk.find("visual/geometry/cylinder")
        if vis is None:
            raise SpecError(f"{name}: no segment cylinder (<visual>); write the prior URDF with pinid wearer")
        o = lk.find("visual/origin")
        d = pin.rpy.rpyToMatrix(*_vec(o.get("rpy")))[:, 2]
        length, radius = float(vis.get("length")), float(vis.get("radius"))
        ends = [_vec(o.get("xyz")) - 0.5 * length * d, _vec(o.get("xyz")) + 0.5 * length * d]
        b = out.get(joint)
        if b is None:
            b = out[joint] = BodyPrior(joint, robot.joint_index(joint), np.zeros(10), d, np.inf, -np.inf, 0.0)
        b.theta = b.theta + theta
        b.segments.append(seg)
        for e in ends:
            along = float(e @ b.axis)
            b.start, b.end = min(b.start, along), max(b.end, along)
            b.radius = max(b.radius, float(np.linalg.norm(e - along * b.axis)) + radius)
    if not out:
        raise SpecError(
            f"{robot.name}: the prior URDF has no wearer segment (links {PREFIX}*); write it with pinid wearer"
        )
    return sorted(out.values(), key=lambda b: b.index)


def drawn(theta: np.ndarray, rng: np.random.Generator, mass: float = 0.25, com: float = 0.20) -> np.ndarray:
    """One body's table parameters (10,) drawn away from the table: mass × (1 ± ``mass``), CoM distance
    from the joint × (1 ± ``com``) (uniform, seeded), inertia about the CoM scaled with the mass."""
    array_like(theta, "theta")
    if not isinstance(rng, np.random.Generator):
        raise SpecError(f"rng: got {type(rng).__name__}, expected a numpy.random.Generator")
    m, c = theta[0], theta[1:4] / theta[0]
    Ic = pin.Inertia.FromDynamicParameters(np.asarray(theta, dtype=float)).inertia
    k, kc = 1 + rng.uniform(-mass, mass), 1 + rng.uniform(-com, com)
    return pin.Inertia(m * k, c * kc, Ic * k).toDynamicParameters()


def draw_wearer(robot, seed: int, mass: float = 0.25, com: float = 0.20):
    """``robot`` (exo + wearer) with its wearer's share of each body replaced by :func:`drawn` — the twin's
    "true" wearer, the same for the same ``seed`` (``pinid simulate`` and ``pinid track --wearer-draw``);
    returns ``(model, {joint: drawn (10,) wearer parameters})``."""
    robot = as_robot(robot)
    if not any(lk.startswith(PREFIX) for lk in re.findall(r'<link\s+name="([^"]*)"', robot.urdf_text or "")):
        raise SpecError(f"{robot.name} carries no wearer to draw (links {PREFIX}*); expected a URDF from pinid wearer")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 2]))
    theta = robot.inertial_parameters().copy()
    out = {}
    for b in wearer_prior(robot.urdf_text, robot):
        w = drawn(b.theta, rng, mass, com)
        theta[10 * b.index : 10 * b.index + 10] += w - b.theta
        out[b.joint] = w
    return robot.with_inertial_parameters(theta), out
