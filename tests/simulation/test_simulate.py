"""The digital twin: exact truth, round trip through files and preprocessing, presets, perturbation, CLI."""

from __future__ import annotations

import hashlib
import json
import warnings

import numpy as np
import pytest

from conftest import assert_clean_error, load, run_cli
from pinid import base_parameters, parameter_names
from pinid.data.formats import read_recording, write_recording
from pinid.errors import SpecError
from pinid.data.preprocess import lowpass, prepare
from pinid.simulation.twin import (
    ZHA2019_TABLE1,
    WearerLoad,
    drawn_wearer_truth,
    friction_torque,
    simulate,
    truth_json,
)
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.cad import perturb
from pinid.excitation.trajectory import FourierTrajectory


@pytest.fixture(scope="module")
def apal_run():
    model = load("apal_leg")
    ds, truth = simulate(model, load_trajectory("zha2019-4", model), seconds=6.0, seed=3)
    return model, ds, truth


@pytest.fixture(scope="module")
def apal_run3():
    model = load("apal_leg")
    return simulate(model, load_trajectory("zha2019-3", model), seconds=6.0, seed=4)


def test_truth_signals_satisfy_the_dynamics_exactly(apal_run):
    model, ds, truth = apal_run
    s = truth["signals"]
    fc, fv = model.coulomb, model.viscous
    v_s = truth["friction"]["coulomb_velocity_scale"]
    smooth = model.rnea(s.q, s.dq, s.ddq) + fc * np.tanh(s.dq / v_s) + fv * s.dq
    np.testing.assert_allclose(smooth, s.tau, atol=1e-9 * np.abs(s.tau).max())
    # the regressor's sign model differs only within a few v_s of zero velocity
    sign = model.rnea(s.q, s.dq, s.ddq) + friction_torque(s.dq, fc, fv)
    far = np.abs(s.dq) > 3 * v_s
    assert np.max(np.abs(sign - s.tau)[far]) < 0.01 * fc.max()
    assert far.mean() > 0.97


def test_recording_is_truth_plus_noise(apal_run):
    model, ds, truth = apal_run
    s = truth["signals"]
    sigma_tau = np.array(list(truth["noise"]["torque_std"].values()))
    np.testing.assert_allclose(sigma_tau, 0.01 * np.abs(s.tau).max(axis=0))
    r = ds.tau - s.tau
    assert np.all(np.abs(r.std(axis=0) / sigma_tau - 1) < 0.05)
    res = truth["noise"]["encoder_resolution"]
    assert res == pytest.approx(2 * np.pi / 2**16)
    np.testing.assert_allclose(np.round(ds.q / res) * res, ds.q, atol=1e-12)  # quantised
    assert np.abs(ds.q - s.q).std() < 3 * np.hypot(truth["noise"]["position_std"], res / np.sqrt(12))
    assert ds.dq is None and ds.ddq is None


def test_round_trip_simulate_write_read_prepare(apal_run, tmp_path):
    """Stated tolerances (docs/simulate.md): against the truth filtered by the same low-pass."""
    model, ds, truth = apal_run
    back = read_recording(write_recording(tmp_path / "run.csv", ds), model=model)
    out = prepare(back)
    s = truth["signals"]
    pp = out.meta["preprocess"]
    k = np.searchsorted(s.t, out.t - 1e-9)
    ref = {name: lowpass(getattr(s, name), pp["sample_rate"], pp["cutoff"])[k] for name in ("q", "dq", "ddq", "tau")}

    def rel(name):
        return np.max(
            np.sqrt(np.mean((getattr(out, name) - ref[name]) ** 2, axis=0)) / np.sqrt(np.mean(ref[name] ** 2, axis=0))
        )

    assert np.max(np.abs(out.q - ref["q"])) < 1e-4  # rad
    assert rel("dq") < 1e-3
    assert rel("ddq") < 2e-2
    assert rel("tau") < 5e-3  # the filtered sensor noise: 1 % of the peak, times about 0.15
    # torques match rnea + friction of the prepared motion within the noise, away from velocity reversals
    # (where filtering smears the Coulomb step over about 1/cutoff: see docs/data.md)
    pred = model.rnea(out.q, out.dq, out.ddq) + friction_torque(out.dq, model.coulomb, model.viscous)
    far = np.all(np.abs(out.dq) > 0.5, axis=1)
    sigma = np.array(list(truth["noise"]["torque_std"].values()))
    assert np.all(np.sqrt(np.mean((out.tau - pred)[far] ** 2, axis=0)) < sigma)
    # and raw recorded torques match the truth states within the noise
    raw = model.rnea(s.q, s.dq, s.ddq) + friction_torque(s.dq, model.coulomb, model.viscous)
    far = np.all(np.abs(s.dq) > 0.05, axis=1)
    assert np.all(np.sqrt(np.mean((ds.tau - raw)[far] ** 2, axis=0)) < 1.1 * sigma)


