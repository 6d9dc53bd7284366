"""Sensor calibration of a floating recording (issue 46, parts 2 and 6): the walking twin with foot F/T sensors
reading known offsets and a motion capture whose vertical is 6° off gravity; the calibration gives them back
within σ, and a clean recording is left as it is (no term chosen, no warning)."""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation

from pinid import RobotModel
from pinid.identification.calibration import fit_calibration
from pinid.identification.run import identify
from pinid.identification.study import Study
from pinid.model.calibration import calibration_names, rotation_xy
from pinid.errors import SpecError
from pinid.simulation.floating_twin import Noise, simulate_gait

OFFSETS = {
    "l_sole": np.array([1.5, -2.0, 6.0, 0.30, -0.20, 0.10]),
    "r_sole": np.array([-1.0, 2.5, 4.0, -0.25, 0.15, -0.10]),
}
#: the motion capture's world turned by Rx(2°)·Ry(5.657°) from gravity's: a 6.0° tilt of its vertical
TILT = np.radians([2.0, np.sqrt(36.0 - 4.0)])


@pytest.fixture(scope="module")
def model():
    return RobotModel.from_urdf("exo_lower_body", base="floating")


def _sensor_recording(model, run, *, offsets=None, tilt=None, seed=0):
    """The twin's walk recorded by F/T sensors under the soles (their frame, moment about their origin, noise
    2 N / 0.2 N·m) that read ``offsets`` on top, and a motion capture whose world is gravity's turned by
    ``Rx·Ry(tilt)`` (the pose read in it: R_MG·pose)."""
    rng = np.random.default_rng(seed)
    ex, rec = run.exact, run.recording
    m, d = model.ff_model, model.ff_model.createData()
    wrenches = {}
    for w in ex.wrenches:  # world wrench about the origin → the sole's frame
        fid = model.frame_id(w.link)
        local = np.empty_like(w.values)
        for k in range(ex.n):
            pin.framesForwardKinematics(m, d, np.r_[ex.base_q[k], ex.data.q[k]])
            local[k] = d.oMf[fid].actInv(pin.Force(w.values[k])).vector
        local += np.r_[np.full(3, 2.0), np.full(3, 0.2)] * rng.standard_normal(local.shape)
        if offsets is not None:
            local += offsets[w.link]
        wrenches[w.link] = local
    pose = rec.floating.base_pose.copy()
    if tilt is not None:
        R_mg = rotation_xy(tilt).T
        pose[:, :3] = pose[:, :3] @ R_mg.T
        pose[:, 3:] = (Rotation.from_matrix(R_mg) * Rotation.from_quat(pose[:, 3:])).as_quat()
    floating = replace(rec.floating, base_pose=pose, wrenches=wrenches, plates={}, contacts={})
    return replace(rec, floating=floating)


@pytest.fixture(scope="module")
def walks(model):
    noise = Noise(position=2e-5, torque=0.3, force=2.0, moment=0.2)
    train = simulate_gait(model, seconds=8.0, rate=200.0, noise=noise, seed=3)
    val = simulate_gait(model, seconds=4.0, rate=200.0, noise=noise, seed=4, pattern={"period": 1.2, "speed": 0.9})
    return train, val


def _identify(model, train, val, **floating):
    study = Study(model, data=[train], validate=[val], floating={"rows": "all", **floating})
    return identify(study, ["ols", "sdp"], show_progress=False)


def test_offsets_and_tilt_come_back_within_sigma(model, walks):
    train, val = walks
    rec = _sensor_recording(model, train, offsets=OFFSETS, tilt=TILT, seed=5)
    rec_val = _sensor_recording(model, val, offsets=OFFSETS, tilt=TILT, seed=6)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ident = _identify(model, rec, rec_val)
    cal = ident.data["calibration"]
    assert cal["terms"] == ["offsets", "tilt"], cal["steps"]
    tilt = cal["tilt"]
    for name, truth in zip(("gravity.tilt_x", "gravity.tilt_y"), np.degrees(TILT)):
        err, sigma = tilt["values"][name] - truth, tilt["std"][name]
        assert 0 < sigma < 0.2 and abs(err) < 3 * sigma, (name, tilt["values"][name], sigma)
    off = cal["offsets"]
    for link, truth in OFFSETS.items():
        for axis, value in zip(("fx", "fy", "fz", "tx", "ty", "tz"), truth):
            name = f"{link}.offset_{axis}"
            err, sigma = off["values"][name] - value, off["std"][name]
            assert 0 < sigma and abs(err) < 4 * sigma, (name, off["values"][name], value, sigma)
    for method in ("ols", "sdp"):  # the calibrated model is the twin's: total mass and held-out error
        assert ident.results[method].base[ident.base["names"].index("base.mR")] == pytest.approx(21.8, rel=0.01)
    assert not [w for w in caught if "calibration" in str(w.message)]
    from pinid.report.markdown import report_markdown

    report = report_markdown(ident)
    assert "Sensor calibration" in report and "tilt_y 5.6" in report and "l_sole.offset_fz 6." in report


