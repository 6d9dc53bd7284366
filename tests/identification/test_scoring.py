"""The yardstick of torque errors (issue 28), errors per unit, per-parameter uncertainty and its warning
(issues 24, 28), and errors against a twin's truth (`pinid identify --truth`)."""

from __future__ import annotations

import itertools
import json
import warnings

import numpy as np
import pytest

from pinid.data.dataset import Dataset
from pinid.identification.study import Study
from pinid.identification.metrics import torque_metrics
from pinid.problem.problem import recorded_torque
from pinid.problem.recordings import prepare_dataset
from pinid.identification.run import identify
from pinid.identification.uncertainty import COND_WARN, STD_WARN_PERCENT
from conftest import assert_clean_error, run_cli

from test_identification import fourier_motion, truth_model


def recording(model, seconds, rate, seed, noise=0.0, frequency=0.2):
    """q and τ only (so the default preprocessing filters and differentiates), τ exact plus white noise."""
    t, q, dq, ddq = fourier_motion(model, seconds, rate, seed, frequency=frequency)
    tau = model.rnea(q, dq, ddq) + model.coulomb * np.sign(dq) + model.viscous * dq
    added = np.random.default_rng(100 + seed).normal(size=tau.shape) * noise
    return Dataset(t, q, model.joint_names, tau=tau + added, source=f"rec{seed}"), added


