"""Preprocessing: defaults from the sample rate, derivatives, alignment of torques, jitter, presets, errors."""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pinid.errors import DataWarning
from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError
from pinid.data.preprocess import PRESETS, Preprocessing, default_cutoff, prepare
from pinid.excitation.trajectory import FourierTrajectory
from pinid.model.robot import RobotModel

ROOT = Path(__file__).resolve().parents[2]

TRAJ = FourierTrajectory(
    ["hip", "knee"],
    2 * np.pi * 0.5,
    [0.3, -0.5],
    [[0.3, 0.1, 0.05], [0.2, -0.1, 0.04]],
    [[0.1, 0.0, 0.02], [0.05, 0.1, -0.03]],
)


def recording(
    fs: float, seconds: float = 12.0, *, noise: float = 1e-4, jitter: float = 0.0, seed: int = 0, velocity: bool = False
) -> Dataset:
    rng = np.random.default_rng(seed)
    t = np.arange(int(seconds * fs)) / fs
    if jitter:
        t = t + rng.uniform(-jitter, jitter, t.shape) / fs
    q, dq, ddq = TRAJ.evaluate(t)
    tau = 2.0 * ddq + 5.0 * np.sin(q) + 0.3 * dq
    return Dataset(
        t=t,
        q=q + rng.normal(0, noise, q.shape),
        joints=["hip", "knee"],
        dq=dq + rng.normal(0, 0.01, q.shape) if velocity else None,
        tau=tau + rng.normal(0, 0.02, q.shape),
    )


def rel_rms(a, b):
    return float(np.max(np.sqrt(np.mean((a - b) ** 2, axis=0)) / np.sqrt(np.mean(b**2, axis=0))))


@pytest.mark.parametrize("fs", [100.0, 1000.0, 5000.0])
@pytest.mark.parametrize("differentiation", ["savgol", "central"])
def test_defaults_work_from_100_hz_to_5_khz(fs, differentiation):
    out = prepare(recording(fs), {"differentiation": differentiation})
    q, dq, ddq = TRAJ.evaluate(out.t)
    pp = out.meta["preprocess"]
    assert pp["cutoff"] == default_cutoff(fs) == 10.0
    assert pp["output_rate"] == pytest.approx(min(fs, 1000.0))
    assert out.t[0] >= pp["trim"] - 1e-9
    # stated tolerances (docs/data.md): 1e-4 rad noise, 1 Hz motion
    assert np.max(np.abs(out.q - q)) < 3e-4
    assert rel_rms(out.dq, dq) < 2e-3
    assert rel_rms(out.ddq, ddq) < 2e-2


def test_noise_free_accuracy_and_edges():
    out = prepare(recording(1000.0, noise=0.0))
    q, dq, ddq = TRAJ.evaluate(out.t)
    assert np.max(np.abs(out.q - q)) < 1e-6
    assert np.max(np.abs(out.dq - dq)) < 1e-4  # also at the trimmed edges
    assert np.max(np.abs(out.ddq - ddq)) < 2e-3


def test_torque_and_positions_share_the_filter():
    ds = recording(500.0)
    ds.tau = ds.q.copy()
    out = prepare(ds)
    np.testing.assert_allclose(out.tau, out.q, atol=1e-12)


def test_low_rate_default_cutoff():
    assert default_cutoff(40.0) == 4.0
    out = prepare(recording(40.0, seconds=30.0, noise=0.0))
    assert out.meta["preprocess"]["cutoff"] == 4.0


def test_jittered_time_is_resampled():
    ds = recording(300.0, jitter=0.3)
    out = prepare(ds)
    pp = out.meta["preprocess"]
    assert pp["resampled"] and pp["jitter"] > 0.1
    assert np.ptp(np.diff(out.t)) < 1e-9
    q, dq, ddq = TRAJ.evaluate(out.t)
    assert rel_rms(out.dq, dq) < 3e-3 and rel_rms(out.ddq, ddq) < 3e-2
    assert not prepare(recording(300.0)).meta["preprocess"]["resampled"]


def test_measured_velocity_used_when_asked():
    ds = recording(1000.0, velocity=True)
    a = prepare(ds)
    b = prepare(ds, {"use_measured_velocity": False})
    assert a.meta["preprocess"]["measured_velocity"] and not b.meta["preprocess"]["measured_velocity"]
    _, dq, ddq = TRAJ.evaluate(a.t)
    assert rel_rms(a.dq, dq) < 2e-3 and rel_rms(a.ddq, ddq) < 3e-2
    assert not np.allclose(a.dq, b.dq)