def test_without_calibration_the_same_recording_is_worse(model, walks):
    train, val = walks
    rec = _sensor_recording(model, train, offsets=OFFSETS, tilt=TILT, seed=5)
    rec_val = _sensor_recording(model, val, offsets=OFFSETS, tilt=TILT, seed=6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plain = _identify(model, rec, rec_val, calibration="none")
        calibrated = _identify(model, rec, rec_val, calibration="offsets,tilt")
    assert plain.data["calibration"]["terms"] == []
    base = [p.results["ols"].validation.per_joint["base"]["rel_rms_percent"] for p in (plain, calibrated)]
    assert base[1] < 0.8 * base[0], base


def test_a_clean_recording_is_left_as_it_is(model, walks):
    train, val = walks
    rec, rec_val = _sensor_recording(model, train, seed=5), _sensor_recording(model, val, seed=6)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        auto = _identify(model, rec, rec_val)
    assert auto.data["calibration"]["terms"] == []
    assert not [w for w in caught if "calibration" in str(w.message)]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        none = _identify(model, rec, rec_val, calibration="none")
    for method in ("ols", "sdp"):
        np.testing.assert_array_equal(auto.results[method].base, none.results[method].base)


def test_an_unphysical_calibration_is_refused(model, walks):
    """A fit whose total mass leaves 0.8–1.25 × the URDF's is refused by auto and warned when asked for."""
    from pinid.identification import calibration as C

    train, _ = walks
    rec = _sensor_recording(model, train, offsets=OFFSETS, tilt=TILT, seed=5)
    study = Study(model, data=[rec], floating={"rows": "base", "calibration": "none"})
    from pinid.identification.run import setup

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        samples = setup(study).floating.train
    band = C.MASS_BAND
    try:
        C.MASS_BAND = (1.5, 2.0)  # the twin's own mass made "unphysical": every candidate refused
        with pytest.warns(UserWarning, match="refused: total mass"):
            cal = fit_calibration(model, samples, "auto")
        assert cal.terms == [] and cal.refused
        with pytest.warns(UserWarning, match="not physical"):
            fit_calibration(model, samples, "tilt")
    finally:
        C.MASS_BAND = band


def test_calibration_names():
    assert calibration_names(None) == "auto" and calibration_names("none") == []
    assert calibration_names("tilt,offsets") == ["offsets", "tilt"]
    with pytest.raises(SpecError, match="calibration term 'gains'"):
        calibration_names("gains")


def test_placeholder_velocity_limits_keep_the_total_mass(tmp_path):
    """A URDF whose velocity limits are placeholders (iCub's 5e4 rad/s) still has the total mass among its base
    parameters: the random states they are computed from cap the speed (RobotModel.random_states)."""
    import re

    from pinid import TermSelection, base_parameters
    from pinid.identification.calibration import total_mass_vector
    from pinid.model.bundled import resolve_robot

    text = re.sub(r'velocity="[^"]*"', 'velocity="50000"', resolve_robot("exo_lower_body")[0].read_text())
    path = tmp_path / "exo_fast.urdf"
    path.write_text(text)
    model = RobotModel.from_urdf(path, base="floating")
    assert np.max(model.velocity_limit) == 50000
    base = base_parameters(model, TermSelection.from_names("none"), rows="base")
    assert "base.mR" in base.names and total_mass_vector(base) is not None


def test_an_unknown_calibration_term_is_one_line(tmp_path):
    from conftest import assert_clean_error, run_cli

    (tmp_path / "run.csv").write_text("t,q_l_knee\n0,0\n")
    proc = run_cli(
        "identify", "--urdf", "exo_lower_body", "--base", "floating", "--data", "run.csv", "--calibration", "gains",
        "-o", "out", cwd=tmp_path,
    )  # fmt: skip
    assert_clean_error(proc, "calibration term 'gains'", "offsets, tilt")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("tilt", [TILT, None])
def test_the_gram_blocks_give_the_rows_numbers(model, walks, monkeypatch, tilt):
    """auto's selection from precomputed Gram blocks (issue 45) chooses the same terms with the same scores, values
    and σ as the same fits on the rows themselves (GRAM = False), on the tilted recording and on an untilted one."""
    from pinid.identification import calibration as C
    from pinid.identification.run import setup

    train, _ = walks
    rec = _sensor_recording(model, train, offsets=OFFSETS, tilt=tilt, seed=5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        samples = setup(Study(model, data=[rec], floating={"rows": "base", "calibration": "none"})).floating.train
        fast = fit_calibration(model, samples, "auto")
        monkeypatch.setattr(C, "GRAM", False)
        slow = fit_calibration(model, samples, "auto")
    assert fast.terms == slow.terms and fast.refused == slow.refused
    assert [list(s) for s in fast.steps] == [list(s) for s in slow.steps]
    for a, b in zip(fast.steps, slow.steps):
        np.testing.assert_allclose(list(a.values()), list(b.values()), rtol=1e-7)
    np.testing.assert_allclose(list(fast.masses.values()), list(slow.masses.values()), rtol=1e-9)
    for name in slow.terms:
        np.testing.assert_allclose(fast.estimates[name].values, slow.estimates[name].values, rtol=1e-7, atol=1e-10)
        np.testing.assert_allclose(fast.estimates[name].std, slow.estimates[name].std, rtol=1e-6)
