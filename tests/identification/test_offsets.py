"""Torque offsets per recording (pinid.identification.offsets) against ground truth on noise-free states."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pinid import Study, base_parameters, regressor, standard_parameters
from pinid.data.dataset import Dataset
from pinid.data.formats import write_recording
from pinid.errors import SpecError
from pinid.estimators import make_estimator
from pinid.identification.offsets import calibrate_offsets, identify_recording_offsets
from pinid.identification.run import identify
from pinid.report.markdown import report_markdown
from conftest import assert_clean_error, load, run_cli

TERMS = "fc,fv"


def recording(model, theta, offsets, seed, n=200):
    """A noise-free recording: rigid body + friction of ``theta`` plus constant ``offsets`` [N·m] per joint."""
    q, dq, ddq = model.random_states(n, np.random.default_rng(seed))
    tau = (regressor(model, q, dq, ddq, TERMS) @ theta).reshape(n, model.nv) + offsets
    return Dataset(t=np.arange(n) * 0.01, q=q, dq=dq, ddq=ddq, tau=tau, joints=list(model.joint_names))


def test_two_recordings_offsets_and_shared_parameters_recovered_then_third_calibrated():
    model = load("exo_leg")
    rng = np.random.default_rng(3)
    theta = standard_parameters(model, TERMS)
    theta[10 * model.nv :] = rng.uniform(0.2, 1.5, theta.size - 10 * model.nv)  # friction the URDF lacks
    o1, o2, o3 = (rng.uniform(-2, 2, model.nv) for _ in range(3))
    fit = identify_recording_offsets(model, [recording(model, theta, o1, 1), recording(model, theta, o2, 2)], TERMS)
    truth = base_parameters(model, TERMS).P @ theta
    assert np.max(np.abs(fit.values - truth)) <= 1e-6 * np.max(np.abs(truth))
    assert np.allclose(fit.offsets, [o1, o2], rtol=1e-6, atol=1e-9)
    # a third day: only its offsets, from its first 10 %
    assert np.allclose(calibrate_offsets(fit, recording(model, theta, o3, 4), 0.1), o3, rtol=1e-6, atol=1e-9)


def test_shared_offset_term_refused():
    with pytest.raises(SpecError, match="collinear"):
        identify_recording_offsets(load("exo_leg"), [], "fc,fv,offset")


# ---------------------------------------------------------------- through the Study: identify, the CLI, the manifest
def twin_days(model, n=300):
    """The truth (standard θ with friction), three days' offsets and their noise-free recordings (named)."""
    rng = np.random.default_rng(3)
    theta = standard_parameters(model, TERMS)
    theta[10 * model.nv :] = rng.uniform(0.2, 1.5, theta.size - 10 * model.nv)
    offsets = [rng.uniform(-2, 2, model.nv) for _ in range(3)]
    days = []
    for k, o in enumerate(offsets):
        ds = recording(model, theta, o, k + 1, n)
        days.append(Dataset(t=ds.t, q=ds.q, dq=ds.dq, ddq=ds.ddq, tau=ds.tau, joints=ds.joints, source=f"day{k + 1}"))
    return theta, offsets, days


def offsets_of(items, joints):
    return np.array([[item["offsets"][j] for j in joints] for item in items])


def assert_recovered(ident, model, theta, offsets):
    truth = base_parameters(model, TERMS).P @ theta
    for m, r in ident.results.items():
        assert np.max(np.abs(r.base - truth)) <= 1e-6 * np.max(np.abs(truth)), m
        got = r.info["offsets"]
        assert np.allclose(offsets_of(got["training"], model.joint_names), offsets[:2], rtol=1e-6, atol=1e-7), m
        assert np.allclose(offsets_of(got["validation"], model.joint_names), offsets[2:], rtol=1e-6, atol=1e-7), m
        assert r.validation.all["rel_rms_percent"] < 1e-5, m  # the third day's last 90 % with its offsets


def test_identify_ols_and_sdp_recover_each_days_offsets_and_calibrate_a_third_day():
    model = load("exo_leg")
    theta, offsets, days = twin_days(model)
    study = Study(
        model, days[:2], validate=days[2:], terms=TERMS, rest_velocity=0, offsets="per-recording", calibrate_offsets=0.1
    )
    ident = identify(study, "ols,sdp")
    assert_recovered(ident, model, theta, offsets)
    assert ident.data["offsets"] == {"per_recording": ["day1", "day2"], "calibrate_fraction": 0.1}
    assert ident["sdp"].physically_consistent
    assert "### Torque offsets per recording" in report_markdown(ident)
    # the shared offset term cannot follow the days: the same data fitted with it are far off
    shared = identify(Study(model, days[:2], validate=days[2:], terms=TERMS + ",offset", rest_velocity=0), "ols")
    assert shared["ols"].validation.all["rel_rms_percent"] > 1.0


