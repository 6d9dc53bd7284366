"""Flexible joints (issue 8, seed 003): the tracker URDF, the batch dynamics, the simulator, output-error
fitting, the spec and the `pinid flex` command."""

from __future__ import annotations

import json
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from pinid import DataError, JointError, RobotModel, SpecError
from pinid.flexible.model import Drive, FlexibleModel, flexible_model
from pinid.flexible.link import TrigDynamics
from pinid.flexible.recording import FlexRecording
from pinid.flexible.output_error import (
    FreeParameters,
    OutputErrorProblem,
    classify,
    fit_output_error,
    make_twin,
    problem_from_spec,
    sensitivity,
)
from pinid.flexible.result import OutputErrorResult
from pinid.flexible.spec import load_flex_spec, methods

from conftest import assert_clean_error, load, run_cli

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "excitation" / "tracker_flex_spec.toml"
TABLE1 = {  # seed 003 Table 1
    "base": dict(ratio=3.0, K1=91.66, K2=-261.30, C=0.0016, Jm=0.0074, Bm=0.0039, fv=0.1358, fc=0.1158),
    "barrel": dict(ratio=2.0, K1=105.62, K2=-183.90, C=0.0259, Jm=0.0136, Bm=0.0053, fv=0.1123, fc=0.0653),
}


@pytest.fixture(scope="module")
def tracker() -> RobotModel:
    return RobotModel.from_urdf(ROOT / "urdf" / "tracker_2dof.urdf")


@pytest.fixture(scope="module")
def spec():
    return load_flex_spec(SPEC)


def short_spec(spec, duration=0.6, **kw):
    return replace(spec, input=replace(spec.input, duration=duration), **kw)


# ---------------------------------------------------------------------------------------------- URDF
def test_tracker_urdf_carries_table1(tracker):
    theta = tracker.inertial_parameters().reshape(2, 10)
    assert tracker.joint_names == ["base", "barrel"]
    assert theta[0, 9] == pytest.approx(0.095)  # base.Izz = J_theta
    assert theta[1, 6] == pytest.approx(0.0254)  # barrel.Iyy = J_alpha
    np.testing.assert_allclose(tracker.viscous, [0.2598, 0.01504])  # b_theta, b_alpha
    g = tracker.rnea(np.zeros(2), np.zeros(2), np.zeros(2))
    assert g[0] == pytest.approx(0.0, abs=1e-12)  # vertical axis: no gravity on the base
    assert g[1] == pytest.approx(1.5 * 9.81 * 0.06, rel=1e-3)  # barrel loaded most when horizontal


# ---------------------------------------------------------------------------------------------- batch dynamics
@pytest.mark.parametrize("robot", ["tracker", "exo_leg", "ur5_3"])
def test_trig_dynamics_equal_pinocchio(robot, tracker):
    """M, c + g and the forward dynamics of the trigonometric backend are Pinocchio's, for random inertias."""
    if robot == "tracker":
        model = tracker
    elif robot == "exo_leg":
        model = load("exo_leg")  # first axis horizontal: gravity depends on both angles
    else:
        model = RobotModel.from_urdf("ur5", joints=["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint"])
    td = TrigDynamics(model)
    rng = np.random.default_rng(3)
    P = 7
    theta = model.inertial_parameters() * (1 + 0.2 * rng.random((P, 10 * model.nv)))
    arm = rng.uniform(0, 0.05, (P, model.nv))
    q = rng.uniform(-3, 3, (P, model.nv))
    dq = rng.uniform(-2, 2, (P, model.nv))
    tau = rng.uniform(-5, 5, (P, model.nv))
    Mc, Gc = td.coefficients(theta, arm)
    M, h = td.terms(Mc, Gc, q, dq)
    acc = td.forward(Mc, Gc, q, dq, tau)
    for i in range(P):
        m = pin.Model(model.pin_model)
        for j in range(model.nv):
            m.inertias[j + 1] = pin.Inertia.FromDynamicParameters(theta[i, 10 * j : 10 * j + 10])
        m.armature[:] = arm[i]
        d = m.createData()
        c = model.configuration(q[i])
        Mp = pin.crba(m, d, c)
        Mp = np.triu(Mp) + np.triu(Mp, 1).T
        np.testing.assert_allclose(M[i], Mp, atol=1e-11)
        np.testing.assert_allclose(h[i], pin.rnea(m, d, c, dq[i], np.zeros(model.nv)), atol=1e-10)
        np.testing.assert_allclose(acc[i], pin.aba(m, d, c, dq[i], tau[i]), rtol=1e-9, atol=1e-9)


