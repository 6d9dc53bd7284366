"""The MuJoCo MJCF export: MuJoCo's dynamics of the exported file are pinid's (Pinocchio's) on the same model."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from pinid import TermSelection, RobotModel, standard_parameters
from pinid.errors import ModelError
from pinid.identification.identified import IdentifiedModel
from pinid.model.bundled import example_robot_data_dir
from pinid.model.physical import com_inertia
from pinid.model.mjcf import exported_pin_model, identified_mjcf, joint_fields
from pinid.model.terms import values as term_values
from pinid.simulation.cad import perturb

from conftest import assert_clean_error, load, run_cli

mujoco = pytest.importorskip("mujoco")

TERMS = TermSelection(coulomb=True, viscous=True, armature=True)


PENDULUM = """<robot name="pendulum">
  <link name="base"/>
  <link name="arm"><inertial><origin xyz="0 0 -0.3"/><mass value="1.0"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.001"/></inertial></link>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="50" velocity="5"/></joint>
</robot>"""


def solo12():
    return load(str(example_robot_data_dir() / "solo_description" / "robots" / "solo12.urdf"))


def robot_named(name, folder=None):
    """A test robot: a bundled / example-robot-data name, solo12, or panda_finger (one prismatic finger active,
    the other, which mimics it, locked open)."""
    if name == "solo12":
        return solo12()
    if name == "exo_continuous":  # the knee a continuous joint (Pinocchio: cos, sin; MuJoCo: an unlimited hinge)
        text = load("exo_leg").urdf_text.replace(
            '<joint name="knee" type="revolute">', '<joint name="knee" type="continuous">'
        )
        path = Path(folder) / "exo_continuous.urdf"
        path.write_text(text)
        return RobotModel.from_urdf(path)
    if name == "exo_hip":  # one active joint (nv = 1): the knee held at its neutral value
        return RobotModel.from_urdf("exo_leg", joints=["hip"])
    if name == "exo_knee_locked":
        return RobotModel.from_urdf("exo_leg", locked={"knee": -0.8})
    if name == "pendulum":
        path = Path(folder) / "pendulum.urdf"
        path.write_text(PENDULUM)
        return RobotModel.from_urdf(path)
    if name == "panda_finger":
        joints = [f"panda_joint{i}" for i in range(1, 8)] + ["panda_finger_joint1"]
        return RobotModel.from_urdf("panda", joints=joints, locked={"panda_finger_joint2": 0.02})
    return load(name)


def identified(model, seed=0, terms=TERMS):
    """A consistent identified-like model: every body's mass distribution moved (20 %), terms in [0.05, 0.5]."""
    rng = np.random.default_rng(seed)
    theta = standard_parameters(perturb(model, 20.0, rng), terms)
    theta[10 * model.nv :] = rng.uniform(0.05, 0.5, model.nv * len(terms))
    return IdentifiedModel(model, terms, theta, meta={"method": "sdp"})


def compiled(text, *flags):
    """The MjModel of ``text`` with the disable ``flags`` (e.g. "CONSTRAINT") set, and its MjData."""
    m = mujoco.MjModel.from_xml_string(text)
    for f in flags:
        m.opt.disableflags |= getattr(mujoco.mjtDisableBit, f"mjDSBL_{f}")
    return m, mujoco.MjData(m)


def full_mass_matrix(m, d):
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    return M


def rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def free_joint_errors(m, d, pm, pd, rng, q_joints, effort, damping):
    """Relative errors of MuJoCo's M(q) and qacc against Pinocchio's free flyer at a random root pose and
    velocity, the joints at ``q_joints`` and torques uniform in ±``effort`` [N·m], viscous ``damping``.
    MuJoCo's qpos is (position, w x y z), its qvel the root's linear velocity in the WORLD frame (Pinocchio:
    root frame): with v_pin = T·v_mj, T = diag(Rᵀ, 1, 1), M_mj = Tᵀ·M_pin·T and the root's linear qacc is
    R·(a + ω × v)."""
    quat = rng.normal(size=4)
    q = np.r_[rng.normal(size=3), quat / np.linalg.norm(quat), q_joints]
    v = rng.normal(size=pm.nv)
    tau = np.r_[np.zeros(6), rng.uniform(-effort, effort, len(q_joints))]
    a = pin.aba(pm, pd, q, v, tau - np.r_[np.zeros(6), damping * v[6:]])
    M = pin.crba(pm, pd, q)
    M = np.triu(M) + np.triu(M, 1).T
    R = pin.Quaternion(q[3:7]).toRotationMatrix()
    T = np.eye(pm.nv)
    T[:3, :3] = R.T
    d.qpos[:] = np.r_[q[:3], q[6], q[3:6], q[7:]]
    d.qvel[:] = np.r_[R @ v[:3], v[3:]]
    d.ctrl[:] = tau[6:]
    mujoco.mj_forward(m, d)
    expected = np.r_[R @ (a[:3] + np.cross(v[3:6], v[:3])), a[3:]]
    return rel(full_mass_matrix(m, d), T.T @ M @ T), rel(d.qacc, expected)


