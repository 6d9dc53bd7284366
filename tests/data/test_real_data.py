"""Real recordings: the DFKI double pendulum (../shared/data/double_pendulum) through a mapping spec.

Messy on purpose: jittered time stamps (about 500 Hz), motor-current torques, two recordings where the
elbow turns more than a full turn.  Skipped when the shared data folder is absent.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from pinid import RobotModel, base_parameters, regressor, standard_parameters
from pinid.data.formats import read_recording
from pinid.errors import DataError
from pinid.data.preprocess import prepare

from conftest import shared_data

ROOT = Path(__file__).resolve().parents[2]
DATA = shared_data() / "double_pendulum"
SPEC = ROOT / "docs" / "examples" / "double_pendulum.toml"
GOOD = ["00", "01", "02", "03", "11", "12", "13"]
SPINNING = ["04", "05"]  # the elbow turns more than a full turn: beyond the URDF's ±π

pytestmark = pytest.mark.skipif(
    not (DATA / "trajectory_00.csv").is_file(),
    reason=f"real recordings not found at {DATA} (set PINID_SHARED_DATA to the folder holding double_pendulum/)",
)


@pytest.fixture(scope="module")
def model() -> RobotModel:
    # The rig's URDF welds base_link to a parent link "world" it never declares: the loader declares it.
    return RobotModel.from_urdf(DATA / "double_pendulum.urdf")


def read(nn: str, model, **kw):
    return read_recording(DATA / f"trajectory_{nn}.csv", mapping=SPEC, model=model, **kw)


@pytest.mark.parametrize("nn", GOOD)
def test_reads_and_prepares(nn, model):
    ds = read(nn, model)
    assert ds.joints == ["Joint1", "Joint2"] and ds.dq is not None and ds.tau is not None
    assert 450 < ds.sample_rate < 700
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = prepare(ds)
        from_q = prepare(ds, {"use_measured_velocity": False})
    pp = out.meta["preprocess"]
    assert pp["resampled"] and pp["jitter"] > 0.5  # steps from 1.2 to 3.8 ms
    assert np.ptp(np.diff(out.t)) < 1e-9
    assert pp["cutoff"] == 10.0 and pp["measured_velocity"]
    # velocities differentiated from the encoder agree with the rig's own to about 1 %
    rel = np.sqrt(np.mean((from_q.dq - out.dq) ** 2, axis=0)) / np.sqrt(np.mean(out.dq**2, axis=0))
    assert np.all(rel < 0.02), rel


@pytest.mark.parametrize("nn", SPINNING)
def test_spinning_elbow_is_caught_then_read_with_checks_relaxed(nn, model):
    with pytest.raises(DataError, match="positions of joint 'Joint2' reach .* more than a full turn"):
        read(nn, model)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = read(nn, model, degrees="warn", limits="warn")
    assert any("outside its URDF limits" in str(w.message) for w in caught)
    assert ds.n > 4000


def test_mapping_signs_match_the_urdf(model):
    """The URDF with the spec's signs explains the torques far better than with the elbow flipped."""
    bp = base_parameters(model)
    nominal = bp.from_standard(standard_parameters(model))

    def residual(flip: float):
        spec = {
            "time": "time",
            "joints": {
                "Joint1": {"q": "pos_meas1", "dq": "vel_meas1", "tau": "tau_meas1"},
                "Joint2": {
                    q: {"column": c, "sign": flip}
                    for q, c in (("q", "pos_meas2"), ("dq", "vel_meas2"), ("tau", "tau_meas2"))
                },
            },
        }
        ds = read_recording(DATA / "trajectory_00.csv", mapping=spec, model=model)
        out = prepare(ds)
        W = bp.columns(regressor(model, out.q, out.dq, out.ddq))
        x, *_ = np.linalg.lstsq(W, out.tau.reshape(-1), rcond=None)
        rms = np.sqrt(np.mean(out.tau**2, axis=0))
        fit = np.sqrt(np.mean((out.tau.reshape(-1) - W @ x).reshape(-1, 2) ** 2, axis=0)) / rms
        urdf = np.sqrt(np.mean((out.tau.reshape(-1) - W @ nominal).reshape(-1, 2) ** 2, axis=0)) / rms
        return fit, urdf

    fit, urdf = residual(1.0)
    _, urdf_flipped = residual(-1.0)
    assert np.all(urdf * 3 < urdf_flipped)
    # a plain least-squares fit explains joint 2 much better than joint 1 (shared/data README)
    assert fit[1] < 0.3 < fit[0]