def test_presets():
    assert set(PRESETS) == {"zha2019", "shi2024"}  # the source papers by author and year
    out = prepare(recording(500.0), {"preset": "zha2019"})
    pp = out.meta["preprocess"]
    assert (pp["cutoff"], pp["order"], pp["sample_rate"], pp["resampled"]) == (10.0, 4, pytest.approx(1000.0), True)
    out = prepare(recording(5000.0, seconds=4.0), {"preset": "zha2019"})  # downsampled with an anti-alias filter
    assert out.meta["preprocess"]["sample_rate"] == pytest.approx(1000.0)
    _, dq, ddq = TRAJ.evaluate(out.t)
    assert rel_rms(out.dq, dq) < 2e-3 and rel_rms(out.ddq, ddq) < 2e-2
    out = prepare(recording(500.0), {"preset": "shi2024", "cutoff": 3.0})  # explicit options win over the preset
    assert out.meta["preprocess"]["cutoff"] == 3.0 and out.meta["preprocess"]["preset"] == "shi2024"
    with pytest.raises(SpecError, match="preset 'seed002' is unknown"):
        prepare(recording(500.0), {"preset": "seed002"})


def test_decimate_and_trim_options():
    out = prepare(recording(1000.0), {"decimate": 4, "trim": 0.5})
    assert out.meta["preprocess"]["output_rate"] == pytest.approx(250.0)
    assert out.t[0] == pytest.approx(0.5) and np.diff(out.t)[0] == pytest.approx(0.004)
    assert prepare(recording(5000.0, seconds=3.0), {"decimate": 1}).meta["preprocess"]["output_rate"] == pytest.approx(
        5000.0
    )


def test_errors():
    with pytest.raises(DataError, match="sample rate 15 Hz is too low for a 10 Hz low-pass"):
        prepare(recording(15.0, seconds=60.0), {"cutoff": 10.0})
    with pytest.raises(DataError, match="no torque"):
        ds = recording(100.0)
        prepare(Dataset(t=ds.t, q=ds.q, joints=ds.joints))
    with pytest.raises(DataError, match="too few"):
        prepare(recording(100.0, seconds=0.5))
    with pytest.raises(DataError, match="500 samples .* fewer than the 1201-sample Savitzky–Golay window"):
        prepare(recording(1000.0, seconds=0.5), {"cutoff": 0.5, "trim": 0})
    with pytest.warns(DataWarning, match="0.5 Hz low-pass removes"):  # the motion is faster than 0.5 Hz: said
        assert (
            prepare(recording(1000.0, seconds=0.5), {"cutoff": 0.5, "trim": 0, "differentiation": "central"}).n == 500
        )
    with pytest.raises(DataError, match="decimating 1000 Hz by 60 leaves 16.67 Hz"):
        prepare(recording(1000.0, seconds=3.0), {"decimate": 60})
    with pytest.raises(SpecError, match="differentiation 'spline'"):
        prepare(recording(100.0), {"differentiation": "spline"})
    with pytest.raises(SpecError, match="filter order 0"):
        prepare(recording(100.0), {"order": 0})


def test_warns_when_motion_is_faster_than_the_cutoff():
    ds = recording(200.0, seconds=20.0)
    with pytest.warns(DataWarning, match="removes 26 % of the position variance of joint 'knee'"):
        prepare(ds, {"cutoff": 0.8})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        prepare(ds)


def test_old_preset_names_still_work_with_a_deprecation_warning():
    with pytest.warns(DeprecationWarning, match="'seed000' is deprecated, use 'zha2019'"):
        old = prepare(recording(500.0), {"preset": "seed000"})
    new = prepare(recording(500.0), {"preset": "zha2019"})
    np.testing.assert_array_equal(old.ddq, new.ddq)
    assert old.meta["preprocess"]["preset"] == "zha2019"


def test_millisecond_time_stamps_suggest_the_time_scale():
    """Issue 33: time stamps in ms read as 1 Hz; the error suggests the mapping spec's time scale."""
    t = np.arange(100) * 1.0  # 1 kHz in milliseconds
    ds = Dataset(t, np.zeros((100, 1)) + 0.1, ["hip"], tau=np.ones((100, 1)))
    with pytest.raises(
        DataError,
        match=r"time stamps in milliseconds\? \(1000 Hz then\) a mapping spec converts them: "
        r'time = \{ column = "t", scale = "ms" \}',
    ):
        prepare(ds)


