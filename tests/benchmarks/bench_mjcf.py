"""Benchmark: how closely MuJoCo simulating pinid's exported MJCF agrees with pinid/Pinocchio (issue 27).

    python tests/benchmarks/bench_mjcf.py [--states N]

For exo_leg, apal_leg, ur5, panda (fingers locked) and solo12 with a fixed base, and solo12 and exo_leg with a
free joint: an identified-like model (every body's mass distribution moved 20 %, fc, fv, armature in
[0.05, 0.5]), exported to MJCF and loaded by mujoco; over N random states the largest relative difference of
the mass matrix (mj_fullM vs crba + armature) and of the joint accelerations (mj_forward vs pinid's forward
dynamics, Coulomb friction added to pinid's torque since MuJoCo's frictionloss is switched off; free joint:
Pinocchio's ABA, velocities converted), and the time to write the MJCF.
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np
import pinocchio as pin

from pinid import TermSelection, RobotModel, standard_parameters
from pinid.identification.identified import IdentifiedModel
from pinid.model.bundled import example_robot_data_dir
from pinid.model.mjcf import exported_pin_model, joint_fields
from pinid.simulation.cad import perturb

TERMS = TermSelection(coulomb=True, viscous=True, armature=True)


def identified(robot, seed=0):
    rng = np.random.default_rng(seed)
    theta = standard_parameters(perturb(robot, 20.0, rng), TERMS)
    theta[10 * robot.nv :] = rng.uniform(0.05, 0.5, robot.nv * len(TERMS))
    return IdentifiedModel(robot, TERMS, theta, meta={"method": "bench"})


def compiled(text, floating):
    m = mujoco.MjModel.from_xml_string(text)
    for f in ("FRICTIONLOSS", "CONTACT") + (("CONSTRAINT",) if floating else ()):
        m.opt.disableflags |= getattr(mujoco.mjtDisableBit, f"mjDSBL_{f}")
    return m, mujoco.MjData(m)


def rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def measure(name: str, floating: bool, n: int) -> tuple[float, float, float]:
    path = example_robot_data_dir() / "solo_description/robots/solo12.urdf" if name == "solo12" else name
    robot = RobotModel.from_urdf(path)
    model = identified(robot)
    t0 = time.perf_counter()
    text = model.export_mjcf(floating=floating)
    seconds = time.perf_counter() - t0
    m, d = compiled(text, floating)
    M_mj = np.zeros((m.nv, m.nv))
    em = ea = 0.0
    rng = np.random.default_rng(1)
    if not floating:
        q, dq, _ = robot.random_states(n, rng)
        tau = rng.uniform(-5, 5, q.shape)
        ddq, M = model.forward_dynamics(q, dq, tau + model.fc * np.sign(dq)), model.mass_matrix(q)
        for k in range(n):
            d.qpos[:], d.qvel[:], d.ctrl[:] = q[k], dq[k], tau[k]
            mujoco.mj_forward(m, d)
            mujoco.mj_fullM(m, d, M_mj)
            em, ea = max(em, rel(M_mj, M[k])), max(ea, rel(d.qacc, ddq[k]))
        return em, ea, seconds
    pm = exported_pin_model(robot, model.theta, floating=True)
    fields, _ = joint_fields(robot, model.theta, TERMS)
    pm.armature[6:] = fields["armature"]
    pd = pm.createData()
    for _ in range(n):
        quat = rng.normal(size=4)
        q = np.r_[rng.normal(size=3), quat / np.linalg.norm(quat), rng.uniform(-1.5, 1.5, robot.nv)]
        v, tau = rng.normal(size=pm.nv), np.r_[np.zeros(6), rng.uniform(-5, 5, robot.nv)]
        a = pin.aba(pm, pd, q, v, tau - np.r_[np.zeros(6), fields["damping"] * v[6:]])
        M = pin.crba(pm, pd, q)
        M = np.triu(M) + np.triu(M, 1).T
        R = pin.Quaternion(q[3:7]).toRotationMatrix()
        T = np.eye(pm.nv)
        T[:3, :3] = R.T
        d.qpos[:], d.qvel[:], d.ctrl[:] = np.r_[q[:3], q[6], q[3:6], q[7:]], np.r_[R @ v[:3], v[3:]], tau[6:]
        mujoco.mj_forward(m, d)
        mujoco.mj_fullM(m, d, M_mj)
        expected = np.r_[R @ (a[:3] + np.cross(v[3:6], v[:3])), a[3:]]
        em, ea = max(em, rel(M_mj, T.T @ M @ T)), max(ea, rel(d.qacc, expected))
    return em, ea, seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=1000)
    n = ap.parse_args().states
    print(f"mujoco {mujoco.__version__}, pinocchio {pin.__version__}; {n} random states per robot")
    print(f"{'robot':<10} {'base':<9} {'max rel M':>10} {'max rel qacc':>13} {'export [ms]':>12}")
    for name, floating in [(r, False) for r in ("exo_leg", "apal_leg", "ur5", "panda", "solo12")] + [
        ("solo12", True),
        ("exo_leg", True),
    ]:
        em, ea, s = measure(name, floating, n)
        print(f"{name:<10} {'floating' if floating else 'fixed':<9} {em:>10.2e} {ea:>13.2e} {1e3 * s:>12.1f}")


if __name__ == "__main__":
    main()