KUKA = shared_data() / "kuka_med7"


@pytest.mark.skipif(not (KUKA / "mext.csv").is_file(), reason=f"KUKA LBR Med 7 recordings not found at {KUKA}")
def test_kuka_med7_offsets_per_recording_figures():
    """docs/identification.md, "KUKA LBR Med 7": the figures measured with offsets per recording (ols)."""
    from pinid.identification.offsets import identify_recording_offsets, relative_rms, score_calibrated
    from pinid.problem.problem import recorded_torque

    model = RobotModel.from_urdf(KUKA / "robot.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mext = read_recording(KUKA / "mext.csv", model=model)
        js = prepare(read_recording(KUKA / "js.csv", model=model))
        n70 = int(0.7 * mext.n)
        train, valid = prepare(mext.select(slice(0, n70))), prepare(mext.select(slice(n70, mext.n)))
        whole = prepare(mext)
    fit = identify_recording_offsets(model, [train], "fc,fv")
    pooled, per = relative_rms(recorded_torque(valid), fit.predict(valid, fit.offsets[0]))
    assert 3.6 < pooled < 3.75 and per[1] < 2.7 and per[3] < 2.1, (pooled, per)
    # KUKA's own model on the same samples: tau − kuka_tau_ext
    raw = np.genfromtxt(KUKA / "mext.csv", delimiter=",", names=True)
    k = np.searchsorted(raw["t"], valid.t - 1e-9)
    tau = np.column_stack([raw[f"tau_A{j}"] for j in range(1, 8)])[k]
    kuka = tau - np.column_stack([raw[f"kuka_tau_ext_A{j}"] for j in range(1, 8)])[k]
    assert np.array_equal(tau, recorded_torque(valid))
    assert 4.6 < relative_rms(tau, kuka)[0] < 4.7
    # another day, its offsets calibrated from its first 10 %, scored on the rest
    pooled, per = score_calibrated(identify_recording_offsets(model, [whole], "fc,fv"), js, 0.1)
    assert 11.9 < pooled < 12.05, (pooled, per)
    # why 6 % is out of reach against the torque as recorded: js's torque differs from its own 10 Hz
    # low-passed copy by 6.95 % (spikes up to 30 N·m from one sample to the next on A2)
    assert 6.9 < relative_rms(recorded_torque(js), js.tau)[0] < 7.0


@pytest.mark.skipif(not (KUKA / "mext.csv").is_file(), reason=f"KUKA LBR Med 7 recordings not found at {KUKA}")
def test_kuka_med7_mext_to_js_with_calibrated_offsets_through_identify():
    """docs/identification.md, "KUKA LBR Med 7": ``pinid identify --offsets per-recording --calibrate-offsets 0.1``
    trained on mext.csv, validated on js.csv's last 90 % with its offsets from its first 10 %: ols 11.9 %,
    sdp 10.0 % against the torque as recorded; the same model class fitted in-sample there (the floor: least squares
    of the recorded torque since issue 44) 8.86 %."""
    from pinid import Study
    from pinid.identification.run import identify

    model = RobotModel.from_urdf(KUKA / "robot.urdf")
    study = Study(
        model,
        KUKA / "mext.csv",
        validate=KUKA / "js.csv",
        terms="fc,fv",
        offsets="per-recording",
        calibrate_offsets=0.1,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ident = identify(study, "ols,sdp")
    assert 11.8 < ident["ols"].validation.all["rel_rms_percent"] < 12.0
    assert 9.9 < ident["sdp"].validation.all["rel_rms_percent"] < 10.1
    assert 8.8 < ident.floor.all["rel_rms_percent"] < 8.95  # least squares of the recorded torque (issue 44)
    js = ident["sdp"].info["offsets"]["validation"][0]
    assert js["source"].endswith("js.csv") and 2.3 < js["offsets"]["A2"] < 2.6