def test_trig_backend_refuses_what_it_cannot_do():
    with pytest.raises(SpecError, match="at most 3"):
        TrigDynamics(load("panda"))
    with pytest.raises(SpecError, match="pinocchio"):
        FlexibleModel(load("panda"), [], backend="trig")


# ---------------------------------------------------------------------------------------------- simulator
def pulse_input(n=151, dt=0.002, amp=(0.4, 0.3), bias=(0.0, 0.44145)):
    t = np.arange(n) * dt
    u = np.tile(np.array(bias, float), (n, 1))
    on = (t > 0.02) & (t < 0.12)
    u[on] += np.array(amp)
    u[t >= 0.12] -= 0.5 * np.array(amp)
    return t, u


def test_backends_and_population_rows_agree(tracker):
    trig = flexible_model(tracker, TABLE1, backend="trig")
    pino = flexible_model(tracker, TABLE1, backend="pinocchio")
    assert "trig" in flexible_model(tracker, TABLE1).backends
    t, u = pulse_input()
    rng = np.random.default_rng(0)
    X = trig.values * (1 + 0.1 * rng.random((3, trig.values.size)))
    a = trig.simulate(u, 0.002, X)
    b = pino.simulate(u, 0.002, X, step=a.step)
    np.testing.assert_allclose(a.q, b.q, atol=1e-10)
    np.testing.assert_allclose(a.qm, b.qm, atol=1e-9)
    for i in range(3):  # a row of a population is the same run as alone
        one = trig.simulate(u, 0.002, X[i], step=a.step)
        np.testing.assert_allclose(one.q[0], a.q[i], atol=1e-12)


def test_static_equilibrium_and_gravity_sign(tracker):
    """At rest with the holding torque g(0)/r the barrel stays still, its belt stretched by g/K1."""
    m = flexible_model(tracker, TABLE1)
    g = 1.5 * 9.81 * 0.06
    u = np.tile([0.0, g / 2.0], (101, 1))
    s = m.simulate(u, 0.002)
    assert np.max(np.abs(s.q[0])) < 1e-9
    delta = s.qm[0, 0, 1] / 2.0 - s.q[0, 0, 1]
    assert 105.62 * delta - 183.90 * delta**3 == pytest.approx(g, rel=1e-9)
    s = m.simulate(np.zeros((101, 2)), 0.002)  # without the holding torque, it falls (elevation decreases)
    assert s.q[0, -1, 1] < -0.01


def test_energy_is_conserved_without_losses(tracker):
    """No damping, no friction: kinetic + potential + spring energy is constant after the input stops."""
    drives = {j: {**d, "C": 0.0, "Bm": 0.0, "fv": 0.0, "fc": 0.0, "b": 0.0, "K2": 300.0} for j, d in TABLE1.items()}
    m = flexible_model(tracker, drives)
    t, u = pulse_input(n=501, dt=0.002, bias=(0.0, 0.0))
    u[t >= 0.12] = 0.0
    s = m.simulate(u, 0.002, step=0.0005)
    model = pin.Model(tracker.pin_model)
    data = model.createData()
    k = np.flatnonzero(t >= 0.14)
    energy = []
    for i in k:
        q, dq, qm, dqm = s.q[0, i], s.dq[0, i], s.qm[0, i], s.dqm[0, i]
        e = pin.computeKineticEnergy(model, data, q, dq) + pin.computePotentialEnergy(model, data, q)
        for j, name in enumerate(["base", "barrel"]):
            d = qm[j] / TABLE1[name]["ratio"] - q[j]
            e += 0.5 * TABLE1[name]["Jm"] * dqm[j] ** 2 + 0.5 * TABLE1[name]["K1"] * d**2 + 0.25 * 300.0 * d**4
        energy.append(e)
    energy = np.array(energy)
    kinetic = pin.computeKineticEnergy(model, data, s.q[0, k[0]], s.dq[0, k[0]])
    assert kinetic > 1e-3  # something moves
    assert np.ptp(energy) < 1e-6 * max(abs(energy).max(), kinetic)