def fit(model, train, valid, cutoff=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pre = None if cutoff is None else {"cutoff": cutoff}
        return identify(Study(model, train, validate=valid, preprocess=pre), methods=["ols"])["ols"]


def test_noise_free_twin_raw_error_is_the_filters_effect_only():
    model = truth_model("exo_leg")
    (train, _), (valid, _) = recording(model, 30, 500, 1), recording(model, 15, 500, 2)
    r = fit(model, train, valid)
    assert r.validation.all["rel_rms_percent"] < 0.2, r.validation.all
    assert r.train.all["rel_rms_percent"] < 0.2, r.train.all


def test_raw_error_is_the_noise_floor_and_does_not_drop_with_the_cutoff():
    """The point of the yardstick: a lower cut-off removes noise from the low-passed reference, so the
    filtered error drops; against the torque as recorded it cannot go below the noise (nor does it drop).
    Without Coulomb friction: its steps, smoothed by a low cut-off, would raise both errors."""
    model = truth_model("exo_leg", fc=0.0)
    train, _ = recording(model, 30, 500, 1, noise=0.3)
    valid, added = recording(model, 15, 500, 2, noise=0.3)
    floor = float(np.sqrt(np.mean(added**2)))
    at10, at2 = fit(model, train, valid), fit(model, train, valid, cutoff=2.0)
    assert 0.97 * floor <= at10.validation.all["rms"] <= 1.05 * floor, (at10.validation.all["rms"], floor)
    assert at2.validation.all["rms"] >= 0.99 * at10.validation.all["rms"]
    assert at2.validation_filtered.all["rms"] < 0.7 * at10.validation_filtered.all["rms"]
    assert at10.validation_filtered.all["rms"] < 0.5 * floor  # the moving yardstick reads below the noise


def test_recorded_torque_exact_at_kept_samples_and_interpolated_after_resampling():
    model = truth_model("exo_leg")
    ds, _ = recording(model, 6, 500, 3, noise=0.2)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the white noise above the cut-off, which the check reports
        prepared = prepare_dataset(ds, {})  # trimmed: the kept samples are recorded ones
        resampled = prepare_dataset(ds, {"rate": 300.0, "cutoff": 10.0})
    k = np.searchsorted(ds.t, prepared.t)
    np.testing.assert_array_equal(recorded_torque(prepared), ds.tau[k])
    assert not np.allclose(prepared.tau, ds.tau[k])  # the low-passed copy differs
    expect = np.column_stack([np.interp(resampled.t, ds.t, ds.tau[:, j]) for j in range(2)])
    np.testing.assert_allclose(recorded_torque(resampled), expect, rtol=0, atol=1e-12)
    assert recorded_torque(ds) is ds.tau  # a recording not prepared is its own record


def test_errors_are_pooled_per_unit_never_n_with_n_m():
    rng = np.random.default_rng(0)
    meas, pred = rng.normal(size=(50, 3)), rng.normal(size=(50, 3))
    m = torque_metrics(meas, pred, ["a", "b", "slide"], units=["N·m", "N·m", "N"])
    assert np.isnan(m.all["rms"]) and set(m.per_unit) == {"N·m", "N"}
    assert m.per_unit["N"]["rms"] == pytest.approx(m.per_joint["slide"]["rms"])
    assert m.per_unit["N·m"]["rms"] == pytest.approx(np.sqrt(np.mean((meas[:, :2] - pred[:, :2]) ** 2)))
    assert [row[0] for row in m.table()][-2:] == ["all N·m", "all N"]
    same = torque_metrics(meas, pred, ["a", "b", "c"])
    assert same.pools() == {"all": same.all} and np.isfinite(same.all["rms"])
    assert json.loads(json.dumps(m.to_dict()))["all"]["rms"] is None


@pytest.fixture(scope="module")
def twin_run(tmp_path_factory):
    """A short exo_leg twin run on disk with its truth, and a plain-reduction drives file."""
    d = tmp_path_factory.mktemp("twin")
    proc = run_cli(
        *("simulate", "--urdf", "exo_leg", "--excitation", "exo_leg", "--seconds", "20", "--seed", "1"),
        *("-o", str(d / "run.csv")),
    )
    assert proc.returncode == 0, proc.stderr
    (d / "plain.toml").write_text(
        '[transmission]\njoints = ["hip", "knee"]\nmotors = ["m_hip", "m_knee"]\nmatrix = [[30, 0], [0, 25]]\n'
    )
    return d


def test_truth_errors_and_no_warning_on_a_well_excited_twin(twin_run):
    d = twin_run
    proc = run_cli(
        "identify",
        "--urdf",
        "exo_leg",
        "--data",
        str(d / "run.csv"),
        "--truth",
        str(d / "run.truth.json"),
        "--methods",
        "ols,sdp",
        "--no-report",
        "-o",
        str(d / "ok"),
    )
    assert proc.returncode == 0, proc.stderr
    assert "warning" not in proc.stdout and "against the truth" in proc.stdout and "error %" in proc.stdout
    out = json.loads((d / "ok" / "identification.json").read_text())
    truth = json.loads((d / "run.truth.json").read_text())["base"]
    for m in ("ols", "sdp"):
        r = out["methods"][m]
        assert r["warning"] is None and r["truth_error"]["truth"] == pytest.approx(
            dict(zip(truth["names"], truth["values"]))
        )
        assert max(r["truth_error"]["error_percent"].values()) < 5, r["truth_error"]["error_percent"]
        assert max(r["std_percent"].values()) < STD_WARN_PERCENT and r["condition_number"] < COND_WARN
        assert r["validation_filtered"] is None and r["train_filtered"]["all"]["rms"] > 0


def test_warns_when_motor_terms_make_it_ill_conditioned(twin_run):
    """Issue 24's case: motor friction and rotor inertia on the exo_leg twin (no drives simulated: their
    truth is 0) take cond(W_b) from about 30 to about 1e4; one line names the parameter and what helps."""
    d = twin_run
    proc = run_cli(
        "identify",
        "--urdf",
        "exo_leg",
        "--drives",
        str(d / "plain.toml"),
        "--data",
        str(d / "run.csv"),
        "--terms",
        "fc,fv,motor_fc,motor_fv,motor_armature",
        "--truth",
        str(d / "run.truth.json"),
        "--methods",
        "ols",
        "--no-report",
        "-o",
        str(d / "bad"),
    )
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    k = next(i for i, x in enumerate(lines) if x.startswith("warning:"))
    assert max(map(len, lines)) <= 120
    line = " ".join([lines[k]] + [x.strip() for x in itertools.takewhile(lambda x: x.startswith("  "), lines[k + 1 :])])
    assert (
        "cond(W_b)" in line
        and "m_knee.armature" in line
        and "pinid excite --urdf exo_leg --terms fc,fv,motor_fc" in line
    )
    r = json.loads((d / "bad" / "identification.json").read_text())["methods"]["ols"]
    assert r["condition_number"] > COND_WARN and r["std_percent"]["m_knee.armature"] > STD_WARN_PERCENT
    assert r["warning"] == line and r["truth_error"]["truth"]["m_knee.armature"] == 0.0  # not simulated: truly 0


def test_bad_truth_is_a_one_line_error(twin_run, tmp_path):
    d = twin_run
    truth = json.loads((d / "run.truth.json").read_text())
    other = dict(truth, joints=["shoulder", "elbow"], robot="arm")
    (tmp_path / "other.json").write_text(json.dumps(other))
    missing = dict(truth, standard={"names": truth["standard"]["names"][:5], "values": truth["standard"]["values"][:5]})
    (tmp_path / "missing.json").write_text(json.dumps(missing))
    base = ("identify", "--urdf", "exo_leg", "--data", str(d / "run.csv"), "--methods", "ols", "--no-report")
    for name, fragments in (
        ("other.json", ("joints shoulder, elbow", "exo_leg")),
        ("missing.json", ("no true value",)),
        ("absent.json", ("cannot read the truth",)),
    ):
        proc = run_cli(*base, "--truth", str(tmp_path / name), "-o", str(tmp_path / name.replace(".", "_")))
        assert_clean_error(proc, name, *fragments)
        assert not (tmp_path / name.replace(".", "_")).exists()
