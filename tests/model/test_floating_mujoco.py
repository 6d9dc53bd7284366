"""The floating-base conventions checked against an independent engine (issue 33): MuJoCo's own URDF import
(not pinid's MJCF exporter) with a free joint computes, by inverse dynamics, the joint torques and the harness
wrench at the pelvis of a known motion; pinid reads them in its floating CSV format and recovers the URDF's
parameters."""

from __future__ import annotations

import numpy as np
import pytest

from pinid import RobotModel
from pinid.identification.study import Study
from pinid.estimators import make_estimator
from pinid.excitation.trajectory import FourierTrajectory
from pinid.problem.recordings import load_datasets
from pinid.identification.run import identify
from pinid.model.terms import TermSelection
from pinid.problem.floating import floating_problem
from pinid.resources import URDF_DIR

mujoco = pytest.importorskip("mujoco")

NONE = TermSelection.from_names("none")  # MuJoCo's damping and friction loss are set to zero below
RATE, SECONDS = 1000, 4.0
#: base orientation: Euler angles z, y, x (R = Rz·Ry·Rx) [rad], frequencies [Hz]; base position [m], [Hz]
ANGLE, ANGLE_HZ = np.array([0.3, 0.2, 0.4]), np.array([0.23, 0.31, 0.17])
SHIFT, SHIFT_HZ = np.array([0.05, 0.04, 0.03]), np.array([0.19, 0.27, 0.35])


def _rotation(t: float) -> np.ndarray:
    z, y, x = ANGLE * np.sin(2 * np.pi * ANGLE_HZ * t)
    cz, sz, cy, sy, cx, sx = np.cos(z), np.sin(z), np.cos(y), np.sin(y), np.cos(x), np.sin(x)
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    return rz @ ry @ rx


def _omega_body(t: float) -> np.ndarray:
    """Angular velocity of R = Rz·Ry·Rx in the BODY frame [rad/s] (MuJoCo's free-joint angular qvel)."""
    w = 2 * np.pi * ANGLE_HZ
    z, y, x = ANGLE * np.sin(w * t)
    dz, dy, dx = ANGLE * w * np.cos(w * t)
    return np.array(
        [dx - dz * np.sin(y), dy * np.cos(x) + dz * np.cos(y) * np.sin(x), -dy * np.sin(x) + dz * np.cos(y) * np.cos(x)]
    )


def mujoco_suspended(path, exo, *, world_frame_force: bool = False) -> float:
    """Write pinid's floating CSV of the exoskeleton moved by a known base and joint motion, its joint torques
    and the harness wrench at the pelvis (on the robot, pelvis frame, about its origin) from MuJoCo's inverse
    dynamics (``mj_inverse``: the free joint's generalised force).  MuJoCo's free joint: linear qvel/qacc of the
    body origin in the WORLD frame, angular in the BODY frame, quaternion w first; its generalised force:
    force in the world frame, moment in the body frame.  ``world_frame_force``: the deliberate mistake of
    leaving the force in MuJoCo's world frame.  Returns MuJoCo's total mass [kg]."""
    spec = mujoco.MjSpec.from_string((URDF_DIR / "exo_lower_body.urdf").read_text())
    spec.worldbody.first_body().add_freejoint()
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT  # no joint limits, no friction loss
    m = spec.compile()
    m.dof_damping[:] = 0.0
    m.dof_armature[:] = 0.0
    d = mujoco.MjData(m)
    jid = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in exo.joint_names]
    qadr, vadr = m.jnt_qposadr[jid], m.jnt_dofadr[jid]
    rng = np.random.default_rng(0)
    span = (exo.upper - exo.lower)[:, None]
    a, b = (rng.uniform(-1, 1, (exo.nv, 4)) * 0.08 * span for _ in range(2))
    joints = FourierTrajectory(exo.joint_names, 2 * np.pi * 0.2, 0.5 * (exo.lower + exo.upper), a, b)
    t = np.arange(int(SECONDS * RATE) + 1) / RATE
    q, dq, ddq = joints.evaluate(t)
    pw = 2 * np.pi * SHIFT_HZ
    h = 1e-4  # ω̇ by a 5-point stencil of the analytic ω: error ~1e-13 rad/s²
    rows = []
    for k, tk in enumerate(t):
        rot = _rotation(tk)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, rot.ravel())
        d.qpos[:3] = np.array([0.0, 0.0, 1.0]) + SHIFT * np.sin(pw * tk)
        d.qpos[3:7] = quat
        d.qvel[:3] = SHIFT * pw * np.cos(pw * tk)
        d.qvel[3:6] = _omega_body(tk)
        d.qacc[:3] = -SHIFT * pw**2 * np.sin(pw * tk)
        d.qacc[3:6] = (
            -_omega_body(tk + 2 * h) + 8 * _omega_body(tk + h) - 8 * _omega_body(tk - h) + _omega_body(tk - 2 * h)
        ) / (12 * h)
        d.qpos[qadr], d.qvel[vadr], d.qacc[vadr] = q[k], dq[k], ddq[k]
        mujoco.mj_inverse(m, d)
        f = d.qfrc_inverse
        force = f[:3] if world_frame_force else rot.T @ f[:3]
        rows.append(np.r_[tk, q[k], f[vadr], d.qpos[:3], quat[1:], quat[0], force, f[3:6]])
    cols = ["t"] + [f"q_{j}" for j in exo.joint_names] + [f"tau_{j}" for j in exo.joint_names]
    cols += [f"base_{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw")]
    cols += [f"wrench_pelvis_{c}" for c in ("fx", "fy", "fz", "tx", "ty", "tz")]
    np.savetxt(path, np.array(rows), delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    return float(m.body_mass.sum())


@pytest.fixture(scope="module")
def exo():
    return RobotModel.from_urdf("exo_lower_body", base="floating")


def test_mujoco_suspended_recording_recovers_the_urdf(exo, tmp_path):
    """Noise-free, 1 kHz, 4 s, pinid's default preprocessing: the total mass to 1e-4 kg (measured 4e-7) and the
    66 base parameters to a median 1e-4 of their natural scale (measured 2.2e-5)."""
    mass = mujoco_suspended(tmp_path / "mj.csv", exo)
    assert mass == pytest.approx(21.8, abs=1e-12)
    ident = identify(Study(exo, tmp_path / "mj.csv", terms=NONE), methods=("ols", "sdp"))
    assert ident.base["names"][0] == "base.mR"
    for method in ("ols", "sdp"):
        assert abs(ident.results[method].base[0] - mass) <= 1e-4, method
    problem = floating_problem(exo, load_datasets(tmp_path / "mj.csv", exo), terms=NONE)
    error = np.abs(make_estimator("ols").fit(problem).base_ - problem.nominal_base) / problem.natural_scale
    assert problem.nb == 66 and np.median(error) <= 1e-4


def test_mujoco_force_left_in_the_world_frame_is_visibly_wrong(exo, tmp_path):
    """The same check fails when a convention is wrong (here MuJoCo's world-frame force written as the
    pelvis-frame wrench): the check is able to fail."""
    mujoco_suspended(tmp_path / "mj.csv", exo, world_frame_force=True)
    problem = floating_problem(exo, load_datasets(tmp_path / "mj.csv", exo), terms=NONE)
    error = np.abs(make_estimator("ols").fit(problem).base_ - problem.nominal_base) / problem.natural_scale
    assert np.median(error) > 1e-2
