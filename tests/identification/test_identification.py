"""Identification end to end: ground-truth recovery, noise floor, checks of the data, results, CLI, real data.

Ground truth is generated here directly: q(t) a Fourier series inside the limits, dq and ddq analytic,
tau = rnea + fc·sign(dq) + fv·dq (+ Gaussian noise of known σ), so nothing depends on a simulator.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from pinid import TermSelection, base_parameters, standard_parameters
from pinid.identification.study import Study
from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError
from pinid.identification.metrics import METRIC_NAMES
from pinid.identification.result import Identification, IdentificationResult
from pinid.identification.run import identify
from pinid.problem.problem import IdentificationProblem
from pinid.problem.rows import rest_thresholds

from conftest import assert_clean_error, load, run_cli, shared_data

SHARED = shared_data()
FRICTION = {"fc": 0.4, "fv": 0.2}


# ---------------------------------------------------------------------------------------------- helpers
def truth_model(name: str, fc: float = FRICTION["fc"], fv: float = FRICTION["fv"]):
    """A robot whose friction is (fc, fv) at every joint."""
    m = load(name)
    return m.with_inertial_parameters(m.inertial_parameters(), coulomb=np.full(m.nv, fc), viscous=np.full(m.nv, fv))


def fourier_motion(
    model,
    seconds: float,
    rate: float,
    seed: int,
    *,
    harmonics: int = 4,
    frequency: float = 0.2,
    fill: float = 0.85,
    around=None,
    amplitude=None,
):
    """(t, q, dq, ddq): a random Fourier series per joint inside the position and velocity limits."""
    rng = np.random.default_rng(seed)
    nv = model.nv
    t = np.arange(int(round(seconds * rate))) / rate
    lo = np.where(np.isfinite(model.lower), model.lower, -np.pi)
    hi = np.where(np.isfinite(model.upper), model.upper, np.pi)
    vmax = np.where(np.isfinite(model.velocity_limit), model.velocity_limit, 3.0)
    mid = 0.5 * (lo + hi) if around is None else np.asarray(around, float)
    half = 0.5 * (hi - lo) if amplitude is None else np.full(nv, float(amplitude))
    w = 2 * np.pi * frequency * np.arange(1, harmonics + 1)
    a = rng.normal(size=(nv, harmonics)) / np.arange(1, harmonics + 1)
    b = rng.normal(size=(nv, harmonics)) / np.arange(1, harmonics + 1)
    s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
    dev, vel, acc = s @ a.T + c @ b.T, (c * w) @ a.T - (s * w) @ b.T, -(s * w**2) @ a.T - (c * w**2) @ b.T
    k = np.minimum(fill * half / np.abs(dev).max(axis=0), fill * vmax / np.abs(vel).max(axis=0))
    return t, mid + k * dev, k * vel, k * acc


def twin(model, seconds: float = 20.0, rate: float = 200.0, seed: int = 0, noise=0.0, **motion) -> Dataset:
    """A noise-free (or noisy-torque) recording of ``model`` (its friction included)."""
    t, q, dq, ddq = fourier_motion(model, seconds, rate, seed, **motion)
    tau = model.rnea(q, dq, ddq) + model.coulomb * np.sign(dq) + model.viscous * dq
    if np.any(np.asarray(noise) > 0):
        tau = tau + np.random.default_rng(1000 + seed).normal(size=tau.shape) * noise
    return Dataset(t, q, model.joint_names, dq=dq, ddq=ddq, tau=tau, source=f"twin{seed}")


def true_base(model, terms=TermSelection()):
    bp = base_parameters(model, terms)
    return bp, bp.from_standard(standard_parameters(model, terms))


def relative_errors(model, estimate, truth, terms=TermSelection()):
    """|estimate − truth| relative to max(|truth_i|, s_i): s_i is the natural magnitude of the base
    parameter (its standard combination with mass M, first moments M·L, inertias M·L² of each body,
    :func:`pinid.model.physical.parameter_scale`), so a parameter that happens to be 0 (a product of inertia of
    a symmetric link) is not a division by zero."""
    from pinid.model.physical import parameter_scale

    bp = base_parameters(model, terms)
    scale = np.abs(bp.P) @ parameter_scale(standard_parameters(model, terms), model.nv, len(terms))
    return np.abs(estimate - truth) / np.maximum(np.abs(truth), scale)


# ---------------------------------------------------------------------------------------------- recovery
@pytest.mark.parametrize("name", ["exo_leg", "ur5"])
def test_noise_free_twin_recovers_base_parameters(name):
    model = truth_model(name)
    train, valid = twin(model, seed=1), twin(model, seconds=8, seed=2)
    res = identify(Study(model, train, validate=valid))
    _, truth = true_base(model)
    for method, r in res.results.items():
        err = relative_errors(model, r.base, truth)
        assert err.max() <= 1e-6, (method, r.base_names[int(err.argmax())], err.max())
        assert r.physically_consistent, (method, r.consistency)
        assert r.validation.all["rms"] < 1e-6 * np.sqrt(np.mean(valid.tau**2))
    assert res["sdp"].standard_source == "estimator"
    assert res["ols"].standard_source == "consistent completion"  # the truth is consistent: found behind OLS


def test_noise_free_twin_recovers_panda_base_parameters():
    model = truth_model("panda")
    res = identify(Study(model, twin(model, seconds=15, rate=200, seed=3)), methods=["ols", "wls", "sdp"])
    _, truth = true_base(model)
    for method, r in res.results.items():
        err = relative_errors(model, r.base, truth)
        assert err.max() <= 1e-6, (method, r.base_names[int(err.argmax())], err.max())
        assert r.physically_consistent


@pytest.mark.parametrize("name,sigma", [("exo_leg", [0.5, 0.3]), ("ur5", 0.2)])
def test_noisy_twin_validation_rms_is_at_the_noise_floor(name, sigma):
    model = truth_model(name)
    train = twin(model, seconds=40, rate=250, seed=4, noise=sigma)
    valid_clean = twin(model, seconds=10, rate=250, seed=5)
    noise = np.random.default_rng(99).normal(size=valid_clean.tau.shape) * sigma
    valid = Dataset(
        valid_clean.t,
        valid_clean.q,
        valid_clean.joints,
        dq=valid_clean.dq,
        ddq=valid_clean.ddq,
        tau=valid_clean.tau + noise,
        source="valid",
    )
    floor = float(np.sqrt(np.mean(noise**2)))
    res = identify(Study(model, train, validate=valid), methods=["ols", "sdp"])
    for method, r in res.results.items():
        assert r.validation.all["rms"] <= 1.05 * floor, (method, r.validation.all["rms"], floor)
        assert r.train.all["rms"] <= 1.05 * floor
    assert res["sdp"].physically_consistent


@pytest.mark.slow
def test_simulated_twin_validation_rms_is_at_the_noise_floor():
    """pinid.simulation.twin's twin (closed loop, quantised positions, noisy torques, no dq/ddq recorded) through
    the default preprocessing: the validation RMS is within 5 % of the RMS of the added torque noise."""
    from pinid.simulation.twin import simulate
    from pinid.excitation.trajectory import FourierTrajectory

    model = load("exo_leg")
    t1 = FourierTrajectory(
        ["hip", "knee"],
        0.2 * np.pi,
        [0.61, -0.87],
        [[0.25, 0.1, 0.05], [0.25, -0.1, 0.05]],
        [[0.1, 0.05, 0.02], [-0.1, 0.05, 0.02]],
    )
    t2 = FourierTrajectory(
        ["hip", "knee"],
        0.25 * np.pi,
        [0.55, -0.9],
        [[0.2, -0.1, 0.05], [0.3, 0.1, -0.04]],
        [[0.1, 0.05, 0.0], [0.0, -0.05, 0.03]],
    )
    train, _ = simulate(model, t1, seconds=30, seed=1)
    valid, truth = simulate(model, t2, seconds=16, seed=2)
    floor = float(np.sqrt(np.mean((valid.tau - truth["signals"].tau) ** 2)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = identify(Study(model, train, validate=valid), methods=["ols", "sdp"])
    for method, r in res.results.items():  # the low-passed yardstick (the raw one also sees the PD's chatter)
        assert r.validation_filtered.all["rms"] <= 1.05 * floor, (method, r.validation_filtered.all["rms"] / floor)
    assert res["sdp"].physically_consistent


def test_wls_weights_joints_by_their_noise():
    model = truth_model("exo_leg")
    sigma = np.array([2.0, 0.05])
    res = identify(Study(model, twin(model, seconds=40, rate=500, seed=6, noise=sigma)), methods=["ols", "wls"])
    est = res["wls"].info["joint_sigma"]
    assert est["hip"] == pytest.approx(2.0, rel=0.05) and est["knee"] == pytest.approx(0.05, rel=0.05)
    # the knee-only parameters are much better determined once the noisy hip no longer dominates
    i = res["wls"].base_names.index("knee.Iyy")
    assert res["wls"].std[i] < 0.5 * res["ols"].std[i]


# ---------------------------------------------------------------------------------------------- statistics
def test_standard_deviations_and_condition_number_follow_the_formulas():
    model = truth_model("exo_leg")
    train = twin(model, seconds=10, rate=200, seed=7, noise=0.3)
    problem = IdentificationProblem.from_datasets(model, train)
    res = identify(Study(model, train), methods=["ols"])
    r = res["ols"]
    W, tau = problem.W, problem.tau
    x, *_ = np.linalg.lstsq(W, tau, rcond=None)
    resid = tau - W @ x
    from pinid.problem.covariance import choose_lag, fixed_b_factor

    g = np.zeros((problem.sample.max() + 1, W.shape[1]))  # Newey–West: per-sample scores, explicit lag sum
    np.add.at(g, problem.sample, W * resid[:, None])
    lag = choose_lag(g / problem.compressed()[3])  # chosen in unit-column coordinates
    S = g.T @ g
    for k in range(1, lag + 1):
        G = g[k:].T @ g[:-k]
        S += (1 - k / (lag + 1)) * (G + G.T)
    Binv = np.linalg.inv(W.T @ W)
    S /= fixed_b_factor(lag, len(g))
    std = np.sqrt(np.diag(Binv @ S @ Binv) * len(tau) / (len(tau) - W.shape[1]))
    np.testing.assert_allclose(r.base, x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(r.std, std, rtol=1e-6)
    np.testing.assert_allclose(r.std_percent, 100 * std / np.abs(x), rtol=1e-6)
    assert r.condition_number == pytest.approx(np.linalg.cond(W), rel=1e-6)
    for j, name in enumerate(model.joint_names):
        rows = problem.joint == j
        assert r.residual_rms[name] == pytest.approx(np.sqrt(np.mean(resid[rows] ** 2)), rel=1e-9)
    assert r.seconds > 0


def test_poorly_excited_data_ols_is_reported_inconsistent():
    """Small motions around one posture with noise: OLS's links are not consistent, and it says so."""
    model = truth_model("ur5")
    data = twin(
        model, seconds=15, rate=200, seed=0, noise=0.05, amplitude=0.05, around=[0.3, -1.0, 1.0, -0.5, 0.8, 0.2]
    )
    res = identify(Study(model, data), methods=["ols", "sdp"])
    assert not res["ols"].physically_consistent
    assert res["ols"].standard_source == "least-norm completion"
    assert res["ols"].consistency["problems"]
    assert "not_realisable" in res["ols"].info
    assert res["sdp"].physically_consistent
    assert res.best == "sdp"