@pytest.mark.parametrize(
    "name",
    ["exo_leg", "exo_continuous", "apal_leg", "ur5", "panda", "panda_finger", "solo12"]
    + ["exo_hip", "exo_knee_locked", "pendulum"],  # one active joint: Pinocchio's Jacobian is 1-D
)
def test_fixed_base_matches_pinid(name, tmp_path):
    """M(q) (mj_fullM vs crba + armature) and qacc (mj_forward vs pinid's forward dynamics) on 50 random states
    inside the limits, to 1e-8 relative; MuJoCo's Coulomb friction (frictionloss, a constraint) switched off
    and added to pinid's torque instead, damping and armature included on both sides."""
    robot = robot_named(name, tmp_path)
    model = identified(robot)
    m, d = compiled(model.export_mjcf(), "FRICTIONLOSS", "CONTACT")
    assert (m.nv, m.nu) == (robot.nv, robot.nv)
    kinds = [
        mujoco.mjtJoint.mjJNT_SLIDE if j.kind == "prismatic" else mujoco.mjtJoint.mjJNT_HINGE for j in robot.joints
    ]
    assert list(m.jnt_type) == kinds
    assert list(m.jnt_limited) == [bool(np.isfinite(j.lower)) for j in robot.joints]
    q, dq, _ = robot.random_states(50, np.random.default_rng(1))
    tau = np.random.default_rng(2).uniform(-5, 5, q.shape)
    ddq = model.forward_dynamics(q, dq, tau + model.fc * np.sign(dq))
    M = model.mass_matrix(q)
    for k in range(len(q)):
        d.qpos[:], d.qvel[:], d.ctrl[:] = q[k], dq[k], tau[k]
        mujoco.mj_forward(m, d)
        assert rel(full_mass_matrix(m, d), M[k]) < 1e-8
        assert rel(d.qacc, ddq[k]) < 1e-8, (k, d.qacc, ddq[k])


@pytest.mark.parametrize("name", ["solo12", "exo_leg"])
def test_floating_base_matches_pinocchio(name):
    """A free joint: MuJoCo's qpos is (position, w x y z), its qvel (linear velocity of the root in the WORLD
    frame, angular velocity in the root frame); Pinocchio's free flyer has both in the root frame.  With
    v_pin = T·v_mj, T = diag(Rᵀ, 1, 1): M_mj = Tᵀ·M_pin·T and the root's linear qacc = R·(a + ω × v)."""
    robot = solo12() if name == "solo12" else load(name)
    model = identified(robot, seed=3)
    m, d = compiled(model.export_mjcf(floating=True), "FRICTIONLOSS", "CONTACT", "CONSTRAINT")
    pm = exported_pin_model(robot, model.theta, floating=True)
    fields, _ = joint_fields(robot, model.theta, TERMS)
    pm.armature[6:] = fields["armature"]
    pd = pm.createData()
    assert (m.nq, m.nv, m.nu) == (pm.nq, pm.nv, robot.nv)
    rng = np.random.default_rng(4)
    for _ in range(30):
        m_err, a_err = free_joint_errors(m, d, pm, pd, rng, rng.uniform(-1.5, 1.5, robot.nv), 5.0, fields["damping"])
        assert m_err < 1e-8 and a_err < 1e-8


