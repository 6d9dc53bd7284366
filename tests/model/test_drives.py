"""Drives and motor-side terms: identities, coupled-transmission twins, URDF <transmission> vs TOML, errors.

Ground truth is generated here directly (analytic Fourier motion, τ = rnea + joint terms + Gᵀ·motor terms
from the independent formula below), as in test_identification.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from pinid import TermSelection, base_parameters, regressor, standard_parameters
from pinid.identification.study import Study
from pinid.data.dataset import Dataset
from pinid.errors import ModelError, ModelWarning, SpecError
from pinid.identification.run import identify
from pinid.identification.identified import IdentifiedModel
from pinid.model.drives import Drives, Transmission, load_drives
from pinid.model.robot import RobotModel
from pinid.model.terms import Stribeck

from conftest import assert_clean_error, load, run_cli
from test_identification import fourier_motion, truth_model

ALL_TERMS = TermSelection.from_names(
    "fc,fv,offset,armature,fc_pos,fc_neg,fs,"
    "motor_fc,motor_fv,motor_offset,motor_armature,motor_fc_pos,motor_fc_neg,motor_fs"
)
STRIBECK = {"fs": (0.3, 1.5), "motor_fs": (40.0, 2.0)}  # (velocity [rad/s], shape) of coupled()'s robots
MOTOR_TERMS = TermSelection.from_names("fc,fv,motor_fc,motor_fv,motor_offset,motor_armature")
EXO_G = [[30.0, 0.0], [12.0, 25.0]]  # cable: the knee motor turns with the hip too
WRIST_G = [[50.0, 0.0], [50.0, 50.0]]  # differential wrist: motor 6 turns with q5 + q6


def coupled(name: str) -> RobotModel:
    """exo_leg with a cable coupling hip→knee, or ur5/panda with reductions and a differential on the last
    two joints; joint friction (0.4, 0.2) and motor friction, offset and rotor inertia."""
    m = truth_model(name)
    j = m.joint_names
    if name == "exo_leg":
        tr = [Transmission(j, ["m_hip", "m_knee"], np.array(EXO_G))]
        vals = {
            "m_hip": {"fc": 0.04, "fv": 0.004, "armature": 2e-5, "offset": 0.003},
            "m_knee": {"fc": 0.05, "fv": 0.003, "armature": 3e-5, "offset": -0.002},
        }
    else:
        tr = [Transmission([x], [f"m{i + 1}"], np.array([[50.0]])) for i, x in enumerate(j[:-2])]
        tr.append(Transmission(j[-2:], [f"m{len(j) - 1}", f"m{len(j)}"], np.array(WRIST_G)))
        vals = {
            f"m{i + 1}": {"fc": 0.01 + 0.002 * i, "fv": 1e-3, "armature": 1e-5, "offset": 1e-3} for i in range(len(j))
        }
    return m.with_stribeck({k: Stribeck(*v) for k, v in STRIBECK.items()}).with_drives(
        Drives(j, tr, vals, "test drives")
    )


def expected_torque(m: RobotModel, q, dq, ddq, theta_terms, terms: TermSelection) -> np.ndarray:
    """rnea + joint terms + Gᵀ·(motor terms at G·q), written out term by term (independent of the registry)."""
    nv, G = m.nv, m.drives.matrix
    nm = G.shape[0]
    nj, nmt = len(terms.joint), len(terms.motor)
    J = theta_terms[: nv * nj].reshape(nv, nj)
    M = theta_terms[nv * nj :].reshape(nm, nmt)
    formula = {
        "fc": np.sign,
        "fv": lambda x: x,
        "offset": np.ones_like,
        "fc_pos": lambda x: (x > 0) * 1.0,
        "fc_neg": lambda x: -1.0 * (x < 0),
    }
    for name, (vs, shape) in STRIBECK.items():  # fs·sign(v)·exp(−(|v|/v_s)^δ)
        formula[name] = lambda x, vs=vs, shape=shape: np.sign(x) * np.exp(-((np.abs(x) / vs) ** shape))
    tau = m.rnea(q, dq, ddq)
    for k, t in enumerate(terms.joint):
        tau += J[:, k] * (ddq if t.name == "armature" else formula[t.name](dq))
    dqm, ddqm = dq @ G.T, ddq @ G.T
    for k, t in enumerate(terms.motor):
        col = ddqm if t.suffix == "armature" else formula[t.name if t.name == "motor_fs" else t.suffix](dqm)
        tau += (M[:, k] * col) @ G
    return tau


def twin(m: RobotModel, terms: TermSelection, seconds=20.0, rate=200.0, seed=0, noise=0.0) -> Dataset:
    t, q, dq, ddq = fourier_motion(m, seconds, rate, seed)
    theta = standard_parameters(m, terms)
    tau = expected_torque(m, q, dq, ddq, theta[10 * m.nv :], terms)
    if np.any(np.asarray(noise) > 0):
        tau = tau + np.random.default_rng(1000 + seed).normal(size=tau.shape) * noise
    return Dataset(t, q, m.joint_names, dq=dq, ddq=ddq, tau=tau, source=f"twin{seed}")


# ---------------------------------------------------------------------------------------------- identities
@pytest.mark.parametrize("name", ["exo_leg", "ur5", "panda"])
def test_regressor_is_rnea_plus_joint_terms_plus_motor_terms(name):
    m = coupled(name)
    rng = np.random.default_rng(3)
    q, dq, ddq = m.random_states(7, rng)
    theta = standard_parameters(m, ALL_TERMS)
    theta[10 * m.nv :] = rng.uniform(-1, 1, theta.size - 10 * m.nv)  # every term, non-zero, both signs
    W = regressor(m, q, dq, ddq, ALL_TERMS)
    want = expected_torque(m, q, dq, ddq, theta[10 * m.nv :], ALL_TERMS)
    assert np.allclose((W @ theta).reshape(7, m.nv), want, rtol=1e-10, atol=1e-9)
    ident = IdentifiedModel(m, ALL_TERMS, theta)  # the identified model's inverse dynamics agrees
    assert np.allclose(ident.inverse_dynamics(q, dq, ddq), want, rtol=1e-10, atol=1e-9)
    for k in range(7):  # forward dynamics inverts it (rotor inertia Gᵀ·diag(Im)·G in the mass matrix)
        assert np.allclose(ident.forward_dynamics(q[k], dq[k], want[k]), ddq[k], atol=1e-7)


def test_plain_reduction_motor_terms_merge_with_joint_terms():
    m = coupled("ur5")
    bp = base_parameters(m, MOTOR_TERMS)
    expr = dict(zip(bp.names, bp.expressions()))
    assert "shoulder_pan_joint.fcR" in expr and "50·m1.fc" in expr["shoulder_pan_joint.fcR"]
    # the differential's motor-6 Coulomb column sign(dq5 + dq6) is its own base parameter
    assert "m6.fc" in bp.names


# ---------------------------------------------------------------------------------------------- twins
@pytest.mark.parametrize("name", ["exo_leg", "ur5"])
def test_noise_free_coupled_twin_recovers_base_parameters(name):
    m = coupled(name)
    bp = base_parameters(m, MOTOR_TERMS)
    truth = bp.from_standard(standard_parameters(m, MOTOR_TERMS))
    res = identify(Study(m, twin(m, MOTOR_TERMS), terms=MOTOR_TERMS), methods=["ols", "sdp"])
    for method, r in res.results.items():
        err = np.abs(r.base - truth) / np.maximum(np.abs(truth), 1e-3)
        assert err.max() <= 1e-6, (method, bp.names[int(err.argmax())], err.max())
    assert res["sdp"].physically_consistent
    assert any(n.startswith("m") and "." in n and n.split(".")[0] in m.motor_names for n in res["ols"].base_names)


@pytest.mark.parametrize("name,sigma", [("exo_leg", [0.3, 0.2]), ("ur5", 0.1)])
def test_noisy_coupled_twin_at_noise_floor_and_motor_terms_matter(name, sigma):
    m = coupled(name)
    train = twin(m, MOTOR_TERMS, seconds=40, rate=250, seed=4, noise=sigma)
    clean = twin(m, MOTOR_TERMS, seconds=10, rate=250, seed=5)
    noise = np.random.default_rng(99).normal(size=clean.tau.shape) * sigma
    valid = Dataset(clean.t, clean.q, clean.joints, dq=clean.dq, ddq=clean.ddq, tau=clean.tau + noise, source="valid")
    floor = float(np.sqrt(np.mean(noise**2)))
    res = identify(Study(m, train, validate=valid, terms=MOTOR_TERMS), methods=["ols", "sdp"])
    for method, r in res.results.items():
        assert r.validation.all["rms"] <= 1.05 * floor, (method, r.validation.all["rms"], floor)
    without = identify(Study(m, train, validate=valid, terms="fc,fv,armature"), methods=["ols"])
    for j in m.joint_names[-2:]:  # the coupled joints
        with_rms = res["ols"].validation.per_joint[j]["rms"]
        assert without["ols"].validation.per_joint[j]["rms"] >= 3 * with_rms, j


# ---------------------------------------------------------------------------------------------- inputs
WRIST_URDF = """
  <transmission name="pan"><type>transmission_interface/SimpleTransmission</type>
    <joint name="shoulder_pan_joint"/><actuator name="m1"><mechanicalReduction>50</mechanicalReduction></actuator>
  </transmission>
  <transmission name="wrist"><type>transmission_interface/DifferentialTransmission</type>
    <actuator name="m5"><role>actuator1</role><mechanicalReduction>50</mechanicalReduction></actuator>
    <actuator name="m6"><role>actuator2</role><mechanicalReduction>-50</mechanicalReduction></actuator>
    <joint name="wrist_2_joint"><role>joint1</role><mechanicalReduction>1</mechanicalReduction></joint>
    <joint name="wrist_3_joint"><role>joint2</role><mechanicalReduction>-1</mechanicalReduction></joint>
  </transmission>