# ---------------------------------------------------------------------------------------------- rest rows
def test_coulomb_rows_at_rest_are_dropped_per_joint():
    model = truth_model("exo_leg")
    data = twin(model, seconds=10, rate=200, seed=8)
    p = IdentificationProblem.from_datasets(model, data)
    thr = rest_thresholds(data.dq)
    for j in range(2):
        expected = int(np.sum(np.abs(data.dq[:, j]) < thr[j]))
        assert p.dropped[j] == expected > 0
        assert np.all(np.abs(data.dq[p.sample[p.joint == j], j]) >= thr[j])
    assert p.rows == 2 * data.n - p.dropped.sum()
    keep_all = IdentificationProblem.from_datasets(model, data, rest_velocity=0)
    assert keep_all.rows == 2 * data.n and keep_all.dropped.sum() == 0
    no_coulomb = IdentificationProblem.from_datasets(model, data, terms=TermSelection(coulomb=False))
    assert no_coulomb.rows == 2 * data.n
    fixed = IdentificationProblem.from_datasets(model, data, rest_velocity=[0.5, 0.0])
    assert fixed.dropped[1] == 0 and fixed.dropped[0] == int(np.sum(np.abs(data.dq[:, 0]) < 0.5))


def test_rest_threshold_follows_velocity_noise():
    rng = np.random.default_rng(0)
    t = np.arange(5000) / 1000
    dq = np.sin(2 * np.pi * 0.5 * t)[:, None] + rng.normal(scale=0.05, size=(5000, 1))
    assert rest_thresholds(dq)[0] == pytest.approx(3 * 0.05, rel=0.1)
    assert rest_thresholds(np.sin(2 * np.pi * 0.5 * t)[:, None])[0] == pytest.approx(0.02, rel=1e-3)