def test_frictionloss_is_coulomb_friction_when_sliding():
    """MuJoCo's frictionloss is a (soft) constraint; at sliding velocities (here |dq| ≥ 0.5 rad/s) it saturates at
    fc, and MuJoCo's qacc with it on is pinid's forward dynamics with fc·sign(dq) (measured: 2e-15; below about
    0.1 rad/s the soft constraint holds the joint with less than fc and the two differ, as documented)."""
    robot = load("ur5")
    model = identified(robot, seed=5)
    m, d = compiled(model.export_mjcf(), "CONTACT", "LIMIT")
    rng = np.random.default_rng(6)
    q, _, _ = robot.random_states(20, rng)
    dq = rng.choice([-1.0, 1.0], q.shape) * rng.uniform(0.5, 2.0, q.shape)
    tau = rng.uniform(-5, 5, q.shape)
    ddq = model.forward_dynamics(q, dq, tau)
    for k in range(len(q)):
        d.qpos[:], d.qvel[:], d.ctrl[:] = q[k], dq[k], tau[k]
        mujoco.mj_forward(m, d)
        np.testing.assert_allclose(d.qfrc_constraint, -model.fc * np.sign(dq[k]), rtol=1e-8, atol=1e-12)
        assert rel(d.qacc, ddq[k]) < 1e-8


def test_exported_fields_are_the_identified_values():
    robot = load("exo_leg")
    terms = TermSelection(coulomb=True, viscous=True, armature=True, offset=True)
    model = identified(robot, seed=7, terms=terms)
    text = model.export_mjcf()
    m, _ = compiled(text)
    np.testing.assert_array_equal(m.dof_armature, model.armature)
    np.testing.assert_array_equal(m.dof_damping, model.fv)
    np.testing.assert_array_equal(m.dof_frictionloss, model.fc)
    np.testing.assert_array_equal(m.jnt_range, np.c_[robot.lower, robot.upper])
    np.testing.assert_array_equal(m.actuator_ctrlrange, np.c_[-robot.effort_limit, robot.effort_limit])
    # masses and centres of mass about the joint frames: h = m·c
    theta = model.theta.reshape(-1)[: 10 * robot.nv].reshape(robot.nv, 10)
    np.testing.assert_allclose(m.body_mass[2:], theta[:, 0], rtol=1e-15)
    np.testing.assert_allclose(m.body_ipos[2:] * theta[:, :1], theta[:, 1:4], rtol=1e-14, atol=1e-16)
    assert "not exported: hip.offset" in text  # no MJCF field for a constant torque, and the file says so


def test_rollout_with_pd_control_agrees_with_pinocchio():
    """1 s of PD control toward a set point on ur5: MuJoCo's RK4 (control held over each 1 ms step) against the
    same RK4 on pinid's forward dynamics (Coulomb friction off in both: MuJoCo models it as a soft constraint).
    The same scheme on the same model: they differ only by rounding (bound 1e-12 rad); MuJoCo's default Euler
    (implicit in damping) by its O(dt) error (bound 2e-3 rad at 1 ms, about 5× what it is)."""
    robot = load("ur5")
    model = identified(robot, seed=8)
    dt, steps = 1e-3, 1000
    q0 = np.zeros(robot.nv)
    target = np.array([0.5, -0.8, 1.0, -0.5, 0.7, 0.3])
    kp, kd = 200.0, 20.0

    def control(q, dq):  # clipped to the effort limits, as MuJoCo clips the control to ctrlrange
        return np.clip(kp * (target - q) - kd * dq, -robot.effort_limit, robot.effort_limit)

    def f(q, dq, tau):
        return model.forward_dynamics(q, dq, tau + model.fc * np.sign(dq))  # cancel pinid's Coulomb term

    q, dq = q0.copy(), np.zeros(robot.nv)
    for _ in range(steps):  # classic RK4, zero-order hold on the control, as MuJoCo's mj_RungeKutta
        tau = control(q, dq)
        k1q, k1v = dq, f(q, dq, tau)
        k2q, k2v = dq + 0.5 * dt * k1v, f(q + 0.5 * dt * k1q, dq + 0.5 * dt * k1v, tau)
        k3q, k3v = dq + 0.5 * dt * k2v, f(q + 0.5 * dt * k2q, dq + 0.5 * dt * k2v, tau)
        k4q, k4v = dq + dt * k3v, f(q + dt * k3q, dq + dt * k3v, tau)
        q = q + dt / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
        dq = dq + dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    finals = {}
    for integrator in ("RK4", "EULER"):
        m, d = compiled(model.export_mjcf(), "FRICTIONLOSS", "CONTACT", "LIMIT")
        m.opt.timestep = dt
        m.opt.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrator}")
        for _ in range(steps):
            d.ctrl[:] = control(d.qpos, d.qvel)
            mujoco.mj_step(m, d)
        finals[integrator] = d.qpos.copy()
    assert np.abs(finals["RK4"] - q).max() < 1e-12  # measured 1.1e-16
    assert np.abs(finals["EULER"] - q).max() < 2e-3  # measured 3.6e-4
    assert np.abs(q - q0).max() > 0.1  # it moved