"""
WRIST_TOML = """
[[transmission]]
joints = ["shoulder_pan_joint"]
motors = ["m1"]
matrix = [[50]]
[[transmission]]
joints = ["wrist_2_joint", "wrist_3_joint"]
motors = ["m5", "m6"]
matrix = [[50, -50], [-50, -50]]
"""


def wrist_urdf(tmp_path, extra=WRIST_URDF):
    import re

    text = load("ur5").urdf_text
    text = re.sub(r"<transmission.*?</transmission>", "", text, flags=re.S)  # drop ur5's own 1:1 ones
    p = tmp_path / "ur5_wrist.urdf"
    p.write_text(text.replace("</robot>", extra + "</robot>"))
    return p


def test_urdf_transmissions_equal_the_drives_toml(tmp_path):
    from_urdf = RobotModel.from_urdf(wrist_urdf(tmp_path))
    (tmp_path / "d.toml").write_text(WRIST_TOML)
    from_toml = RobotModel.from_urdf(wrist_urdf(tmp_path, ""), drives=tmp_path / "d.toml")
    assert from_urdf.motor_names == from_toml.motor_names == ["m1", "m5", "m6"]
    assert np.array_equal(from_urdf.drives.matrix, from_toml.drives.matrix)
    q, dq, ddq = from_urdf.random_states(5, np.random.default_rng(0))
    assert np.array_equal(regressor(from_urdf, q, dq, ddq, MOTOR_TERMS), regressor(from_toml, q, dq, ddq, MOTOR_TERMS))
    # ur5's own URDF has six 1:1 SimpleTransmissions
    assert load("ur5").drives.matrix.tolist() == np.eye(6).tolist()


@pytest.mark.parametrize(
    "toml, message",
    [
        (
            '[transmission]\njoints = ["hip", "ankle"]\nmotors = ["a", "b"]\nmatrix = [[1, 0], [0, 1]]\n',
            "joint 'ankle'",
        ),
        ('[transmission]\njoints = ["hip", "knee"]\nmotors = ["a", "b"]\nmatrix = [[1, 2], [2, 4]]\n', "singular"),
        ('[transmission]\njoints = ["hip", "knee"]\nmotors = ["a"]\nmatrix = [[1, 2]]\n', "expected a square"),
        ('[transmission]\njoints = ["hip"]\nmotors = ["a"]\nmatrix = [[1]]\n[motors.b]\nfc = 1\n', "[motors.b]"),
        ('[transmission]\njoints = ["hip"]\nmotors = ["a"]\nmatrix = [[1]]\n[motors.a]\nfc = -1\n', "expected >= 0"),
    ],
)
def test_bad_drives_files(tmp_path, toml, message):
    p = tmp_path / "d.toml"
    p.write_text(toml)
    with pytest.raises(SpecError) as exc:
        load_drives(p, ["hip", "knee"])
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_motor_terms_need_drives():
    with pytest.raises(ModelError, match="need drives"):
        base_parameters(load("exo_leg"), TermSelection.from_names("fc,motor_fc"))


@pytest.mark.parametrize(
    "toml, fragment",
    [
        (
            '[transmission]\njoints = ["hip", "ankle"]\nmotors = ["a", "b"]\nmatrix = [[1, 0], [0, 1]]\n',
            "joint 'ankle'",
        ),
        ('[transmission]\njoints = ["hip", "knee"]\nmotors = ["a", "b"]\nmatrix = [[1, 2], [2, 4]]\n', "singular"),
        ('[transmission]\njoints = ["hip", "knee"]\nmotors = ["a"]\nmatrix = [[1, 2]]\n', "square"),
        (None, "need drives"),
    ],
)
def test_cli_drive_errors_exit_2_and_write_nothing(tmp_path, toml, fragment):
    args = ["info", "--urdf", "exo_leg", "--terms", "fc,motor_fc", "--json", str(tmp_path / "out.json")]
    if toml is not None:
        (tmp_path / "d.toml").write_text(toml)
        args += ["--drives", str(tmp_path / "d.toml")]
    assert_clean_error(run_cli(*args), fragment)
    assert not (tmp_path / "out.json").exists()


def test_cli_info_shows_motors_and_merged_expressions(tmp_path):
    (tmp_path / "d.toml").write_text(
        '[transmission]\njoints = ["hip", "knee"]\nmotors = ["m_hip", "m_knee"]\nmatrix = [[30, 0], [12, 25]]\n'
    )
    out = tmp_path / "info.json"
    proc = run_cli(
        "info",
        "--urdf",
        "exo_leg",
        "--drives",
        str(tmp_path / "d.toml"),
        "--terms",
        "fc,fv,motor_fc,motor_armature",
        "--json",
        str(out),
    )
    assert proc.returncode == 0, proc.stderr
    assert "m_knee" in proc.stdout
    d = json.loads(out.read_text())
    assert d["drives"]["motors"] == ["m_hip", "m_knee"]
    assert any("m_knee.fc" in b["expression"] for b in d["base_parameters"])


def test_simulated_plant_has_motor_friction_and_rotor_inertia():
    """The twin's recorded truth satisfies τ = rnea + fc·tanh(dq/v_s) + fv·dq + Gᵀ·(motor terms at G·dq, G·ddq)."""
    from pinid.excitation.trajectory import FourierTrajectory
    from pinid.model import terms as T
    from pinid.simulation.twin import simulate

    m = coupled("exo_leg")
    tr = FourierTrajectory(
        m.joint_names, 0.5 * np.pi, np.array([0.6, -0.9]), np.array([[0.4], [0.5]]), np.zeros((2, 1))
    )
    rec, truth = simulate(m, tr, seconds=2.0, seed=1)
    s = truth["signals"]
    theta = standard_parameters(m, MOTOR_TERMS)[10 * m.nv :]
    want = m.rnea(s.q, s.dq, s.ddq) + T.torque(
        m, MOTOR_TERMS, theta, s.q, s.dq, s.ddq, smoothing=truth["friction"]["coulomb_velocity_scale"]
    )
    assert np.allclose(want, s.tau, atol=1e-8)
    assert "motor_armature" in truth["terms"] and truth["drives"]["transmission"][0]["matrix"] == EXO_G