# ---------------------------------------------------------------------------------------------- data errors
def test_nan_mismatched_joints_few_samples_and_rank_deficiency_are_named():
    model = truth_model("exo_leg")
    good = twin(model, seconds=5, rate=100, seed=9)
    bad = Dataset(good.t, good.q, good.joints, dq=good.dq, ddq=good.ddq, tau=good.tau.copy(), source="bad.csv")
    bad.tau[17, 1] = np.nan
    with pytest.raises(DataError, match=r"bad\.csv: tau of joint 'knee' has 1 NaN.*sample 17"):
        identify(Study(model, bad))
    other = Dataset(good.t, good.q, ["hip", "ankle"], dq=good.dq, ddq=good.ddq, tau=good.tau, source="other.csv")
    with pytest.raises(DataError, match=r"other\.csv: no data for joint\(s\) \['knee'\]"):
        identify(Study(model, other))
    with pytest.raises(DataError, match="for 10 base parameters"):
        identify(Study(model, good.select(slice(0, 4))))
    still = Dataset(good.t, good.q.copy(), good.joints, dq=good.dq.copy(), ddq=good.ddq.copy(), source="still")
    still.q[:, 1], still.dq[:, 1], still.ddq[:, 1] = -0.5, 0.0, 0.0
    still.tau = model.rnea(still.q, still.dq, still.ddq) + model.coulomb * np.sign(still.dq) + model.viscous * still.dq
    with pytest.raises(DataError, match=r"rank-deficient.*knee\.fc.*knee\.fv.*knee at rest"):
        identify(Study(model, still))
    # collinear (not zero) columns: the pivoted QR names the parameters left over
    p = IdentificationProblem.from_datasets(model, good)
    p.W = p.W.copy()
    p.W[:, 4] = 2.0 * p.W[:, 1]
    with pytest.raises(
        DataError,
        match=r"rank-deficient regressor \(rank 9 < 10 base parameters\), the data do not "
        r"excite (hip\.mzR|knee\.mz) independently",
    ):
        p.check()
    with pytest.raises(DataError, match="no torque"):
        identify(Study(model, Dataset(good.t, good.q, good.joints, dq=good.dq, ddq=good.ddq)))
    with pytest.raises(SpecError, match="unknown method 'lsq'"):
        identify(Study(model, good), methods="ols,lsq")