def test_inconsistent_or_massless_models_are_refused(tmp_path):
    robot = load("exo_leg")
    theta = standard_parameters(robot, TERMS)
    bad = theta.copy()
    bad[10] = -1.0  # knee mass
    with pytest.raises(ModelError, match="physically inconsistent.*knee.*MuJoCo needs positive masses"):
        identified_mjcf(robot, bad, TERMS, tmp_path / "x.xml")
    massless = theta.copy()
    massless[10:20] = 0.0  # consistent (a body of nothing), but MuJoCo refuses a massless moving body
    with pytest.raises(ModelError, match="body of joint 'knee' has mass 0 kg; MuJoCo needs"):
        identified_mjcf(robot, massless, TERMS, tmp_path / "x.xml")
    assert not (tmp_path / "x.xml").exists()


def test_absurd_mass_is_refused_as_the_urdf_export_refuses_it(tmp_path):
    """A model with a 1e300 kg body: both exports refuse it in one error, nothing written."""
    robot = load("exo_leg")
    theta = standard_parameters(robot, TermSelection())
    theta[0:10] *= 1e300 / theta[0]
    model = IdentifiedModel(robot, TermSelection(), theta)
    with pytest.raises(ModelError, match="'hip' has mass 1e\\+300 kg; expected 0 to 1e\\+06 kg"):
        model.export_mjcf(tmp_path / "x.xml")
    with pytest.raises(ModelError, match="mass 1e\\+300 kg; expected 0 to 1e\\+06 kg"):
        model.export_urdf(tmp_path / "x.urdf")
    assert not list(tmp_path.iterdir())


def test_consistent_body_with_a_rounding_size_negative_moment_is_exported(tmp_path):
    """The consistency check and the MJCF export share one tolerance: a knee whose smallest principal moment
    is −9.3e-12 kg·m² (as woa produced) is consistent, and its MJCF is written with that moment at MIN_VALUE;
    a moment of −1e-3 kg·m² is refused by both."""
    from pinid.model.mjcf import MIN_VALUE
    from pinid.model.physical import check_consistency

    robot = load("exo_leg")
    theta = standard_parameters(robot, TermSelection())

    def with_moment(x):
        th = theta.copy()
        m, c, I = com_inertia(th[10:20])
        e, V = np.linalg.eigh(I)
        e[0] = x
        e[1] = max(e[1], e[2])  # keep the triangle inequality
        Io = (V * e) @ V.T + m * (c @ c * np.eye(3) - np.outer(c, c))  # about the joint frame's origin
        th[10:20] = [m, *(m * c), Io[0, 0], Io[0, 1], Io[1, 1], Io[0, 2], Io[1, 2], Io[2, 2]]
        return th

    good, bad = with_moment(-9.3e-12), with_moment(-1e-3)
    assert check_consistency(good[:20], robot.joint_names, []).consistent
    assert not check_consistency(bad[:20], robot.joint_names, []).consistent
    m, _ = compiled(IdentifiedModel(robot, TermSelection(), good).export_mjcf())
    assert m.body_inertia[-1].min() == pytest.approx(MIN_VALUE, rel=1e-6)
    with pytest.raises(ModelError, match="physically inconsistent"):
        IdentifiedModel(robot, TermSelection(), bad).export_mjcf(tmp_path / "x.xml")


def test_identify_writes_mjcf_and_export_command(tmp_path, recording):
    """pinid identify writes identified_<method>.xml beside the URDF for consistent methods; pinid export
    writes one from identification.json and refuses an inconsistent model in one line, writing nothing."""
    out = tmp_path / "run"
    proc = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(recording), "--methods", "ols,sdp", "--no-report", "-o", str(out)
    )
    assert proc.returncode == 0, proc.stderr
    names = {p.name for p in out.iterdir()}
    assert "identified_sdp.xml" in names and "identified_sdp.urdf" in names, names
    compiled((out / "identified_sdp.xml").read_text())
    proc = run_cli(
        "export", "--model", str(out / "identification.json"), "--method", "sdp", "-o", str(tmp_path / "a.xml")
    )
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "a.xml").read_text() == (out / "identified_sdp.xml").read_text()