def test_cli_identify_with_drives_exports_drives_toml_and_motor_names(tmp_path):
    from pinid.data.formats import write_recording

    m = coupled("exo_leg")
    write_recording(tmp_path / "train.csv", twin(m, MOTOR_TERMS, seconds=10))
    drives_file = tmp_path / "d.toml"
    drives_file.write_text(
        '[transmission]\njoints = ["hip", "knee"]\nmotors = ["m_hip", "m_knee"]\n'
        f"matrix = {EXO_G}\n[motors.m_knee]\nfc = 0.05\n"
    )
    out = tmp_path / "out"
    proc = run_cli(
        "identify",
        "--urdf",
        "exo_leg",
        "--drives",
        str(drives_file),
        "--data",
        str(tmp_path / "train.csv"),
        "--terms",
        ",".join(MOTOR_TERMS.names),
        "--methods",
        "sdp",
        "--no-report",
        "-o",
        str(out),
    )
    assert proc.returncode == 0, proc.stderr
    d = json.loads((out / "identification.json").read_text())
    assert "m_knee.armature" in d["methods"]["sdp"]["base_parameters"] or any(
        n.startswith("m_knee.") for n in d["methods"]["sdp"]["base_parameters"]
    )
    back = load_drives(out / "identified_sdp_drives.toml", m.joint_names)
    assert np.array_equal(back.matrix, m.drives.matrix)
    ident = IdentifiedModel.load(out / "model_sdp.json")  # the saved model carries its drives
    q, dq, ddq = m.random_states(4, np.random.default_rng(1))
    theta = standard_parameters(m, MOTOR_TERMS)
    want = expected_torque(m, q, dq, ddq, theta[10 * m.nv :], MOTOR_TERMS)
    assert np.allclose(ident.inverse_dynamics(q, dq, ddq), want, atol=1e-5)