# ---------------------------------------------------------------------------------------- one prepare (issue 32)
def test_prepare_of_a_floating_recording_filters_its_channels_with_the_same_options():
    """``prepare`` of a Dataset with floating channels gives its FloatingSamples, the base filtered with the
    options given (a 5 Hz and a 20 Hz cut-off differ), the joints exactly as ``prepare`` of the joints alone with
    ``use_measured_*`` false (one filter for every signal); the base state is the twin's exact one to the filter's
    error; a recording without its model is refused in one line."""
    from pinid import RobotModel
    from pinid.data.dataset import FloatingChannels
    from pinid.simulation.floating_twin import Noise, simulate_gait

    model = RobotModel.from_urdf("exo_lower_body", base="floating")
    run = simulate_gait(model, seconds=1.5, rate=200, noise=Noise(1e-4, 0.2, 1.0, 0.1), seed=1)
    rec = run.recording
    assert rec.floating.model is model
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for opts in ({}, {"cutoff": 20.0}, {"cutoff": 5.0, "order": 2, "differentiation": "central"}):
            s = prepare(rec, opts)
            joints = prepare(replace(rec, floating=None), {**opts, "use_measured_velocity": False})
            for k in ("q", "dq", "ddq", "tau"):
                np.testing.assert_array_equal(getattr(s.data, k), getattr(joints, k))
            assert s.wrenches and set(s.uncertain) | set(s.unsensed) == set(rec.floating.contacts)
        slow, fast = prepare(rec, {"cutoff": 5.0}), prepare(rec, {"cutoff": 20.0})
        assert not np.allclose(slow.base_a, fast.base_a[: len(slow.base_a)])  # the base is filtered with the options
        k = np.searchsorted(run.exact.data.t, fast.data.t)
        assert np.max(np.abs(fast.base_q[:, :3] - run.exact.base_q[k, :3])) < 1e-3  # [m]
        with pytest.raises(DataError, match="without its model") as e:
            prepare(replace(rec, floating=replace(rec.floating, model=None)))
        assert "\n" not in str(e.value)
        with pytest.raises(DataError, match="without its model"):
            prepare(replace(rec, floating=FloatingChannels(base_pose=rec.floating.base_pose)))


def test_prepare_takes_its_options_as_one_object_or_its_dict_form():
    """``prepare(ds, options)``: a Preprocessing and its dict form (the keys of a manifest's [preprocess] table)
    give the same arrays; the options are those a keyword gave (a 20 Hz cut-off differs from the default); an
    unknown key is one line naming the known ones (issue 32: prepare had 11 parameters)."""
    ds = recording(1000.0)
    a = prepare(ds, {"cutoff": 20.0, "order": 2})
    b = prepare(ds, Preprocessing(cutoff=20.0, order=2))
    np.testing.assert_array_equal(a.ddq, b.ddq)
    assert a.meta["preprocess"]["cutoff"] == 20.0 and a.meta["preprocess"]["order"] == 2
    assert prepare(ds).meta["preprocess"]["cutoff"] == 10.0  # the default, not the options'
    assert Preprocessing.from_dict({"cutoff": 20.0, "order": 2}).to_dict()["cutoff"] == 20.0
    with pytest.raises(SpecError, match="unknown option") as e:
        prepare(ds, {"cutof": 20.0})
    assert "\n" not in str(e.value) and "cutoff" in str(e.value)
    with pytest.raises(SpecError, match="expected a dict of preprocessing options"):
        prepare(ds, 20.0)


EXO = (ROOT / "urdf" / "exo_leg.urdf").read_text()


def _exo_with(old: str, new: str) -> str:
    assert old in EXO, old
    return EXO.replace(old, new, 1)


def test_wrapped_continuous_joint_is_unwrapped(tmp_path):
    from pinid.data.dataset import Dataset
    from pinid.problem.recordings import free_angles, load_datasets

    p = tmp_path / "continuous_hip.urdf"
    p.write_text(_exo_with('<joint name="hip" type="revolute">', '<joint name="hip" type="continuous">'))
    model = RobotModel.from_urdf(p)
    free = free_angles(model)
    assert free == ["hip"]
    j = 0
    t = np.arange(4000) / 1000.0
    q = np.zeros((t.size, model.nv))
    q[:, j] = 1.5 * t  # 6 rad: wraps once
    q[:, 1] = -0.9 + 0.2 * np.sin(t)
    tau = np.ones_like(q)
    wrapped = q.copy()
    wrapped[:, j] = (q[:, j] + np.pi) % (2 * np.pi) - np.pi
    ds = Dataset(t=t, q=wrapped, joints=model.joint_names, tau=tau, source="wrapped")
    out = load_datasets(ds, model)[0]
    assert out.meta["preprocess"]["unwrapped"] == [free[0]]
    assert np.allclose(out.dq[:, j], 1.5, atol=1e-3)  # without unwrapping: a spike of ~2π·1000 rad/s
    with pytest.warns(DataWarning):  # the plain preprocessing step unwraps only when told
        plain = prepare(ds)
    assert np.abs(plain.dq[:, j]).max() > 100


def test_no_lowpass_warning_on_a_still_joint():
    from pinid.data.dataset import Dataset

    rng = np.random.default_rng(0)
    t = np.arange(5000) / 1000.0
    q = np.c_[1e-4 * rng.standard_normal(t.size), 0.5 * np.sin(2 * t)]  # hip held: encoder noise only
    ds = Dataset(t=t, q=q, joints=["hip", "knee"], tau=np.ones_like(q), source="still")
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        prepare(ds)
    moving = Dataset(
        t=t,
        q=np.c_[0.05 * np.sin(2 * np.pi * 40 * t), q[:, 1]],
        joints=["hip", "knee"],
        tau=np.ones_like(q),
        source="fast",
    )
    with pytest.warns(DataWarning, match="removes .* of joint 'hip'"):
        prepare(moving)