def test_least_squares_recovers_the_inertial_base_parameters(apal_run, apal_run3):
    """Trajectories 3 and 4 together (in No. 4 alone hip + knee is constant, so J_s is not excited)."""
    from pinid import regressor

    model, ds, truth = apal_run
    bp = base_parameters(model)
    W, y = [], []
    for rec in (ds, apal_run3[0]):
        out = prepare(rec)
        W.append(bp.columns(regressor(model, out.q, out.dq, out.ddq)))
        y.append(out.tau.reshape(-1))
    x, *_ = np.linalg.lstsq(np.vstack(W), np.concatenate(y), rcond=None)
    true = np.array(truth["base"]["values"])
    inertial = [i for i, n in enumerate(bp.names) if not n.endswith((".fc", ".fv"))]
    np.testing.assert_allclose(x[inertial], true[inertial], rtol=5e-3)


def test_truth_dict_contents(apal_run):
    model, ds, truth = apal_run
    d = truth_json(truth)
    json.dumps(d, allow_nan=False)
    assert d["standard"]["names"] == parameter_names(model)
    bp = base_parameters(model)
    assert d["base"]["names"] == bp.names and len(d["base"]["expressions"]) == bp.count
    np.testing.assert_allclose(d["base"]["values"], bp.from_standard(np.array(d["standard"]["values"])))
    assert d["friction"]["coulomb"] == {"hip": 1.7285, "knee": model.coulomb[1]}
    assert d["seed"] == 3 and d["rates"] == {"control": 1000, "sample": 1000, "integration": 2000}
    assert d["tracking"]["max_error"]["knee"] < 0.02


def test_reproducible_and_seeded():
    model = load("exo_leg")
    tr = load_trajectory("zha2019-1", model)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a, _ = simulate(model, tr, seconds=0.5, seed=7)
        b, _ = simulate(model, tr, seconds=0.5, seed=7)
        c, _ = simulate(model, tr, seconds=0.5, seed=8)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.tau, b.tau)
    assert not np.array_equal(a.tau, c.tau)


def test_friction_override_velocity_rates_and_pid():
    model = load("apal_leg")
    tr = load_trajectory("zha2019-3", model)
    ds, truth = simulate(
        model,
        tr,
        seconds=1.0,
        coulomb=[0.5, 0.2],
        viscous=0.3,
        controller="pid",
        sample_rate=200,
        control_rate=1000,
        record_velocity=True,
        torque_noise=[0.1, 0.05],
    )
    assert ds.n == 200 and ds.sample_rate == pytest.approx(200)
    assert truth["friction"]["coulomb"] == {"hip": 0.5, "knee": 0.2}
    names = truth["standard"]["names"]
    assert truth["standard"]["values"][names.index("knee.fv")] == 0.3
    assert truth["controller"]["ki"][0] > 0
    assert (ds.dq - truth["signals"].dq).std() == pytest.approx(0.01, rel=0.2)
    assert truth["noise"]["torque_std"] == {"hip": 0.1, "knee": 0.05}


