"""IdentifiedModel: the equation of motion holds term by term; save/load (a tampered file is a SpecError, its
consistency is checked again on load); the docs' computed-torque example."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest

from pinid import TermSelection, standard_parameters
from pinid.identification.study import Study
from pinid.errors import ModelError, SpecError
from pinid.identification.identified import IdentifiedModel

from conftest import knee_mass as _param, load, tampered_json as _tampered
from test_identification import identify, truth_model, twin

ALL = TermSelection(coulomb=True, viscous=True, offset=True, armature=True)


def model_with_terms(name="ur5", seed=0):
    robot = load(name)
    theta = standard_parameters(robot, ALL)
    theta[10 * robot.nv :] = np.random.default_rng(seed).uniform(0.05, 0.5, robot.nv * 4)
    return IdentifiedModel(robot, ALL, theta, meta={"method": "test"})


def test_equation_of_motion_term_by_term():
    m = model_with_terms()
    rng = np.random.default_rng(1)
    q, dq, ddq = m.robot.random_states(10, rng)
    for a, b, c in zip(q, dq, ddq):
        M, C, g = m.mass_matrix(a), m.coriolis(a, b), m.gravity(a)
        tau = M @ c + C @ b + g + m.friction(b) + m.offset
        np.testing.assert_allclose(m.inverse_dynamics(a, b, c), tau, atol=1e-10)
        np.testing.assert_allclose(M, M.T, atol=0)
        assert np.linalg.eigvalsh(M)[0] > 0
        np.testing.assert_allclose(m.friction(b), m.fc * np.sign(b) + m.fv * b)
        np.testing.assert_allclose(m.forward_dynamics(a, b, m.inverse_dynamics(a, b, c)), c, atol=1e-8)
    # batch = one by one
    np.testing.assert_allclose(m.inverse_dynamics(q, dq, ddq), [m.inverse_dynamics(*x) for x in zip(q, dq, ddq)])
    np.testing.assert_allclose(m.gravity(q), [m.gravity(x) for x in q])
    assert m.armature.shape == (6,) and np.all(
        np.diag(m.mass_matrix(q[0])) - np.diag(pin.crba(m.pin_model, m.pin_data, q[0])) == pytest.approx(m.armature)
    )


def test_coriolis_matrix_makes_mdot_minus_2c_skew():
    m = model_with_terms("panda")
    rng = np.random.default_rng(2)
    q, dq, _ = m.robot.random_states(3, rng)
    h = 1e-6
    for a, b in zip(q, dq):
        Mdot = (m.mass_matrix(a + h * b) - m.mass_matrix(a - h * b)) / (2 * h)
        S = Mdot - 2 * m.coriolis(a, b)
        np.testing.assert_allclose(S, -S.T, atol=1e-6)


def test_model_matches_the_truth_after_identification():
    truth = truth_model("exo_leg")
    res = identify(Study(truth, twin(truth, seconds=10, rate=200, seed=1)), methods=["sdp"])
    m = res.model
    assert m.physically_consistent and res.best == "sdp"
    q, dq, ddq = truth.random_states(20, np.random.default_rng(3))
    expected = truth.rnea(q, dq, ddq) + truth.coulomb * np.sign(dq) + truth.viscous * dq
    np.testing.assert_allclose(m.inverse_dynamics(q, dq, ddq), expected, atol=1e-6)
    np.testing.assert_allclose(m.gravity(q[0]), truth.rnea(q[0], 0 * q[0], 0 * q[0]), atol=1e-6)


def test_save_and_load(tmp_path):
    m = model_with_terms("panda")
    path = m.save(tmp_path / "model.json")
    back = IdentifiedModel.load(path)
    q, dq, ddq = m.robot.random_states(5, np.random.default_rng(4))
    np.testing.assert_allclose(back.inverse_dynamics(q, dq, ddq), m.inverse_dynamics(q, dq, ddq), atol=1e-12)
    assert back.terms == ALL and back.meta == {"method": "test"} and back.physically_consistent
    assert back.joint_names == m.joint_names
    (tmp_path / "junk.json").write_text('{"format": "other"}')
    with pytest.raises(SpecError, match="not an identified model"):
        IdentifiedModel.load(tmp_path / "junk.json")
    with pytest.raises(SpecError, match="file not found"):
        IdentifiedModel.load(tmp_path / "none.json")
    with pytest.raises(ModelError, match="expected 98 standard parameters"):
        IdentifiedModel(m.nominal_robot, ALL, np.zeros(12))


def test_computed_torque_example_tracks():
    """The computed-torque controller of docs/identification.md, on the identified model of a twin."""
    truth = truth_model("exo_leg")
    result = identify(Study(truth, twin(truth, seconds=20, rate=200, seed=5, noise=0.2)), methods=["ols", "sdp"])
    model = result.model
    Kp, Kd = np.diag([400.0, 400.0]), np.diag([40.0, 40.0])

    def computed_torque(q, dq, q_d, dq_d, ddq_d):
        v = ddq_d + Kd @ (dq_d - dq) + Kp @ (q_d - q)
        return model.mass_matrix(q) @ v + model.coriolis(q, dq) @ dq + model.gravity(q) + model.friction(dq_d)

    # the plant is the truth (exact friction with sign(dq)), integrated at 2 kHz
    plant = IdentifiedModel(truth, TermSelection(), standard_parameters(truth, TermSelection()))
    w, dt = 2 * np.pi * 0.5, 5e-4
    ref = lambda t: (
        np.array([0.6, -0.9]) + 0.3 * np.sin(w * t),
        0.3 * w * np.cos(w * t) * np.ones(2),
        -0.3 * w * w * np.sin(w * t) * np.ones(2),
    )
    q, dq = ref(0.0)[0].copy(), ref(0.0)[1].copy()
    errors = []
    for k in range(4000):
        q_d, dq_d, ddq_d = ref(k * dt)
        tau = computed_torque(q, dq, q_d, dq_d, ddq_d)
        ddq = plant.forward_dynamics(q, dq, tau)
        dq = dq + dt * ddq
        q = q + dt * dq
        errors.append(q - ref((k + 1) * dt)[0])
    assert np.abs(np.array(errors[1000:])).max() < 5e-3


# ---------------------------------------------------------------- batches and derivatives (issue 15)
def coupled_model(seed=0):
    """UR5 with a wrist differential and every smooth joint and motor term at random positive values."""
    from test_drives import coupled

    robot = coupled("ur5")
    terms = TermSelection.from_names("fc,fv,offset,armature,motor_fc,motor_fv,motor_armature")
    theta = standard_parameters(robot, terms)
    theta[10 * robot.nv :] = np.random.default_rng(seed).uniform(0.05, 0.5, theta.size - 10 * robot.nv)
    return IdentifiedModel(robot, terms, theta)


@pytest.mark.parametrize("make", [model_with_terms, coupled_model])
def test_every_dynamics_method_takes_batches(make):
    m = make()
    q, dq, ddq = m.robot.random_states(7, np.random.default_rng(2))
    tau = m.inverse_dynamics(q, dq, ddq)
    for method, args in [
        ("mass_matrix", (q,)),
        ("coriolis", (q, dq)),
        ("gravity", (q,)),
        ("friction", (dq,)),
        ("inverse_dynamics", (q, dq, ddq)),
        ("forward_dynamics", (q, dq, tau)),
        ("derivatives", (q, dq, ddq)),
        ("forward_derivatives", (q, dq, tau)),
    ]:
        batch = getattr(m, method)(*args)
        one = [getattr(m, method)(*x) for x in zip(*args)]
        if isinstance(batch, tuple):  # derivatives: the terms' central differences round at ~1e-16/1e-6
            for b, part in zip(batch, zip(*one)):
                np.testing.assert_allclose(b, np.array(part), rtol=1e-7, atol=1e-8, err_msg=method)
        else:
            assert batch.shape == (7,) + one[0].shape, method
            np.testing.assert_allclose(batch, np.array(one), rtol=1e-12, atol=1e-12, err_msg=method)
    np.testing.assert_allclose(m.forward_dynamics(q, dq, tau), ddq, atol=1e-8)


def nominal_leg():
    """exo_leg's URDF values with Coulomb and viscous friction: what a controller's model usually is."""
    robot = load("exo_leg")
    return IdentifiedModel(robot, TermSelection(), standard_parameters(robot, TermSelection()))


@pytest.mark.parametrize("make", [nominal_leg, model_with_terms, coupled_model])
def test_one_sample_gives_the_batch_rows_to_the_last_bit(make):
    """A controller's call (one float sample) takes a short path: the numbers of the checked path (a list
    goes there) bit for bit, and a NaN is still refused."""
    m = make()
    q, dq, _ = m.robot.random_states(5, np.random.default_rng(7))
    for method, args in [("mass_matrix", (q,)), ("coriolis", (q, dq)), ("gravity", (q,)), ("friction", (dq,))]:
        for k, row in enumerate(zip(*args)):
            checked = getattr(m, method)(*[x.tolist() for x in row])
            assert np.array_equal(getattr(m, method)(*row), checked), (method, k)
    from pinid.errors import DataError

    for method in ("mass_matrix", "gravity", "friction"):
        with pytest.raises(DataError, match="finite|NaN"):
            getattr(m, method)(np.full(m.nv, np.nan))


def _numeric_jacobian(f, args, k, h=1e-6):
    """Central-difference Jacobian of ``f(*args)`` with respect to ``args[k]``."""

    def at(step):
        moved = list(args)
        moved[k] = args[k] + step
        return f(*moved)

    return np.stack([(at(h * e) - at(-h * e)) / (2 * h) for e in np.eye(args[k].size)], axis=1)


@pytest.mark.parametrize("make", [model_with_terms, coupled_model])
def test_derivatives_match_finite_differences(make):
    m = make()
    q, dq, ddq = m.robot.random_states(3, np.random.default_rng(3))
    dq += np.sign(dq) * 0.1  # away from the Coulomb step
    for a, b, c in zip(q, dq, ddq):
        dtau_dq, dtau_dv = m.derivatives(a, b, c)
        np.testing.assert_allclose(dtau_dq, _numeric_jacobian(m.inverse_dynamics, (a, b, c), 0), atol=2e-6)
        np.testing.assert_allclose(dtau_dv, _numeric_jacobian(m.inverse_dynamics, (a, b, c), 1), atol=2e-6)
        tau = m.inverse_dynamics(a, b, c)
        fq, fv, ft = m.forward_derivatives(a, b, tau)
        np.testing.assert_allclose(fq, _numeric_jacobian(m.forward_dynamics, (a, b, tau), 0), atol=1e-5)
        np.testing.assert_allclose(fv, _numeric_jacobian(m.forward_dynamics, (a, b, tau), 1), atol=1e-5)
        np.testing.assert_allclose(ft, _numeric_jacobian(m.forward_dynamics, (a, b, tau), 2), atol=1e-5)


def test_passive_term_enters_the_position_derivative():
    robot = load("exo_leg")
    terms = TermSelection.from_names("fv,passive")
    theta = standard_parameters(robot, terms)
    m = IdentifiedModel(robot, terms, theta)
    q, dq, ddq = robot.random_states(2, np.random.default_rng(4))
    for a, b, c in zip(q, dq, ddq):
        np.testing.assert_allclose(
            m.derivatives(a, b, c)[0], _numeric_jacobian(m.inverse_dynamics, (a, b, c), 0), rtol=1e-5, atol=1e-5
        )


@pytest.mark.parametrize(
    "call",
    [
        lambda m: m.mass_matrix(np.zeros(3)),
        lambda m: m.inverse_dynamics(np.zeros((4, 6)), np.zeros((5, 6)), np.zeros((4, 6))),
        lambda m: m.inverse_dynamics(np.zeros(6), np.zeros((1, 6)), np.zeros(6)),
        lambda m: m.gravity(np.full(6, np.nan)),
        lambda m: m.coriolis("abc", np.zeros(6)),
        lambda m: m.derivatives(np.zeros((2, 2, 6)), np.zeros(6), np.zeros(6)),
    ],
)
def test_wrong_shapes_are_data_errors(call):
    from pinid.errors import DataError

    with pytest.raises(DataError):
        call(model_with_terms())


def test_an_identification_file_given_as_a_model_names_the_model_files():
    """Issue 33: identification.json where a model is expected (``--exo``, ``export --model``) says which files
    to pass, model_<method>.json."""
    d = {"robot": {}, "methods": {"ols": {}, "sdp": {}}}
    with pytest.raises(SpecError) as exc:
        IdentifiedModel.from_dict(d)
    assert (
        "this is pinid identify's identification.json: pass one of the model_<method>.json files written "
        "beside it (model_ols.json, model_sdp.json)" in str(exc.value)
    )


def test_model_of_a_repaired_urdf_loads_back(tmp_path):
    """A model identified with --repair-inertia (a knee izz of the wrong sign) is saved with the repair flag:
    IdentifiedModel.load, `pinid export --model` and the saved robot's inertias all read it back; without the
    flag the saved text is refused naming 'the saved URDF text', not a temporary file."""
    import json

    from pinid import RobotModel

    from conftest import run_cli

    bad = tmp_path / "bad.urdf"
    bad.write_text(load("exo_leg").urdf_text.replace('izz="0.0075"', 'izz="-0.0075"'))
    with pytest.warns(Warning, match="repaired to the nearest physical inertia"):
        robot = RobotModel.from_urdf(bad, repair_inertia=True)
    terms = TermSelection()
    theta = standard_parameters(robot, terms)
    IdentifiedModel(robot, terms, theta, meta={"method": "sdp"}).save(tmp_path / "model_sdp.json")
    back = IdentifiedModel.load(tmp_path / "model_sdp.json")
    assert back.robot.repair_inertia
    np.testing.assert_array_equal(standard_parameters(back.robot, terms), theta)
    proc = run_cli("export", "--model", str(tmp_path / "model_sdp.json"), "-o", str(tmp_path / "a.urdf"))
    assert proc.returncode == 0, proc.stderr
    d = json.loads((tmp_path / "model_sdp.json").read_text())
    d["robot"].pop("repair_inertia")
    (tmp_path / "plain.json").write_text(json.dumps(d))
    with pytest.raises(ModelError, match=r"plain\.json: the saved URDF text: the body moved by joint 'knee'"):
        IdentifiedModel.load(tmp_path / "plain.json")


def _set(key, value):
    def change(d):
        d[key] = value

    return change


@pytest.mark.parametrize(
    "change, fragment",
    [
        (lambda d: d.pop("robot"), "'robot'"),
        (_set("robot", [1, 2]), "'robot' is list"),
        (_set("meta", [1]), "'meta' is list"),
        (lambda d: d["robot"].__setitem__("terms", "fc,fv"), "'terms' is str"),
        (lambda d: d["robot"].pop("terms"), "'terms'"),
        (lambda d: d["robot"].__setitem__("joints", "hip"), "'joints' is str"),
        (_param("abc"), "knee.m is 'abc'"),
        (_param(None), "knee.m is None"),
        (_param(True), "knee.m is True"),
        (_set("standard_parameters", [1.0]), "'standard_parameters' is list"),
        (_set("physically_consistent", "no"), "'physically_consistent' is 'no'"),
    ],
)
def test_tampered_model_json(tmp_path, model_json, change, fragment):
    with pytest.raises(SpecError) as info:
        IdentifiedModel.load(_tampered(tmp_path, model_json, change))
    assert fragment in str(info.value)


def test_model_json_not_an_object(tmp_path):
    path = tmp_path / "m.json"
    path.write_text("[1, 2]")
    with pytest.raises(SpecError, match="expected a JSON object"):
        IdentifiedModel.load(path)
    with pytest.raises(SpecError, match="expected a JSON object"):
        IdentifiedModel.from_dict([1, 2])


def test_identification_json_points_to_identification_load(tmp_path, model_json):
    """Case 26: the message names Identification.load."""
    path = tmp_path / "identification.json"
    path.write_text(json.dumps({"robot": model_json["robot"], "methods": {}}))
    with pytest.raises(SpecError, match=r"Identification\.load"):
        IdentifiedModel.load(path)


def test_stored_consistency_flag_not_trusted(tmp_path, model_json):
    """Case 9: a knee mass of −50 with the flag true loads as NOT consistent; a true model stays true."""
    assert IdentifiedModel.from_dict(model_json).physically_consistent
    path = _tampered(tmp_path, model_json, _param(-50.0))
    assert json.loads(path.read_text())["physically_consistent"] is True
    assert not IdentifiedModel.load(path).physically_consistent
    stored_false = _tampered(tmp_path, model_json, _set("physically_consistent", False))
    assert not IdentifiedModel.load(stored_false).physically_consistent


def test_load_errors_name_the_file(tmp_path):
    """Issue 47: a JSON object that is not an identified model ('{}') is a pinid error naming the file."""
    from pinid.errors import PinidError

    path = tmp_path / "empty.json"
    path.write_text("{}")
    with pytest.raises(PinidError, match=f"^{path}: not an identified model") as info:
        IdentifiedModel.load(path)
    assert isinstance(info.value, SpecError) and "\n" not in str(info.value)
    with pytest.raises(SpecError, match=r"^\S*m\.json: identified model: missing parameter"):
        (tmp_path / "m.json").write_text(json.dumps({**model_with_terms().to_dict(), "standard_parameters": {}}))
        IdentifiedModel.load(tmp_path / "m.json")


def test_floating_model_saves_and_loads_back(tmp_path):
    """Issue 47: a floating robot's model_<method>.json holds its base link's parameters (base.*, first) and
    loads back to the same theta; before, the names of the fixed-base robot were zipped with theta, which
    dropped the last 10 values and named the base's after the first joint's."""
    from pinid import RobotModel

    robot = RobotModel.from_urdf("exo_lower_body", base="floating")
    terms = TermSelection.from_names("fc,fv")
    theta = standard_parameters(robot, terms)
    theta[0] *= 1.1  # the base link 10 % heavier: its value must stay under base.m
    m = IdentifiedModel(robot, terms, theta, meta={"method": "sdp"})
    names = list(m.standard_parameters)
    assert len(names) == theta.size and names[0] == "base.m" and m.standard_parameters["base.m"] == theta[0]
    back = IdentifiedModel.load(m.save(tmp_path / "model_sdp.json"))
    np.testing.assert_array_equal(back.theta, theta)
    assert back.nominal_robot.base == "floating" and back.physically_consistent
