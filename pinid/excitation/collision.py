"""Self-collision between the legs along a trajectory (``pinid excite --base floating``).

The collision geometry is the URDF's ``<collision>`` elements (Pinocchio's geometry model, hpp-fcl
distances).  The pairs checked are those between bodies on *different branches* of the base link: one
body in each leg (no body is an ancestor of the other, neither is the base link), e.g. for
``exo_lower_body`` the 16 pairs of {l_hip, l_thigh, l_shank, l_foot} × {r_hip, …, r_foot}.  Bodies of one
leg, and a leg against the pelvis, are not checked (adjacent bodies overlap by construction of simple
shapes).  One period of the trajectory is checked on a grid (default 50 samples per harmonic, at least 400), and its smallest distance must stay above ``margin`` (default 0.02 m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pinid.errors import ModelError, SpecError
from pinid.excitation.trajectory import FourierTrajectory
from pinid.model.robot import RobotModel

#: Smallest distance [m] kept between the legs' collision shapes.
COLLISION_MARGIN = 0.02


@dataclass(frozen=True)
class CollisionCheck:
    """The smallest distance [m] between the checked pairs, where (pair, time [s]) and the margin."""

    distance: float
    pair: tuple[str, str]
    time: float
    margin: float
    pairs: int

    @property
    def ok(self) -> bool:
        return self.distance >= self.margin

    def text(self) -> str:
        verdict = "clear" if self.ok else "TOO CLOSE"
        return (
            f"self-collision ({self.pairs} pairs between the legs): smallest distance {self.distance:.4f} m "
            f"({self.pair[0]}–{self.pair[1]} at t = {self.time:.3f} s), margin {self.margin:g} m: {verdict}"
        )


def leg_pairs(model: RobotModel) -> tuple[pin.GeometryModel, list[tuple[int, int]]]:
    """The collision geometry of ``model``'s URDF and the pairs between bodies of different branches."""
    m = model.pin_model
    if model.urdf_path is None:
        raise ModelError(f"{model.name}: no URDF path, so no collision geometry")
    geom = pin.buildGeomFromUrdf(m, str(model.urdf_path), pin.GeometryType.COLLISION)
    objs = list(geom.geometryObjects)
    pairs = []
    for a in range(len(objs)):
        for b in range(a + 1, len(objs)):
            ja, jb = objs[a].parentJoint, objs[b].parentJoint
            if ja == 0 or jb == 0 or ja in m.supports[jb] or jb in m.supports[ja]:
                continue
            pairs.append((a, b))
    for a, b in pairs:
        geom.addCollisionPair(pin.CollisionPair(a, b))
    return geom, pairs


def check_self_collision(
    model: RobotModel,
    trajectory: FourierTrajectory,
    *,
    margin: float = COLLISION_MARGIN,
    samples: int | None = None,
) -> CollisionCheck:
    """The smallest distance between the legs along one period of ``trajectory`` (see the module text)."""
    if not (np.isfinite(margin) and margin >= 0):
        raise SpecError(f"margin={margin!r}, expected a distance >= 0 [m]")
    geom, pairs = leg_pairs(model)
    if not pairs:
        raise ModelError(f"{model.name}: no pair of collision shapes on different branches to check")
    traj = trajectory.for_joints(model.joint_names, model.name)
    n = samples or max(400, 50 * traj.harmonics)
    t = np.linspace(0.0, traj.period, n, endpoint=False)
    q = np.atleast_2d(traj.evaluate(t)[0])
    gdata = geom.createData()
    data = model.pin_model.createData()
    best = (np.inf, (0, 0), 0.0)
    for k in range(n):
        pin.computeDistances(model.pin_model, data, geom, gdata, model.configuration(q[k]))
        d = np.array([r.min_distance for r in gdata.distanceResults])
        i = int(np.argmin(d))
        if d[i] < best[0]:
            best = (float(d[i]), pairs[i], float(t[k]))
    names = tuple(geom.geometryObjects[j].name for j in best[1])
    return CollisionCheck(best[0], names, best[2], margin, len(pairs))


def shrink_to_clear(
    model: RobotModel, trajectory: FourierTrajectory, *, margin: float = COLLISION_MARGIN, steps: int = 20
) -> tuple[FourierTrajectory, float, CollisionCheck]:
    """``trajectory`` shrunk toward its offsets ``q0`` by the largest factor in (0, 1] (bisection, ``steps``
    halvings) that keeps the legs ``margin`` apart, the factor, and the check.  Shrinking keeps every position,
    velocity and acceleration limit the trajectory met.  SpecError when ``q0`` itself is too close."""
    check = check_self_collision(model, trajectory, margin=margin)
    if check.ok:
        return trajectory, 1.0, check

    def scaled(f: float) -> FourierTrajectory:
        t = trajectory
        return FourierTrajectory(t.joints, t.base_frequency, t.q0, f * t.a, f * t.b, meta=dict(t.meta))

    still = check_self_collision(model, scaled(0.0), margin=margin)
    if not still.ok:
        raise SpecError(
            f"self-collision: the legs are {still.distance:.4f} m apart at the offsets q0 ({still.pair[0]}–"
            f"{still.pair[1]}), less than the margin {margin:g} m; expected offsets that keep the legs apart"
        )
    lo, hi = 0.0, 1.0
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        if check_self_collision(model, scaled(mid), margin=margin).ok:
            lo = mid
        else:
            hi = mid
    out = scaled(lo)
    return out, lo, check_self_collision(model, out, margin=margin)