def test_lmi_is_an_alias_of_sdp():
    """Issue 33: the docs call sdp "the LMI method"; ``lmi`` names it (once, in order)."""
    from pinid.identification.run import parse_methods

    assert parse_methods("ols,LMI") == ["ols", "sdp"]
    assert parse_methods(["lmi", "sdp", "wls"]) == ["sdp", "wls"]


def test_recordings_without_derivatives_are_prepared():
    """A recording with q and tau only goes through pinid.data.preprocess (defaults from the sample rate)."""
    model = truth_model("exo_leg")
    full = twin(model, seconds=30, rate=1000, seed=10)
    raw = Dataset(full.t, full.q, full.joints, tau=full.tau, source="raw")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = identify(Study(model, raw, validate=twin(model, seconds=10, rate=1000, seed=11)), methods=["ols"])
    assert res["ols"].validation.all["rel_rms_percent"] < 2.0


# ---------------------------------------------------------------------------------------------- results
def test_results_round_trip_through_json(tmp_path):
    model = truth_model("exo_leg")
    res = identify(
        Study(
            model,
            twin(model, seconds=8, rate=100, seed=12, noise=0.1),
            validate=twin(model, seconds=4, rate=100, seed=13, noise=0.1),
        )
    )
    d = res.to_dict()
    assert set(d["methods"]) == {"ols", "wls", "sdp"}
    for r in d["methods"].values():
        for key in (
            "base_parameters",
            "std_percent",
            "standard_parameters",
            "physically_consistent",
            "train",
            "validation",
            "condition_number",
            "seconds",
        ):
            assert key in r, key
        for kind in ("train", "validation"):
            for m in r[kind]["per_joint"].values():
                assert set(m) == set(METRIC_NAMES)
    json.dumps(d, allow_nan=False)
    path = res.save(tmp_path / "identification.json")
    back = Identification.load(path)
    assert back.best == res.best
    q, dq, ddq = model.random_states(5, np.random.default_rng(0))
    np.testing.assert_allclose(
        back.model.inverse_dynamics(q, dq, ddq), res.model.inverse_dynamics(q, dq, ddq), rtol=1e-12, atol=1e-12
    )
    one = res["wls"].save(tmp_path / "wls.json")
    r2 = IdentificationResult.load(one)
    np.testing.assert_allclose(r2.base, res["wls"].base)
    np.testing.assert_allclose(r2.std_percent, res["wls"].std_percent)
    assert r2.validation.all == res["wls"].validation.all
    np.testing.assert_allclose(r2.model.mass_matrix(q[0]), res["wls"].model.mass_matrix(q[0]), rtol=1e-12)