def test_one_active_joint_identify_writes_a_loadable_mjcf(tmp_path, recording):
    """identify --joints hip (nv = 1) writes its MJCF (it used to end in an internal IndexError) and pinid
    export writes the same file from the saved model."""
    out = tmp_path / "run"
    args = ["--data", str(recording), "--methods", "sdp", "--no-report", "--no-progress", "-o", str(out)]
    proc = run_cli("identify", "--urdf", "exo_leg", "--joints", "hip", *args)
    assert proc.returncode == 0, proc.stderr
    m, _ = compiled((out / "identified_sdp.xml").read_text())
    assert (m.nv, m.nu) == (1, 1)
    proc = run_cli("export", "--model", str(out / "model_sdp.json"), "-o", str(tmp_path / "a.xml"))
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "a.xml").read_text() == (out / "identified_sdp.xml").read_text()


def test_body_names_are_unique_when_a_link_is_called_world_link(tmp_path):
    """Root link "world" and a link "world_link": the root body becomes "world_link_1", MuJoCo loads the file
    and its mass matrix is Pinocchio's."""
    text = PENDULUM.replace('"base"', '"world"').replace('"arm"', '"world_link"')
    text = text.replace(
        "</robot>",
        '<link name="arm"><inertial><origin xyz="0 0 -0.2"/><mass value="1"/>'
        '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.001"/></inertial></link>'
        '<joint name="j2" type="revolute"><parent link="world_link"/><child link="arm"/><origin xyz="0 0 -0.4"/>'
        '<axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="50" velocity="5"/></joint></robot>',
    )
    (tmp_path / "w.urdf").write_text(text)
    robot = RobotModel.from_urdf(tmp_path / "w.urdf")
    model = IdentifiedModel(robot, TermSelection(), standard_parameters(robot, TermSelection()))
    m, d = compiled(model.export_mjcf())
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)]
    assert names == ["world", "world_link_1", "world_link", "arm"]
    d.qpos[:] = [0.3, -0.7]
    mujoco.mj_forward(m, d)
    assert rel(full_mass_matrix(m, d), model.mass_matrix(np.array([[0.3, -0.7]]))[0]) < 1e-12


def test_export_command_refuses_an_inconsistent_model(tmp_path):
    robot = load("exo_leg")
    theta = standard_parameters(robot, TERMS)
    theta[10] = -1.0  # knee mass
    IdentifiedModel(robot, TERMS, theta, meta={"method": "ols"}).save(tmp_path / "model_ols.json")
    proc = run_cli("export", "--model", str(tmp_path / "model_ols.json"), "-o", str(tmp_path / "b.xml"))
    assert_clean_error(proc, "physically inconsistent", "knee")
    assert not (tmp_path / "b.xml").exists()


def test_shapes_sit_where_the_urdf_puts_them(tmp_path):
    """The URDF's collision shapes collide, its visual ones are for display; both at the URDF's placement:
    MuJoCo's geom pose at random q is Pinocchio's link frame × the shape's <origin>."""
    text = load("exo_leg").urdf_text.replace("<visual>", "<collision>", 1).replace("</visual>", "</collision>", 1)
    (tmp_path / "exo.urdf").write_text(text)  # the trunk's box becomes a collision shape
    robot = RobotModel.from_urdf(tmp_path / "exo.urdf")
    model = identified(robot)
    m, d = compiled(model.export_mjcf())
    names = [m.geom(i).name for i in range(m.ngeom)]
    assert names == ["trunk_collision_0", "thigh_visual_0", "shank_visual_0", "shank_visual_1"]
    assert list(m.geom_contype) == [1, 0, 0, 0] and list(m.geom_group) == [0, 1, 1, 1]
    np.testing.assert_array_equal(m.geom_size[3], [0.12, 0.05, 0.01])  # the foot plate: half of 0.24 0.10 0.02
    origins = {"trunk_collision_0": (0, 0, 0.05), "thigh_visual_0": (0, 0, -0.21), "shank_visual_0": (0, 0, -0.19)}
    origins["shank_visual_1"] = (0.05, 0, -0.39)
    pm, pd = robot.pin_model, robot.pin_model.createData()
    for q in robot.random_states(5, np.random.default_rng(9))[0]:
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        pin.framesForwardKinematics(pm, pd, q)
        for name, xyz in origins.items():
            M = pd.oMf[pm.getFrameId(name.split("_")[0])] * pin.SE3(np.eye(3), np.array(xyz, dtype=float))
            np.testing.assert_allclose(d.geom(name).xpos, M.translation, atol=1e-14)
            np.testing.assert_allclose(d.geom(name).xmat.reshape(3, 3), M.rotation, atol=1e-14)