def test_very_stiff_belt_behaves_rigid(tracker):
    stiff = {j: {**d, "K1": 2e4, "K2": 0.0, "C": 2.0} for j, d in TABLE1.items()}
    flex = flexible_model(tracker, stiff)
    rigid = flex.rigid()
    assert rigid.flexible_joints == [] and "base.K1" not in rigid.names
    t, u = pulse_input()
    a = flex.simulate(u, 0.002)
    b = rigid.simulate(u, 0.002)
    assert a.step < 0.002 / 4  # the stiff spring forces a small step
    assert np.max(np.abs(a.q - b.q)) < 0.01 * np.max(np.abs(b.q))


def test_voltage_input_is_kv_times_torque(tracker):
    drives = {j: {**d, "kv": 0.5} for j, d in TABLE1.items()}
    m = flexible_model(tracker, drives)
    t, u = pulse_input()
    a = m.simulate(u, 0.002)
    b = m.simulate(2 * u, 0.002, input="voltage")
    np.testing.assert_allclose(a.q, b.q, atol=1e-12)


def test_step_rule_and_integrator_tolerance(tracker):
    m = flexible_model(tracker, TABLE1)
    omega, lam = m.rates(m.values[None], np.zeros(2))
    h, n = m.choose_step(0.002, m.values[None], np.zeros(2))
    assert h * omega <= 0.5 + 1e-12 and h * lam <= 2.0 + 1e-12 and h * n == pytest.approx(0.002)
    t, u = pulse_input(n=251)
    a = m.simulate(u, 0.002)
    b = m.simulate(u, 0.002, step=a.step / 16)
    assert np.max(np.abs(a.q - b.q)) < 1e-5  # docs/flexible.md: 6e-6 rad at 2 ms on the spec's input


def test_simulator_rejects_bad_input(tracker):
    m = flexible_model(tracker, TABLE1)
    with pytest.raises(DataError, match="shape"):
        m.simulate(np.zeros((10, 3)), 0.002)
    with pytest.raises(DataError, match="NaN"):
        m.simulate(np.full((10, 2), np.nan), 0.002)
    with pytest.raises(SpecError, match="K1"):
        flexible_model(tracker, {"base": {"ratio": 1.0, "Jm": 0.01}})  # K1 has no default
    with pytest.raises(JointError, match="elbow"):
        FlexibleModel(tracker, [Drive("elbow", 2.0)], {})


def test_general_urdf_flexible_knee():
    """Any URDF: a flexible knee on the exoskeleton leg, both backends, hip torque-driven."""
    leg = load("exo_leg")
    drives = {"knee": dict(ratio=50.0, K1=800.0, C=1.0, Jm=2e-4, Bm=1e-4, fv=1e-3, fc=0.01)}
    a = flexible_model(leg, drives, backend="trig")
    b = flexible_model(leg, drives, backend="pinocchio")
    assert a.flexible_joints == ["knee"] and "hip.K1" not in a.names and "hip.Jm" in a.names
    t = np.arange(101) * 0.002
    u = np.column_stack([20 * np.sin(6 * t), 0.2 * np.sin(9 * t)])
    q0 = np.array([0.3, -0.5])
    sa = a.simulate(u, 0.002, q0=q0)
    sb = b.simulate(u, 0.002, q0=q0, step=sa.step)
    np.testing.assert_allclose(sa.q, sb.q, atol=1e-9)
    assert np.ptp(sa.q[0, :, 0]) > 1e-3