@pytest.mark.parametrize("number", [1, 2, 3, 4])
def test_seed000_presets(number):
    model = load("apal_leg")
    tr = load_trajectory(f"zha2019-{number}", model)
    ho, ha, ko, ka = ZHA2019_TABLE1[number]
    q, dq, _ = tr.evaluate([0.25, 0.0])
    np.testing.assert_allclose(np.degrees(q[0]), [ho + ha, ko + ka])  # sin(2π·0.25) = 1
    np.testing.assert_allclose(dq[1], np.radians([ha, ka]) * 2 * np.pi)
    assert tr.base_frequency == pytest.approx(2 * np.pi) and tr.harmonics == 1


def test_presets_follow_each_robots_convention():
    exo = load("exo_leg")  # axes -y: both signs flip
    q, _, _ = load_trajectory("zha2019-1", exo).evaluate(0.0)
    np.testing.assert_allclose(np.degrees(q[0]), [10.0, -45.0])
    with pytest.raises(SpecError, match="takes joint 'knee' to -1.66 rad at t = 0.617 s, outside its URDF limits"):
        simulate(exo, load_trajectory("zha2019-3", exo), seconds=1.0)
    dp = load("double_pendulum")
    tr = load_trajectory("zha2019-2", dp, flip=["joint2"])
    np.testing.assert_allclose(np.degrees(tr.q0), [-10.0, -60.0])
    with pytest.raises(SpecError, match="--flip knee: not a joint of the preset"):
        load_trajectory("zha2019-2", dp, flip=["knee"])
    with pytest.raises(SpecError, match="not a bundled trajectory"):
        load_trajectory("seed000-9", dp)


def test_perturb_is_consistent_and_sized():
    model = load("apal_leg")
    base = model.inertial_parameters()
    assert np.allclose(perturb(model, 0.0, np.random.default_rng(0)).inertial_parameters(), base)
    for seed in range(5):
        theta = perturb(model, 20.0, np.random.default_rng(seed)).inertial_parameters()
        for b in range(model.nv):
            p = theta[10 * b : 10 * b + 10]
            m, h = p[0], p[1:4]
            inertia = np.array([[p[4], p[5], p[7]], [p[5], p[6], p[8]], [p[7], p[8], p[9]]])
            J = np.zeros((4, 4))
            J[:3, :3], J[:3, 3], J[3, :3], J[3, 3] = 0.5 * np.trace(inertia) * np.eye(3) - inertia, h, h, m
            assert np.linalg.eigvalsh(J).min() > -1e-12
            assert abs(m / base[10 * b] - 1) <= 0.2 + 1e-12
        change = np.abs(theta - base)[np.abs(base) > 1e-3] / np.abs(base)[np.abs(base) > 1e-3]
        assert 0.01 < np.median(change) < 0.3
    with pytest.raises(SpecError, match="perturbation 120"):
        perturb(model, 120.0, np.random.default_rng(0))


def test_api_errors():
    model = load("apal_leg")
    tr = load_trajectory("zha2019-3", model)
    with pytest.raises(SpecError, match="trajectory joints"):
        simulate(model, FourierTrajectory(["a", "b"], 1.0, [0, 0], [[0.1], [0.1]], [[0], [0]]), seconds=1)
    with pytest.raises(SpecError, match="sample rate 333.5"):
        simulate(model, tr, seconds=1, sample_rate=333.5)
    with pytest.raises(SpecError, match="integration rate 1500"):
        simulate(model, tr, seconds=1, integration_rate=1500)
    with pytest.raises(SpecError, match="friction must be >= 0"):
        simulate(model, tr, seconds=1, viscous=-1.0)
    with pytest.raises(SpecError, match="duration 0"):
        simulate(model, tr, seconds=0)