def test_estimator_options_reach_the_estimators():
    model = truth_model("exo_leg")
    data = twin(model, seconds=8, rate=100, seed=14, noise=0.1)
    res = identify(
        Study(model, data),
        methods=["wls", "sdp"],
        options={"wls": {"iterations": 3}, "sdp": {"mass_bounds": (0.5, 50.0), "regularization": 0.0}},
    )
    assert res["wls"].settings["iterations"] == 3 and len(res["wls"].history) >= 1
    assert res["sdp"].settings["mass_bounds"] == (0.5, 50.0)
    with pytest.raises(SpecError, match="not run"):
        identify(Study(model, data), methods=["ols"], options={"sdp": {}})


# ---------------------------------------------------------------------------------------------- CLI
def _simulated_csv(tmp_path, seed: int, seconds: float = 12.0) -> Path:
    from pinid.data.formats import write_recording
    from pinid.simulation.twin import simulate
    from pinid.excitation.trajectory import FourierTrajectory

    model = load("exo_leg")
    traj = FourierTrajectory(
        ["hip", "knee"],
        0.2 * np.pi,
        [0.61, -0.87],
        [[0.25, 0.1, 0.05], [0.25, -0.1, 0.05]],
        [[0.1, 0.05, 0.02], [-0.1, 0.05, 0.02]],
    )
    if seed % 2:
        traj = FourierTrajectory(
            ["hip", "knee"],
            0.25 * np.pi,
            [0.55, -0.9],
            [[0.2, -0.1, 0.05], [0.3, 0.1, -0.04]],
            [[0.1, 0.05, 0.0], [0.0, -0.05, 0.03]],
        )
    ds, _ = simulate(model, traj, seconds=seconds, seed=seed)
    return write_recording(tmp_path / f"run{seed}.csv", ds)