# ---------------------------------------------------------------------------------------------- twin, spec
def test_spec_reads_table1_and_bounds(spec):
    assert spec.robot.name == "tracker_2dof"
    assert [d.ratio for d in spec.drives] == [3.0, 2.0]
    assert spec.fixed == {"base.Bm": 0.0039, "barrel.Bm": 0.0053}
    assert len(spec.free) == 16 and spec.truth["base.K2"] == -261.30 and spec.truth["barrel.Iyy"] == 0.0254
    m = spec.model()
    assert m.value("base.Izz") == 0.095 and m.value("barrel.fc") == 0.0653
    rigid = spec.rigid()
    assert not any(n.endswith((".K1", ".K2", ".C")) for n in rigid.free) and len(rigid.free) == 10


def test_twin_noise_is_seeded_and_recording_roundtrips(spec, tmp_path):
    s = short_spec(spec, 0.2)
    a = make_twin(s.model(), s.input, noise=1e-3, rng=5)
    b = make_twin(s.model(), s.input, noise=1e-3, rng=5)
    c = make_twin(s.model(), s.input, noise=1e-3, rng=6)
    np.testing.assert_array_equal(a.q, b.q)
    assert not np.array_equal(a.q, c.q)
    clean = make_twin(s.model(), s.input, noise=0.0)
    assert np.std(a.q - clean.q) == pytest.approx(1e-3, rel=0.2)
    path = a.save(tmp_path / "rec.csv")
    r = FlexRecording.load(path)
    assert r.joints == ["base", "barrel"] and r.input == "torque"
    np.testing.assert_allclose(r.q, a.q, rtol=1e-11, atol=1e-14)
    np.testing.assert_allclose(r.qm, a.qm, rtol=1e-11, atol=1e-14)
    assert r.meta["truth"]["base.K1"] == 91.66
    assert open(path).readline().strip() == "t,T_base,T_barrel,q_base,q_barrel,qm_base,qm_barrel"


@pytest.mark.parametrize(
    "content, fragment",
    [
        ("x,T_a,q_a\n0,0,0\n", "expected 't'"),
        ("t,q_base\n0,0\n0.1,0\n0.2,0\n", "input columns"),
        ("t,T_base,q_base,T_barrel,q_barrel\n0,0,0,0,0\n0.1,0,0,0,0\n0.25,0,0,0,0\n", "uniform sampling"),
        ("t,T_base,q_base,T_barrel,q_barrel\n0,0,0,0,0\n0.1,0,nan,0,0\n0.2,0,0,0,0\n", "NaN"),
        ("t,T_base,q_base,foo\n0,0,0,0\n0.1,0,0,0\n0.2,0,0,0\n", "unknown column"),
    ],
)
def test_bad_recordings(tmp_path, content, fragment):
    p = tmp_path / "bad.csv"
    p.write_text(content)
    with pytest.raises(DataError, match=re.escape(fragment)):
        FlexRecording.load(p)


BAD_SPECS = [
    ("K1 = [20.0, 400.0]", "K1 = [-5.0, 400.0]", "negative or zero stiffness"),
    ("K1 = [20.0, 400.0]", "K1 = -3.0", "expected > 0"),
    ("[joints.barrel]", "[joints.elbow]", "unknown joint 'elbow'"),
    ("ratio = 3.0", "ratio = 0.0", "ratio = 0.0, expected a positive number"),
    ("ratio = 3.0", "ratio = -2", "ratio = -2, expected a positive number"),
    ("Jm = [0.004, 0.03]", "Jm = [0.0, 0.03]", "motor inertia"),
    ("C = [0.0, 0.2]", "C = [-0.1, 0.2]", "negative values allowed"),
    ("fc = [0.0, 0.3]", "fc = [0.3, 0.1]", "expected lower < upper"),
    ("fc = [0.0, 0.3]", "friction = [0.0, 0.3]", "unknown parameter 'friction'"),
    ("K1 = 91.66", "K1 = 500.0", "outside its bounds"),
    ('cost = "abs"', 'cost = "l1"', "cost = 'l1'"),
    ('method = "pso"', 'method = "ga"', "method = 'ga'"),
]