@pytest.mark.parametrize(
    ("option", "message"),
    [
        (
            {"wearer": {"thigh": ("hip", 7.0, np.zeros(3), np.eye(3))}},
            "wearer: got dict, expected a WearerLoad or None",
        ),
        ({"wearer": 5.0}, "wearer: got float, expected a WearerLoad or None"),
        ({"rates": 500}, "rates: got int, expected a Rates or None"),
        ({"friction": {"coulomb": 0.1}}, "friction: got dict, expected a Friction or None"),
        ({"controller": 3}, "controller: got int, expected a Controller"),
        ({"wearer_torque": 5.0}, "simulate: unknown option 'wearer_torque' (the wearer's options are fields of"),
        ({"bandwith": 5.0}, "simulate: unknown option 'bandwith'; expected one of "),
    ],
)
def test_option_groups_of_another_type_are_one_line_spec_errors(option, message):
    """simulate (in docs/api.md) refuses a group of the wrong type, the wearer's segments given bare (its
    keyword before WearerLoad) included, in one line naming the group."""
    model = load("apal_leg")
    with pytest.raises(SpecError) as e:
        simulate(model, load_trajectory("zha2019-3", model), seconds=1, **option)
    assert str(e.value) == message or str(e.value).startswith(message), str(e.value)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda: WearerLoad(segments=[("thigh", "hip")]), "WearerLoad segments: got list, expected the wearer's"),
        (lambda: WearerLoad(drawn={"hip": 1}), "WearerLoad drawn: got dict, expected (table values, drawn values)"),
        (lambda: WearerLoad(torque="5"), "WearerLoad torque: got str, expected a percentage"),
        (lambda: WearerLoad(torque=None), "WearerLoad torque: got NoneType, expected a percentage"),
        (lambda: WearerLoad(torque=True), "WearerLoad torque: got bool, expected a percentage"),
    ],
)
def test_wearer_load_refuses_wrong_types(make, message):
    with pytest.raises(SpecError) as e:
        make()
    assert str(e.value).startswith(message) and "\n" not in str(e.value), str(e.value)


def test_wearer_load_torque_moves_the_plant_and_its_draw_is_kept():
    """A WearerLoad's torque acts on the plant (the recorded torque is the motor's: the tracked motion changes,
    the truth states the percentage) and its ``drawn`` values are kept in ``truth["wearer"]["drawn"]``."""
    model = load("apal_leg")
    tr = load_trajectory("zha2019-3", model)
    table = model.inertial_parameters()
    drawn = {"hip": np.arange(10.0), "knee": np.ones(10)}
    plain, _ = simulate(model, tr, seconds=1.0, seed=1)
    rec, truth = simulate(model, tr, seconds=1.0, seed=1, wearer=WearerLoad(torque=20.0, drawn=(table, drawn)))
    assert truth["wearer"]["active_torque"]["percent_of_gravity_rms"] == 20.0
    assert not np.array_equal(rec.q, plain.q)
    assert truth["wearer"]["drawn"] == drawn_wearer_truth(table, drawn)
    assert truth["wearer"]["drawn"]["wearer_standard"]["hip"] == list(range(10))
    json.dumps(truth_json(truth))


# ---------------------------------------------------------------------------------------------- CLI
def _md5(p):
    return hashlib.md5(p.read_bytes()).hexdigest()