def test_cli_and_manifest_give_the_same_offsets(tmp_path):
    model = load("exo_leg")
    theta, offsets, days = twin_days(model)
    files = [write_recording(tmp_path / f"day{k + 1}.npz", ds) for k, ds in enumerate(days)]
    common = ["--urdf", "exo_leg", "--terms", TERMS, "--rest-velocity", "0", "--methods", "ols,sdp", "--no-report"]
    proc = run_cli(
        "identify", "--data", files[0], "--data", files[1], "--validate", files[2], "--offsets", "per-recording",
        "--calibrate-offsets", "0.1", "-o", tmp_path / "cli", *common,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "torque offsets per recording" in proc.stdout
    manifest = tmp_path / "study.toml"
    manifest.write_text(
        'offsets = "per-recording"\ncalibrate_offsets = 0.1\n'
        + "".join(
            f'[[recording]]\nfile = "{f.name}"\nrole = "{r}"\n' for f, r in zip(files, ("train", "train", "validate"))
        )
    )
    proc = run_cli("identify", "--manifest", manifest, "-o", tmp_path / "manifest", *common)
    assert proc.returncode == 0, proc.stderr
    for out in ("cli", "manifest"):
        d = json.loads((tmp_path / out / "identification.json").read_text())
        assert d["data"]["offsets"]["calibrate_fraction"] == 0.1
        for m in ("ols", "sdp"):
            got = d["methods"][m]["info"]["offsets"]
            assert np.allclose(offsets_of(got["training"], model.joint_names), offsets[:2], rtol=1e-6, atol=1e-7)
            assert np.allclose(offsets_of(got["validation"], model.joint_names), offsets[2:], rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize(
    "fields, message",
    [
        (dict(offsets="per-recording", calibrate_offsets=0.6), "0 < f ≤ 0.5"),
        (dict(offsets="per-recording", calibrate_offsets=0.0), "0 < f ≤ 0.5"),
        (dict(calibrate_offsets=0.1), "expected offsets per-recording"),
        (dict(offsets="per-day"), "expected per-recording"),
        (dict(offsets="per-recording", terms="fc,fv,offset"), "collinear with the per-recording ones"),
        (dict(offsets="per-recording", one=True), "that is the model of the 'offset' term"),
        (dict(offsets="per-recording", calibrate_offsets=0.1, validate=None), "no validation recording"),
    ],
)
def test_bad_offset_options_one_line(fields, message):
    model = load("exo_leg")
    _, _, days = twin_days(model, 60)
    fields = {"terms": TERMS, "rest_velocity": 0, "validate": days[2:], **fields}
    data = days[:1] if fields.pop("one", False) else days[:2]
    with pytest.raises(SpecError, match=message) as info:
        identify(Study(model, data, **fields), "ols")
    assert "\n" not in str(info.value)


def test_cli_refuses_offsets_with_the_offset_term(tmp_path):
    model = load("exo_leg")
    _, _, days = twin_days(model, 60)
    files = [write_recording(tmp_path / f"day{k + 1}.npz", ds) for k, ds in enumerate(days)]
    proc = run_cli(
        "identify", "--urdf", "exo_leg", "--data", files[0], "--data", files[1], "--terms", "fc,fv,offset",
        "--offsets", "per-recording", "-o", tmp_path / "out",
    )  # fmt: skip
    assert_clean_error(proc, "collinear")
    assert not (tmp_path / "out" / "identification.json").exists()


def test_simulating_estimators_and_compare_refuse_offsets_per_recording():
    from pinid.identification.compare import compare

    model = load("exo_leg")
    _, _, days = twin_days(model, 60)
    study = Study(model, days[:2], terms=TERMS, rest_velocity=0, offsets="per-recording")
    with pytest.raises(SpecError, match="iv, didim with offsets per recording: not supported"):
        identify(study, "ols,iv,didim")
    with pytest.raises(SpecError, match="not supported by compare; use identify"):
        compare(study, "ols")


def test_cli_refuses_a_fraction_above_one_half(tmp_path):
    model = load("exo_leg")
    _, _, days = twin_days(model, 60)
    files = [write_recording(tmp_path / f"day{k + 1}.npz", ds) for k, ds in enumerate(days)]
    proc = run_cli(
        "identify", "--urdf", "exo_leg", "--data", files[0], "--validate", files[2], "--terms", TERMS,
        "--offsets", "per-recording", "--calibrate-offsets", "0.6", "-o", tmp_path / "out",
    )  # fmt: skip
    assert_clean_error(proc, "calibrate offsets 0.6", "0 < f ≤ 0.5")
    assert not (tmp_path / "out").exists()


def test_profiled_offsets_give_the_standard_deviations_of_the_explicit_offset_columns():
    """σ ("white") of the base parameters with the offsets profiled out equals that of OLS on the regressor with
    the offset columns written out (Frisch–Waugh–Lovell; the degrees of freedom count the offset columns)."""
    from pinid.identification.run import setup
    from pinid.problem.statistics import base_statistics

    model = load("exo_leg")
    _, _, days = twin_days(model, 80)
    rng = np.random.default_rng(7)
    noisy = [Dataset(t=d.t, q=d.q, dq=d.dq, ddq=d.ddq, tau=d.tau + rng.normal(0, 0.05, d.tau.shape), joints=d.joints, source=d.source) for d in days[:2]]  # fmt: skip
    s = setup(Study(model, noisy, terms=TERMS, rest_velocity=0, offsets="per-recording"))
    x = make_estimator("ols").fit(s.problem).base_
    std = base_statistics(s.problem, x, kind="white")[0]
    nv, blocks = model.nv, []
    for r, ds in enumerate(noisy):  # the explicit regressor [W | O] and its OLS covariance
        O = np.zeros((ds.n * nv, 2 * nv))
        O[:, r * nv : (r + 1) * nv] = np.tile(np.eye(nv), (ds.n, 1))
        blocks.append(np.hstack([regressor(model, ds.q, ds.dq, ds.ddq, TERMS)[:, s.base.independent], O]))
    X, y = np.vstack(blocks), np.concatenate([ds.tau.reshape(-1) for ds in noisy])
    b, *_ = np.linalg.lstsq(X, y, rcond=None)
    e = y - X @ b
    cov = e @ e / (len(y) - X.shape[1]) * np.linalg.inv(X.T @ X)
    assert np.allclose(b[: s.base.count], x, rtol=1e-9, atol=1e-12)
    assert np.allclose(std, np.sqrt(np.diag(cov))[: s.base.count], rtol=1e-6)