@pytest.mark.parametrize("old, new, fragment", BAD_SPECS)
def test_bad_specs_give_clear_errors(tmp_path, old, new, fragment):
    text = SPEC.read_text()
    assert old in text
    p = tmp_path / "bad.toml"
    p.write_text(text.replace(old, new, 1).replace('urdf = "../urdf/', f'urdf = "{ROOT}/urdf/'))
    with pytest.raises(SpecError) as err:
        load_flex_spec(p)
    msg = str(err.value)
    assert fragment in msg and str(p) in msg and "\n" not in msg


def test_cli_bad_spec_is_one_line(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text(
        SPEC.read_text()
        .replace("[joints.barrel]", "[joints.elbow]")
        .replace('urdf = "../urdf/', f'urdf = "{ROOT}/urdf/')
    )
    assert_clean_error(run_cli("flex", "check", "--spec", str(p)), "unknown joint 'elbow'", "bad.toml")
    q = tmp_path / "neg.toml"
    q.write_text(
        SPEC.read_text()
        .replace("K1 = [20.0, 400.0]", "K1 = [-5.0, 400.0]", 1)
        .replace('urdf = "../urdf/', f'urdf = "{ROOT}/urdf/')
    )
    out = tmp_path / "fit.json"
    assert_clean_error(run_cli("flex", "fit", "--spec", str(q), "-o", str(out)), "base.K1", "stiffness")
    assert not out.exists()


# ---------------------------------------------------------------------------------------------- identification
@pytest.mark.slow
def test_noise_free_recovery_within_two_percent(spec):
    """Noise-free twin (made with a 4× finer step), least squares from 10 % off: every parameter within 2 %
    with the 0.5 ms step; the simulated angles match to the integrator's tolerance."""
    s = short_spec(spec, 1.0, max_step=0.0005)
    twin = make_twin(s.model(), s.input, noise=0.0)
    prob = problem_from_spec(s, twin, cost="sq")
    xt = np.array([prob.truth[n] for n in prob.free])
    signs = np.random.default_rng(1).choice([-1.0, 1.0], xt.size)
    res = fit_output_error(prob, "least_squares", x0=xt * (1 + 0.1 * signs), max_nfev=40)
    bad = {n: e for n, e in res.rel_error.items() if abs(e) > 0.02}
    assert not bad, bad
    tol = res.extra["integrator_error"]
    assert tol < 1e-7
    assert max(m["max_abs"] for m in res.metrics.values()) < 10 * tol


def test_sensitivity_says_what_is_observable(spec):
    s = short_spec(spec, 1.0)
    twin = make_twin(s.model(), s.input, noise=0.0)
    sens = sensitivity(problem_from_spec(s, twin), noise=1e-3)
    rel = sens["rel_std"]
    for n in ("base.K2", "barrel.K2", "base.C"):  # the cubic spring and the tiny base damper: not at 1 mrad
        assert classify(rel[n]) == "unobservable", (n, rel[n])
    for n in ("base.K1", "base.Izz", "barrel.Jm"):
        assert rel[n] < 0.05, (n, rel[n])


@pytest.mark.parametrize("method", methods())
def test_every_method_through_one_interface(spec, method, tmp_path):
    s = short_spec(spec, 0.2)
    twin = make_twin(s.model(), s.input, noise=1e-3, rng=0)
    prob = problem_from_spec(s, twin)
    opts = None if method == "least_squares" else {"population": 6, "iterations": 3}
    res = fit_output_error(prob, method, rng=0, options=opts, max_nfev=3)
    h = np.array(res.history)
    assert res.nfev > 0 and res.seconds > 0 and np.all(np.diff(h[:, 1]) <= 1e-12) and np.all(np.diff(h[:, 0]) >= 0)
    assert res.cost == pytest.approx(prob.cost(res.x)) and res.cost <= h[0, 1] + 1e-12
    assert np.all(res.x >= prob.lower) and np.all(res.x <= prob.upper)
    back = OutputErrorResult.load(res.save(tmp_path / "r.json"))
    assert back.values == res.values and back.rel_error == res.rel_error


def test_problem_checks(spec):
    s = short_spec(spec, 0.2)
    twin = make_twin(s.model(), s.input, noise=0.0, motor=False)
    with pytest.raises(DataError, match="motor angles"):
        problem_from_spec(s, twin, outputs=("link", "motor"))
    with pytest.raises(SpecError, match="cost"):
        OutputErrorProblem(s.model(), twin, FreeParameters(s.free, s.lower, s.upper), cost="l1")
    with pytest.raises(SpecError, match="expected FreeParameters"):
        OutputErrorProblem(s.model(), twin, s.free)
    with pytest.raises(SpecError, match="FreeParameters names"):
        FreeParameters("ks", [1.0], [2.0])
    with pytest.raises(SpecError, match="unknown method"):
        fit_output_error(problem_from_spec(s, twin), "ga")


# ---------------------------------------------------------------------------------------------- CLI
@pytest.mark.slow
def short_spec_file(folder: Path) -> Path:
    """The tracker spec with a 0.3 s input and absolute URDF paths, written to ``folder``/s.toml."""
    sp = folder / "s.toml"
    sp.write_text(
        SPEC.read_text()
        .replace("duration = 2.0", "duration = 0.3")
        .replace('urdf = "../urdf/', f'urdf = "{ROOT}/urdf/')
    )
    return sp


def test_cli_twin_fit_compare(spec, tmp_path):
    sp = short_spec_file(tmp_path)
    rec = tmp_path / "rec.csv"
    p = run_cli("flex", "twin", "--spec", str(sp), "-o", str(rec), "--seed", "3")
    assert p.returncode == 0, p.stderr
    assert rec.exists() and (tmp_path / "rec.csv.json").exists()
    out, fig = tmp_path / "fit.json", tmp_path / "fit.png"

    def fit(*args: str):  # pinid flex fit of the spec on the recording
        return run_cli("flex", "fit", "--spec", str(sp), "--data", str(rec), *args)

    p = fit("--method", "pso", "--population", "6", "--iterations", "2", "-o", str(out), "--plot", str(fig))
    assert p.returncode == 0, p.stderr
    d = json.loads(out.read_text())
    assert d["method"] == "pso" and d["model"] == "flexible" and set(d["values"]) == set(spec.free)
    assert d["truth"]["base.K1"] == 91.66 and fig.stat().st_size > 1000
    p = fit(
        "--method", "least_squares", "--x0", "truth", "--max-nfev", "2", "--rigid", "-o", str(tmp_path / "rigid.json")
    )
    assert p.returncode == 2 and "--x0 truth" in p.stderr  # the rigid model has no truth
    cmp_ = tmp_path / "cmp.json"
    p = run_cli(
        "flex",
        "compare",
        "--spec",
        str(sp),
        "--method",
        "de",
        "--population",
        "6",
        "--iterations",
        "2",
        "--no-polish",
        "-o",
        str(cmp_),
        "--plot",
        str(tmp_path / "cmp.png"),
    )
    assert p.returncode == 0, p.stderr
    d = json.loads(cmp_.read_text())
    assert d["flexible"]["model"] == "flexible" and d["rigid"]["model"] == "rigid"
    assert "rigid" in p.stdout and (tmp_path / "cmp.png").exists()


def test_flex_output_option_is_o_like_every_command_and_out_still_works(tmp_path):
    """-o/--output as in the other commands; --out is a deprecated alias (same file)."""
    import subprocess
    import sys

    sp = short_spec_file(tmp_path)
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    assert run_cli("flex", "twin", "--spec", str(sp), "-o", str(a), "--seed", "3").returncode == 0
    proc = subprocess.run(
        [
            sys.executable,
            "-W",
            "error::DeprecationWarning:pinid.cli.flex",
            "-m",
            "pinid.cli",
            "flex",
            "twin",
            "--spec",
            str(sp),
            "--out",
            str(b),
            "--seed",
            "3",
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode != 0 and "deprecated" in proc.stderr  # the warning is there (made an error here)
    assert run_cli("flex", "twin", "--spec", str(sp), "--out", str(b), "--seed", "3").returncode == 0
    assert a.read_bytes() == b.read_bytes()


@pytest.mark.slow
def test_flex_help_examples_run_from_any_folder(tmp_path):
    """--spec takes a bundled spec's name (as --urdf and --excitation take theirs): the help's examples run in
    an empty folder, not only at the repository's root (the fits shortened by --population/--iterations)."""
    from pinid.cli.main import build_parser
    from pinid.resources import bundled_flex_specs

    assert "tracker_flex_spec" in bundled_flex_specs()
    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    examples = sub.choices["flex"].format_help().split("\nexamples:\n")[1].split("\n\n")[0].splitlines()
    short = {"fit": ["--population", "6", "--iterations", "2", "--max-nfev", "3"]}
    ran = []
    for line in examples:
        argv = line.split()[1:]
        if argv[1] == "compare":
            continue  # compare runs two fits of the spec's size (minutes): its --spec is the same lookup
        assert argv[argv.index("--spec") + 1] == "tracker_flex_spec", line
        proc = run_cli(*argv, *short.get(argv[1], []), cwd=tmp_path)
        assert proc.returncode == 0, (line, proc.stderr)
        ran.append(argv[1])
    assert ran == ["check", "twin", "fit", "fit"]
    assert {"tracker_twin.csv", "fit.json", "polished.json"} <= {p.name for p in tmp_path.iterdir()}
    assert_clean_error(run_cli("flex", "check", "--spec", "no_such_spec", cwd=tmp_path), "tracker_flex_spec")
    assert load_flex_spec("tracker_flex_spec.toml").source == load_flex_spec("tracker_flex_spec").source


def test_flex_force_and_progress_before_or_after_the_action():
    """pinid flex --force twin … and pinid flex twin --force … both force (the action's default used to undo
    the command's); the same for --no-progress."""
    from pinid.cli.main import build_parser

    parser = build_parser()
    for argv in (["flex", "--force", "--no-progress", "twin"], ["flex", "twin", "--force", "--no-progress"]):
        args = parser.parse_args([*argv, "-o", "x.csv"])
        assert args.force is True and args.progress is False, argv
    args = parser.parse_args(["flex", "twin", "-o", "x.csv"])
    assert args.force is False and args.progress is None


def _flex_spec(tmp_path, f_max: str):
    from pinid.model.bundled import BUNDLED_URDF_DIR

    src = BUNDLED_URDF_DIR.parent / "excitation" / "tracker_flex_spec.toml"
    text = src.read_text().replace("f_max = 12.0", f"f_max = {f_max}")
    assert f"f_max = {f_max}" in text
    path = tmp_path / "spec.toml"
    path.write_text(text.replace('urdf = "', f'urdf = "{src.parent}/') if 'urdf = "../' in text else text)
    return path


def test_flex_f_max_above_nyquist_refused(tmp_path):
    """Case 25: f_max at or above half the input rate (500 Hz) is refused."""
    for f_max in ("1e9", "250.0"):
        spec = _flex_spec(tmp_path, f_max)
        proc = run_cli("flex", "check", "--spec", str(spec), cwd=tmp_path)
        assert_clean_error(proc, "f_max", "Nyquist")