def test_motor_terms_reflect_through_single_joint_motors():
    """ur5 with 50:1 reductions and a differential wrist (pinid's drives tests): a motor turning one joint
    reflects G²·Im, G²·fv and |G|·fc onto it; the differential's second motor couples two joints (off-diagonal
    rotor inertia), has no MJCF field and is listed as not exported — M differs by exactly its Gᵀ·Im·G."""
    from test_drives import WRIST_G, coupled

    robot = coupled("ur5")
    terms = TermSelection.from_names("fc,fv,motor_fc,motor_fv,motor_armature")
    model = identified(robot, seed=10, terms=terms)
    text = model.export_mjcf()
    m, d = compiled(text)
    v = term_values(robot, terms, model.theta[10 * robot.nv :])
    G = np.full(robot.nv, 50.0)  # motors m1..m5 turn one joint each, 50:1 (m5: the wrist's first row)
    np.testing.assert_allclose(m.dof_armature, G**2 * np.r_[v["motor_armature"][:5], 0], rtol=1e-14)
    np.testing.assert_allclose(m.dof_damping, model.fv + G**2 * np.r_[v["motor_fv"][:5], 0], rtol=1e-14)
    np.testing.assert_allclose(m.dof_frictionloss, model.fc + G * np.r_[v["motor_fc"][:5], 0], rtol=1e-14)
    assert "m6.armature" in text and "m6.fv" in text and "m6.fc" in text and "coupled to several joints" in text
    g6 = np.r_[0, 0, 0, 0, WRIST_G[1]]
    q = robot.random_states(1, np.random.default_rng(11))[0][0]
    d.qpos[:] = q
    mujoco.mj_forward(m, d)
    lost = v["motor_armature"][5] * np.outer(g6, g6)
    assert rel(full_mass_matrix(m, d) + lost, model.mass_matrix(q)) < 1e-12


@pytest.mark.parametrize(
    "content, extra, fragment",
    [
        (None, [], "file not found"),
        ("nonsense", [], "not valid JSON"),
        ('{"a": 1}', [], "not an identified model"),
        ("model", ["--method", "wls"], "holds method 'sdp', not 'wls'"),
        ("model", ["--format", "urdf", "--floating"], "--floating is for --format mjcf"),
        ("model", ["--format", "sdf"], "invalid choice"),
    ],
)
def test_export_command_bad_inputs(tmp_path, content, extra, fragment):
    """One line, exit status 2, nothing written."""
    src = tmp_path / "in.json"
    if content == "model":
        identified(load("exo_leg")).save(src)
    elif content is not None:
        src.write_text(content)
    proc = run_cli("export", "--model", str(src), *extra, "-o", str(tmp_path / "out.xml"))
    assert_clean_error(proc, fragment)
    assert not (tmp_path / "out.xml").exists()


def test_export_command_does_not_replace_an_existing_file(tmp_path):
    identified(load("exo_leg")).save(tmp_path / "model_sdp.json")
    (tmp_path / "out.xml").write_text("precious")
    proc = run_cli("export", "--model", str(tmp_path / "model_sdp.json"), "-o", str(tmp_path / "out.xml"))
    assert_clean_error(proc, "already exists")
    assert (tmp_path / "out.xml").read_text() == "precious"
    proc = run_cli("export", "--model", str(tmp_path / "model_sdp.json"), "-o", str(tmp_path / "out.xml"), "--force")
    assert proc.returncode == 0, proc.stderr
    compiled((tmp_path / "out.xml").read_text())


def test_docs_example_runs(tmp_path, monkeypatch, capsys):
    """docs/mujoco.md's Python block runs and prints the same accelerations from MuJoCo and pinid."""
    doc = (Path(__file__).resolve().parents[2] / "docs" / "mujoco.md").read_text()
    block = doc.split("```python\n", 1)[1].split("```", 1)[0]
    monkeypatch.chdir(tmp_path)
    exec(compile(block, "docs/mujoco.md", "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    mj, pinid_ = (np.array(line.split("[", 1)[1].split("]", 1)[0].split(), dtype=float) for line in lines[-2:])
    np.testing.assert_allclose(mj, pinid_, rtol=1e-7)  # as printed (8 digits)
    assert (tmp_path / "exo_leg.xml").is_file()