def test_cli_issue_command_line(tmp_path):
    """`pinid simulate --urdf ... --excitation FILE --seconds S --seed 1 -o data/run1.csv` with defaults."""
    exo = load("exo_leg")
    tr = FourierTrajectory(
        exo.joint_names, 0.2 * np.pi, [0.6107, -0.8727], [[0.3, 0.05], [-0.3, 0.05]], [[0.0, 0.05], [0.1, 0.0]]
    )
    tr.save(tmp_path / "excitation.json")
    args = [
        "simulate",
        "--urdf",
        "urdf/exo_leg.urdf",
        "--excitation",
        "excitation.json",
        "--seconds",
        "2",
        "--seed",
        "1",
        "-o",
        "data/run1.csv",
    ]
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    (tmp_path / "urdf").mkdir()
    (tmp_path / "urdf" / "exo_leg.urdf").write_text((root / "urdf" / "exo_leg.urdf").read_text())
    proc = run_cli(*args, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    run1, truth = tmp_path / "data" / "run1.csv", tmp_path / "data" / "run1.truth.json"
    first = (_md5(run1), _md5(truth))
    ds = read_recording(run1, model=exo)
    assert ds.n == 2000 and ds.joints == ["hip", "knee"]
    d = json.loads(truth.read_text())
    assert d["seed"] == 1 and d["standard"]["names"] == parameter_names(exo)
    again = run_cli(*args, cwd=tmp_path)  # the CLI never replaces an existing file unless told to
    assert again.returncode == 2 and "already exists" in again.stderr
    assert (_md5(run1), _md5(truth)) == first
    assert run_cli(*args, "--force", cwd=tmp_path).returncode == 0
    assert (_md5(run1), _md5(truth)) == first  # same arguments, same files


def test_cli_perturb_npz_and_true_signals(tmp_path):
    out = tmp_path / "r.npz"
    proc = run_cli(
        "simulate",
        "--urdf",
        "apal_leg",
        "--excitation",
        "zha2019-1",
        "--seconds",
        "1",
        "-o",
        str(out),
        "--perturb",
        "20",
        "--true-signals",
        str(tmp_path / "true.csv"),
        "--torque-noise",
        "0.2,0.1",
        "--coulomb",
        "hip=1.0,knee=0.5",
        "--record-velocity",
    )
    assert proc.returncode == 0, proc.stderr
    d = json.loads((tmp_path / "r.truth.json").read_text())
    assert d["cad"]["percent"] == 20.0 and d["cad"]["standard"]["values"] != d["standard"]["values"]
    assert d["friction"]["coulomb"] == {"hip": 1.0, "knee": 0.5}
    assert d["noise"]["torque_std"] == {"hip": 0.2, "knee": 0.1}
    assert read_recording(out).dq is not None
    true = read_recording(tmp_path / "true.csv")
    assert true.ddq is not None and true.n == 1000


def test_cli_cad_urdf_is_the_perturbed_model(tmp_path):
    """--cad-urdf writes the CAD model of --perturb as a URDF that loads back with the truth JSON's 'cad' values."""
    from pinid import TermSelection, RobotModel, standard_parameters

    cad = tmp_path / "cad.urdf"
    proc = run_cli(
        "simulate",
        "--urdf",
        "exo_leg",
        "--excitation",
        "excitation/exo_leg.json",
        "--seconds",
        "1",
        "-o",
        str(tmp_path / "r.csv"),
        "--perturb",
        "30",
        "--cad-urdf",
        str(cad),
    )
    assert proc.returncode == 0, proc.stderr
    d = json.loads((tmp_path / "r.truth.json").read_text())
    back = RobotModel.from_urdf(cad)
    np.testing.assert_allclose(
        standard_parameters(back, TermSelection()), d["cad"]["standard"]["values"], rtol=1e-9, atol=1e-12
    )
    assert d["cad"]["standard"]["values"] != d["standard"]["values"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--excitation", "seed000-7"], "seed000-7: no such excitation file, and not a bundled trajectory"),
        (
            ["--urdf", "exo_leg", "--excitation", "zha2019-3"],
            "trajectory takes joint 'knee' to -1.66 rad at t = 0.617 s, outside its URDF limits",
        ),
        (["--excitation", "zha2019-1", "-o", "x.txt"], "unknown suffix '.txt', expected .csv or .npz"),
        (["--excitation", "zha2019-1", "--coulomb", "1,2,3"], "--coulomb '1,2,3': 3 values for 2 joints"),
        (["--excitation", "zha2019-1", "--coulomb", "ankle=1"], "--coulomb: joint 'ankle' is not an active joint"),
        (["--excitation", "zha2019-1", "--torque-noise", "lots%"], "--torque-noise 'lots%'"),
        (["--excitation", "zha2019-1", "--sample-rate", "300", "--control-rate", "7"], "velocity cut-off 30 Hz"),
        (["--excitation", "zha2019-1", "--perturb", "150"], "perturbation 150.0 %"),
        (["--excitation", "zha2019-1", "--cad-urdf", "cad.urdf"], "--cad-urdf needs --perturb"),
        (["--excitation", "bad.json"], "not valid JSON"),
        (["--excitation", "hip.json"], "trajectory joints ['thigh'] do not match apal_leg's active joints"),
    ],
)
def test_cli_errors_leave_nothing(tmp_path, args, message):
    (tmp_path / "bad.json").write_text("{")
    FourierTrajectory(["thigh"], 1.0, [0.0], [[0.1]], [[0.0]]).save(tmp_path / "hip.json")
    before = set(tmp_path.iterdir())
    base = ["simulate", "--urdf", "apal_leg", "--seconds", "1", "-o", "out.csv"]
    if "--urdf" in args:
        base = ["simulate", "--seconds", "1", "-o", "out.csv"]
    if "-o" in args:
        base = base[:-2]
    proc = run_cli(*base, *args, cwd=tmp_path)
    assert_clean_error(proc, message)
    assert set(tmp_path.iterdir()) == before