def _kinova_style(reduction2: float = 1.0) -> str:
    """Two joints, each described by two SimpleTransmissions (ros_control, then one with a motorInertia), as
    Kinova's published Gen3 URDF does; ``reduction2``: the second description's reduction."""
    links = "".join(
        f'<link name="l{i}"><inertial><origin xyz="0 0 0.1"/><mass value="1"/>'
        '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.002"/></inertial></link>'
        for i in (1, 2)
    )
    joints = "".join(
        f'<joint name="j{i}" type="revolute"><parent link="{"base" if i == 1 else "l1"}"/><child link="l{i}"/>'
        f'<origin xyz="0 0 0.2"/><axis xyz="0 {i - 1} {2 - i}"/>'
        '<limit lower="-2" upper="2" effort="50" velocity="2"/></joint>'
        for i in (1, 2)
    )
    trans = "".join(
        f'<transmission name="j{i}_{tag}"><type>transmission_interface/SimpleTransmission</type>'
        f'<joint name="j{i}"><hardwareInterface>hardware_interface/{iface}</hardwareInterface></joint>'
        f'<actuator name="j{i}_{tag}_act"><mechanicalReduction>{n}</mechanicalReduction>{extra}</actuator>'
        "</transmission>"
        for i in (1, 2)
        for tag, iface, n, extra in (
            ("trans", "PositionJointInterface", 1.0, ""),
            ("tran", "EffortJointInterface", reduction2, "<motorInertia>0.0001</motorInertia>"),
        )
    )
    return f'<robot name="k"><link name="base"/>{links}{joints}{trans}</robot>'


def test_a_drive_described_twice_is_read_once_with_one_warning(tmp_path):
    """Issue 33: a vendor URDF with two <transmission> elements per joint loads (every command read it as an
    error); the repeated descriptions are left out with one warning naming them."""
    path = tmp_path / "k.urdf"
    path.write_text(_kinova_style())
    with pytest.warns(ModelWarning, match="j1_tran, j2_tran describe drives already read") as record:
        robot = RobotModel.from_urdf(path)
    assert len([w for w in record if issubclass(w.category, ModelWarning)]) == 1
    assert robot.drives.motor_names == ["j1_trans_act", "j2_trans_act"]
    np.testing.assert_array_equal(robot.drives.matrix, np.eye(2))
    path.write_text(_kinova_style(reduction2=50.0))
    with pytest.raises(ModelError, match="'j1' is also in <transmission name='j1_trans'> with another reduction"):
        RobotModel.from_urdf(path)