@pytest.mark.slow
def test_cli_identify_on_simulated_recordings(tmp_path):
    train, valid = _simulated_csv(tmp_path, 0), _simulated_csv(tmp_path, 1)
    out = tmp_path / "results"
    proc = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(train), "--validate", str(valid), "-o", str(out), "--verbose"
    )
    assert proc.returncode == 0, proc.stderr
    assert "== sdp" in proc.stdout and "validation" in proc.stdout  # --verbose: every method's detail
    d = json.loads((out / "identification.json").read_text())
    for m in ("ols", "wls", "sdp"):
        r = d["methods"][m]
        assert r["validation"]["all"]["rel_rms_percent"] < 10, (m, r["validation"]["all"])
    assert d["methods"]["sdp"]["physically_consistent"]
    assert (out / "identified_sdp.urdf").is_file() and (out / "report.md").is_file()
    assert (out / "errors.png").is_file() and (out / f"torque_{d['best']}.png").is_file()  # the best method's
    assert (out / "parameters.png").is_file() and (out / "predictions.png").is_file()
    from pinid.identification.identified import IdentifiedModel
    from pinid.model.robot import RobotModel

    m = IdentifiedModel.load(out / "model_sdp.json")
    reloaded = RobotModel.from_urdf(out / "identified_sdp.urdf")
    q, dq, ddq = reloaded.random_states(5, np.random.default_rng(0))
    np.testing.assert_allclose(reloaded.rnea(q, dq, ddq) + m.friction(dq), m.inverse_dynamics(q, dq, ddq), atol=1e-9)