def test_old_trajectory_preset_names_still_work_with_a_deprecation_warning():
    from pinid.simulation import twin as twin_module

    model = load("apal_leg")
    with pytest.warns(DeprecationWarning, match="'seed000-3' is deprecated, use 'zha2019-3'"):
        old = load_trajectory("seed000-3", model)
    new = load_trajectory("zha2019-3", model)
    assert old.meta["name"] == new.meta["name"] == "zha2019-3"
    np.testing.assert_array_equal(old.evaluate(0.3)[0], new.evaluate(0.3)[0])
    with pytest.warns(DeprecationWarning, match="seed000_trajectory is deprecated"):
        assert twin_module.seed000_trajectory is twin_module.zha2019_trajectory


def test_cli_draws_the_run_beside_the_recording(tmp_path):
    """OUTPUT with .png: written (a PNG), listed in what the command prints, left out with --no-figures; the
    figure's error column is the truth's tracking error (simulated − reference)."""
    args = ("simulate", "--urdf", "apal_leg", "--excitation", "zha2019-1", "--seconds", "1", "--seed", "2")
    proc = run_cli(*args, "-o", str(tmp_path / "a.csv"), figures=True)
    assert proc.returncode == 0, proc.stderr
    png = tmp_path / "a.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert f"wrote {png} (per joint: reference and simulated q, tracking error, measured torque)" in proc.stdout
    proc = run_cli(*args, "--no-figures", "-o", str(tmp_path / "b.csv"))
    assert proc.returncode == 0, proc.stderr
    assert not (tmp_path / "b.png").exists() and ".png" not in proc.stdout
    assert sorted(f.name for f in tmp_path.iterdir()) == ["a.csv", "a.png", "a.truth.json", "b.csv", "b.truth.json"]
    # --no-figures is not part of the run's record: the same truth and command line but for the file name
    a, b = (json.loads((tmp_path / f"{k}.truth.json").read_text()) for k in "ab")
    assert a.pop("command").replace("a.csv", "b.csv") == b.pop("command") and a == b


def test_simulation_figure_draws_the_tracking_error(apal_run):
    from pinid.report.plot_simulation import simulation_figure

    model, ds, truth = apal_run
    reference = load_trajectory("zha2019-4", model).evaluate(ds.t)[0]
    fig = simulation_figure(ds.t, reference, truth["signals"].q, ds.tau, ds.joints)
    try:
        error_axes = fig.axes[1::3]
        error = 1e3 * (truth["signals"].q - reference)  # [mrad]
        for j, joint in enumerate(ds.joints):
            # at most ~2000 points a line: each bucket's extremes, samples of the error at their own times
            line = error_axes[j].lines[0]
            at = np.searchsorted(ds.t, line.get_xdata())
            assert len(at) <= 2000 and np.array_equal(ds.t[at], line.get_xdata())
            assert np.array_equal(line.get_ydata(), error[at, j])
            assert line.get_ydata().max() == error[:, j].max() and line.get_ydata().min() == error[:, j].min()
            rms = 1e3 * truth["tracking"]["rms_error"][joint]
            assert np.sqrt(np.mean(error[:, j] ** 2)) == pytest.approx(rms, rel=1e-9)
            assert f"RMS {rms:.3g} mrad" in [t.get_text() for t in error_axes[j].texts]
        with pytest.raises(SpecError, match="reference: shape"):
            simulation_figure(ds.t, reference[:, :1], truth["signals"].q, ds.tau, ds.joints)
    finally:
        import matplotlib.pyplot as plt

        plt.close("all")