def test_cli_errors_are_one_line_and_write_nothing(tmp_path):
    out = tmp_path / "results"
    proc = run_cli("identify", "--urdf", "exo_leg", "--data", str(tmp_path / "missing.csv"), "-o", str(out))
    assert_clean_error(proc, "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("t,q_hip,q_knee,tau_hip,tau_knee\n" + "".join(f"{k / 100},0.1,-0.5,1,nan\n" for k in range(50)))
    proc = run_cli("identify", "--urdf", "exo_leg", "--data", str(bad), "-o", str(out))
    assert_clean_error(proc, "bad.csv")
    proc = run_cli("identify", "--urdf", "exo_leg", "--data", str(bad), "--methods", "ols,magic", "-o", str(out))
    assert_clean_error(proc, "magic")
    assert not out.exists() or not any(out.iterdir())


# ---------------------------------------------------------------------------------------------- real data
DP = SHARED / "double_pendulum"


@pytest.mark.skipif(
    not (DP / "trajectory_02.csv").is_file(),
    reason=f"real recordings not found at {DP} (set PINID_SHARED_DATA to the folder holding double_pendulum/)",
)
def test_real_double_pendulum_recordings(tmp_path):
    """Train on one real recording, validate on another: an imperfect but sensible fit (see its README)."""
    from pinid.model.robot import RobotModel

    mapping = Path(__file__).resolve().parents[2] / "docs" / "examples" / "double_pendulum.toml"
    if not mapping.is_file():
        pytest.skip("docs/examples/double_pendulum.toml absent")
    model = RobotModel.from_urdf(DP / "double_pendulum.urdf")  # the rig's URDF as it is (undeclared "world")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = identify(Study(model, DP / "trajectory_02.csv", validate=DP / "trajectory_03.csv", mapping=mapping))
    sdp = res["sdp"]
    assert sdp.physically_consistent and sdp.status == "optimal"
    assert sdp.validation.per_joint["Joint2"]["rel_rms_percent"] < 40
    assert sdp.validation.all["rel_rms_percent"] < 60
    for r in res:
        assert r.train.all["rel_rms_percent"] < 50
    assert res["sdp"].export_urdf(tmp_path / "identified.urdf")


@pytest.mark.skipif(
    not (DP / "trajectory_02.csv").is_file(),
    reason=f"real recordings not found at {DP} (set PINID_SHARED_DATA to the folder holding double_pendulum/)",
)
@pytest.mark.slow
def test_cli_on_real_recordings(tmp_path):
    """The real-data path from the command line: the rig's own URDF and column names through the documented
    mapping spec, two training recordings, validation on a third; every output written and reloadable."""
    import json

    from pinid.model.robot import RobotModel

    mapping = Path(__file__).resolve().parents[2] / "docs" / "examples" / "double_pendulum.toml"
    out = tmp_path / "dp"
    proc = run_cli(
        "identify",
        "--urdf",
        str(DP / "double_pendulum.urdf"),
        "--data",
        str(DP / "trajectory_02.csv"),
        "--data",
        str(DP / "trajectory_00.csv"),
        "--validate",
        str(DP / "trajectory_03.csv"),
        "--mapping",
        str(mapping),
        "-o",
        str(out),
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    ident = json.loads((out / "identification.json").read_text())
    sdp = ident["methods"]["sdp"]
    assert sdp["physically_consistent"]
    assert sdp["validation"]["per_joint"]["Joint2"]["rel_rms_percent"] < 40, sdp["validation"]
    assert (out / "report.md").is_file() and (out / f"torque_{ident['best']}.png").is_file()
    again = RobotModel.from_urdf(out / "identified_sdp.urdf")
    assert again.joint_names == ["Joint1", "Joint2"]


@pytest.mark.parametrize("rate", [100, 5000])
@pytest.mark.slow
def test_default_preprocessing_on_a_6dof_arm_at_100_hz_and_5_khz(rate):
    """Recordings of q and tau only (no dq, ddq), no tuning flag: the identified model predicts the
    validation torques as well as the true parameters do on the same preprocessed data."""
    from pinid.data.preprocess import prepare
    from pinid.simulation.twin import simulate
    from pinid.excitation.trajectory import FourierTrajectory

    model = load("ur5")
    fc, fv = np.full(6, 0.5), np.full(6, 0.3)

    def trajectory(seed):
        rng = np.random.default_rng(seed)
        k = np.arange(1, 5)
        return FourierTrajectory(
            model.joint_names,
            2 * np.pi * 0.2,
            [0, -1.2, 1.2, -1.5, 0.5, 0.3],
            rng.normal(size=(6, 4)) * 0.2 / k,
            rng.normal(size=(6, 4)) * 0.2 / k,
        )

    opts = dict(sample_rate=rate, control_rate=max(rate, 1000), coulomb=fc, viscous=fv)
    train, _ = simulate(model, trajectory(1), seconds=12 if rate < 1000 else 6, seed=1, **opts)
    valid, _ = simulate(model, trajectory(2), seconds=6 if rate < 1000 else 4, seed=2, **opts)
    assert train.dq is None and train.ddq is None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = identify(Study(model, train, validate=valid), methods=["ols", "sdp"])
        p = prepare(valid)
    truth = model.rnea(p.q, p.dq, p.ddq) + fc * np.sign(p.dq) + fv * p.dq
    floor = float(np.sqrt(np.mean((p.tau - truth) ** 2)))
    for method, r in res.results.items():  # the floor is of the preprocessed data: the filtered yardstick
        assert r.validation_filtered.all["rms"] <= 1.1 * floor, (method, r.validation_filtered.all["rms"], floor)
        assert r.validation_filtered.all["rel_rms_percent"] < 3.0
    assert res["sdp"].physically_consistent


def test_the_model_class_floor_is_the_noise_on_the_twin():
    """Issue 34 item 4 (issue 44: least squares of the recorded torque, a lower bound): the same terms fitted on
    the validation recording itself; on the twin (the model class is the truth's) its per-joint error is the
    torque noise, and every method validates at it, never below it pooled."""
    from pinid.identification.outputs import identification_text

    model = truth_model("exo_leg")
    noise = 0.05
    ident = identify(
        Study(
            model,
            twin(model, seconds=10, seed=0, noise=noise),
            validate=twin(model, seconds=10, seed=1, noise=noise),
            terms="fc,fv",
        ),
        methods="ols,sdp",
    )
    floor = ident.floor.per_joint
    for j in model.joint_names:
        assert floor[j]["rms"] == pytest.approx(noise, rel=0.05)
        for r in ident:
            assert r.validation.per_joint[j]["rms"] <= 1.02 * floor[j]["rms"]
    for r in ident:
        assert ident.floor.all["rms"] <= r.validation.all["rms"]
    assert ident.data["floor"]["rank"] == ident.data["floor"]["parameters"] and not ident.data["floor"]["undetermined"]
    again = Identification.from_dict(json.loads(json.dumps(ident.to_dict())))
    assert again.floor.per_joint["knee"]["rms"] == floor["knee"]["rms"]
    text = identification_text(ident)
    hip = f"hip {floor['hip']['rel_rms_percent']:.3g} ({ident.best} {ident[ident.best].validation.per_joint['hip']['rel_rms_percent']:.3g})"
    line = " ".join(text.split())
    assert "model-class floor, valid. RMS raw % (the same terms fitted by least squares on the validation" in line
    assert hip in line
    assert identify(Study(model, twin(model, seconds=5, seed=0)), methods="ols").floor is None


def test_identify_on_two_workers_gives_the_same_numbers(leg_twins):
    """identify(workers=2): the methods fitted on two processes (the shared RLS run once, rls-pso after
    it), the same numbers as one after the other; a bad count is one SpecError line."""
    from pinid import Study, identify

    truth, train, val = leg_twins
    study = Study(truth, [train], validate=[val])
    methods = ["ols", "sdp", "rls", "rls-pso", "pso"]
    options = {m: {"seed": 3} for m in ("rls-pso", "pso")}
    one = identify(study, methods, options=options, workers=1)
    two = identify(study, methods, options=options, workers=2)
    for m in methods:
        np.testing.assert_array_equal(two[m].base, one[m].base)
        assert two[m].validation == one[m].validation
    with pytest.raises(SpecError, match="workers: got 0"):
        identify(study, methods, workers=0)


def test_duplicate_training_data_refused(tmp_path, recording):
    """Case 14: --data X --data X is an error (the std would shrink by √2 without a word)."""
    out = tmp_path / "run"
    proc = run_cli("identify", "--urdf", "exo_leg", "--data", str(recording), "--data", str(recording), "-o", str(out))
    assert_clean_error(proc, "given twice as training data")
    assert not out.exists()
    with pytest.raises(DataError, match="given twice"):  # the same through another spelling of the path
        identify(Study(load("exo_leg"), [recording, recording.parent / "." / recording.name]))


def test_validation_equal_to_training_warns(recording):
    """Case 14: --validate equal to a --data file: a clear warning (its error is a training error)."""
    from pinid.errors import DataWarning
    from pinid.identification.run import check_distinct

    with pytest.warns(DataWarning, match="also a training recording"):
        check_distinct([recording], [str(recording)])
    with pytest.warns(DataWarning, match="also a training recording"):
        check_distinct([recording], {"validation": [recording]})


def test_tampered_identification_json(tmp_path, model_json):
    """Identification.load on a tampered file: a SpecError naming the file, never a bare KeyError/TypeError."""
    from pinid import Identification

    path = tmp_path / "identification.json"
    for methods in (
        {"ols": {"method": "ols"}},
        {"ols": {"method": "ols", "physically_consistent": True}},
        {"ols": {"physically_consistent": True, "base_parameters": {"a": "abc"}}},
        [1],
        "x",
        {},
    ):
        path.write_text(json.dumps({"robot": model_json["robot"], "methods": methods}))
        with pytest.raises(SpecError, match="identification.json"):
            Identification.load(path)
    with pytest.raises(SpecError, match="not a valid identification"):
        Identification.from_dict({"robot": model_json["robot"], "methods": {"ols": 3}})
