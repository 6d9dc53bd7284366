"""Stribeck friction (fs, motor_fs): noise-free twins with the velocity given and fitted, settings, errors.

The identities (regressor × θ = RNEA + terms, fs and motor_fs on exo_leg, ur5, panda) are in
tests/model/test_drives.py (ALL_TERMS).  Ground truth here is written out independently of the registry:
τ = rnea + fc·sign(v) + fv·v + fs·sign(v)·exp(−(|v|/v_s)^δ), joint and motor side (through Gᵀ).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from pinid import TermSelection, base_parameters, standard_parameters
from pinid.identification.study import Study
from pinid.data.dataset import Dataset
from pinid.errors import SpecError
from pinid.identification.run import identify
from pinid.identification.result import Identification
from pinid.model.terms import Stribeck, term_parameter_names, stribeck_settings
from pinid.data.formats import write_recording

from conftest import assert_clean_error, run_cli
from test_drives import coupled
from test_identification import fourier_motion, truth_model

JOINT = TermSelection.from_names("fc,fv,fs")
MOTOR = TermSelection.from_names("fc,fv,motor_fc,motor_fs")
FS, VS, SHAPE = 0.6, 0.25, 2.0  # joint Stribeck: fs [N·m], v_s [rad/s], δ
MFS, MVS = 0.03, 6.0  # motor Stribeck [N·m at the motor], v_s [rad/s at the motor]


def stribeck(x, vs, shape):
    return np.sign(x) * np.exp(-((np.abs(x) / vs) ** shape))


def twin(m, terms: TermSelection, seconds=30.0, rate=200.0, seed=0, shape=SHAPE) -> tuple[Dataset, np.ndarray]:
    """Noise-free recording of ``m`` with joint fc, fv (the model's), motor fc (its drives') and the Stribeck
    terms of ``terms`` (FS, VS, ``shape``; MFS, MVS, SHAPE); and the true standard parameters."""
    t, q, dq, ddq = fourier_motion(m, seconds, rate, seed)
    tau = m.rnea(q, dq, ddq) + m.coulomb * np.sign(dq) + m.viscous * dq
    theta = standard_parameters(m, terms)
    names = m.inertial_names + term_parameter_names(m, terms)
    if "fs" in terms:
        tau += FS * stribeck(dq, VS, shape)
        theta[[i for i, n in enumerate(names) if n in [f"{j}.fs" for j in m.joint_names]]] = FS
    if "motor_fs" in terms:
        G = m.drives.matrix
        tau += (m.drives.nominal("fc") * np.sign(dq @ G.T) + MFS * stribeck(dq @ G.T, MVS, SHAPE)) @ G
        theta[[i for i, n in enumerate(names) if n in [f"{k}.fs" for k in m.motor_names]]] = MFS
    return Dataset(t, q, m.joint_names, dq=dq, ddq=ddq, tau=tau, source=f"twin{seed}"), theta


def exo_joint():
    return truth_model("exo_leg")


def exo_motor():
    # cable G = [[30, 0], [12, 25]]; coupled()'s drives without its Stribeck shapes
    return truth_model("exo_leg").with_drives(coupled("exo_leg").drives)


def _relative(a, b):
    return np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-3))


@pytest.mark.parametrize("make,terms,key,vs", [(exo_joint, JOINT, "fs", VS), (exo_motor, MOTOR, "motor_fs", MVS)])
def test_noise_free_twin_velocity_given_and_fitted(make, terms, key, vs):
    m = make()
    ds, theta = twin(m, terms)
    truth = base_parameters(m, terms).from_standard(theta)
    given = identify(
        Study(m, ds, terms=terms, stribeck_velocity={key: vs}, stribeck_shape=SHAPE), methods=["ols", "sdp"]
    )
    for method in ("ols", "sdp"):
        assert _relative(given[method].base, truth) <= 1e-6, method
    assert given.data["stribeck"][key] == {"velocity": vs, "shape": SHAPE, "fitted": False}
    assert m.stribeck == {}  # the caller's model is left as it was

    wrong = identify(Study(m, ds, terms=terms, stribeck_velocity={key: 3 * vs}), methods=["ols"])
    assert _relative(wrong["ols"].base, truth) > 1e-2  # the velocity matters

    fitted = identify(Study(m, ds, terms=terms, stribeck_velocity={key: "auto"}), methods=["ols"])
    found = fitted.data["stribeck"][key]
    assert found["fitted"] and abs(found["velocity"] / vs - 1) <= 0.01
    assert found["bounds"][0] < vs < found["bounds"][1]
    assert _relative(fitted["ols"].base, truth) <= 1e-3
    # the fitted velocity is saved with the robot: the reloaded model predicts with it
    again = Identification.from_dict(json.loads(json.dumps(fitted.to_dict())))
    assert again.model.robot.stribeck[key].velocity == found["velocity"]
    assert np.allclose(again.model.inverse_dynamics(ds.q[:50], ds.dq[:50], ds.ddq[:50]), ds.tau[:50], atol=1e-3)


def test_noisy_twin_velocity_found():
    m = exo_joint()
    ds, _ = twin(m, JOINT, seed=1)
    noisy = Dataset(
        ds.t,
        ds.q,
        ds.joints,
        dq=ds.dq,
        ddq=ds.ddq,
        source="noisy",
        tau=ds.tau + np.random.default_rng(7).normal(size=ds.tau.shape) * 0.1,
    )  # σ = fs / 6
    found = identify(Study(m, noisy, terms=JOINT, stribeck_velocity="auto"), methods=["ols"]).data["stribeck"]["fs"]
    assert abs(found["velocity"] / VS - 1) <= 0.02


def test_noise_free_twin_shape_fitted_with_the_velocity():
    m = exo_joint()
    ds, theta = twin(m, JOINT, shape=1.5)
    fitted = identify(Study(m, ds, terms=JOINT, stribeck_velocity="auto", stribeck_shape="auto"), methods=["ols"])
    found = fitted.data["stribeck"]["fs"]
    assert found["shape_fitted"] and abs(found["shape"] / 1.5 - 1) <= 0.01 and abs(found["velocity"] / VS - 1) <= 0.01
    truth = base_parameters(m, JOINT).from_standard(theta)
    assert _relative(fitted["ols"].base, truth) <= 1e-3


def test_settings_from_the_robot_python_and_defaults():
    m = exo_joint()
    assert stribeck_settings(m, JOINT) == ({"fs": Stribeck(0.1, 2.0)}, {})  # the documented default
    m = m.with_stribeck({"fs": Stribeck(0.2, 1.0)})
    assert stribeck_settings(m, JOINT, shape=3) == ({"fs": Stribeck(0.2, 3.0)}, {})
    assert stribeck_settings(m, JOINT, "fs=auto") == ({"fs": Stribeck(0.2, 1.0)}, {"fs": False})
    assert stribeck_settings(m, JOINT, "auto", "auto") == ({"fs": Stribeck(0.2, 1.0)}, {"fs": True})


@pytest.mark.parametrize(
    "velocity,shape,message",
    [
        (0, None, "velocity of fs 0, expected a number > 0"),
        (-0.1, None, "expected a number > 0"),
        (float("nan"), None, "expected a number > 0"),
        ("fast", None, "expected a number > 0 [rad/s] or 'auto'"),
        (None, 0, "shape of fs 0"),
        (None, "auto", "fitted only with the velocity 'auto'"),
        ("motor_fs=1", None, "expected Stribeck term(s) selected"),
    ],
)
def test_bad_settings(velocity, shape, message):
    with pytest.raises(SpecError) as err:
        stribeck_settings(exo_joint(), JOINT, velocity, shape)
    assert message in str(err.value)


def test_setting_without_a_stribeck_term():
    with pytest.raises(SpecError, match="no Stribeck term is selected"):
        identify(
            Study(exo_joint(), twin(exo_joint(), JOINT, seconds=5)[0], terms="fc,fv", stribeck_velocity=0.1),
            methods=["ols"],
        )
    with pytest.raises(SpecError, match="velocity"):
        Stribeck(float("nan"))


def identify_stribeck(folder, model, seconds: float, velocity: str):
    """``pinid identify --terms fc,fv,fs --stribeck-velocity=velocity`` (ols, no report) on a ``seconds``
    twin recording of ``model`` written to ``folder``; returns ``(process, output folder)``."""
    write_recording(folder / "train.csv", twin(model, JOINT, seconds=seconds)[0])
    out = folder / "out"
    args = ("--urdf", "exo_leg", "--data", str(folder / "train.csv"), "--terms", "fc,fv,fs", "--methods", "ols")
    return run_cli("identify", *args, "--no-report", f"--stribeck-velocity={velocity}", "-o", str(out)), out


@pytest.mark.parametrize(
    "value,fragment",
    [("0", "expected a number > 0"), ("nan", "expected a number > 0"), ("-1", "expected a number > 0")],
)
def test_cli_bad_velocity_exits_2_and_writes_nothing(tmp_path, value, fragment):
    proc, out = identify_stribeck(tmp_path, exo_joint(), 5, value)
    assert_clean_error(proc, fragment)
    assert not out.exists()


def test_cli_identify_fits_the_velocity(tmp_path):
    proc, out = identify_stribeck(tmp_path, truth_model("exo_leg"), 20, "auto")
    assert proc.returncode == 0, proc.stderr
    assert "Stribeck fs: velocity" in proc.stdout and "(fitted)" in proc.stdout
    d = json.loads((out / "identification.json").read_text())
    assert abs(d["data"]["stribeck"]["fs"]["velocity"] / VS - 1) <= 0.02  # written CSV, filtered derivatives
    assert d["robot"]["stribeck"]["fs"]["velocity"] == d["data"]["stribeck"]["fs"]["velocity"]


def test_plant_law_and_nominal_motor_value_from_the_drives_file():
    from pinid.model import terms as T
    from pinid.model.drives import Drives

    m = exo_motor().with_stribeck({"fs": Stribeck(VS, SHAPE), "motor_fs": Stribeck(MVS, 1.0)})
    m = m.with_drives(Drives(m.joint_names, m.drives.transmissions, {"m_knee": {"fs": 0.03}}, "test"))
    sel = TermSelection.from_names("fs,motor_fs")
    assert np.array_equal(T.nominal(m, sel), [0, 0, 0, 0.03])
    ds, _ = twin(m, MOTOR, seconds=2)
    vals = np.array([0.5, 0.4, 0.02, 0.03])
    G, smooth = m.drives.matrix, 0.01
    want = (
        vals[:2] * np.tanh(ds.dq / smooth) * np.exp(-((np.abs(ds.dq) / VS) ** SHAPE))
        + (vals[2:] * np.tanh(ds.dq @ G.T / smooth) * np.exp(-np.abs(ds.dq @ G.T) / MVS)) @ G
    )
    assert np.allclose(T.torque(m, sel, vals, ds.q, ds.dq, ds.ddq, smoothing=smooth), want, rtol=1e-12, atol=1e-12)


def test_compare_fits_the_velocity_too():
    from pinid.identification.compare import compare

    m = exo_joint()
    ds, _ = twin(m, JOINT, seconds=20)
    comp = compare(Study(m, ds, terms=JOINT, stribeck_velocity="auto"), methods="ols")
    assert abs(comp.data["stribeck"]["fs"]["velocity"] / VS - 1) <= 0.01
    assert comp.robot["stribeck"]["fs"]["velocity"] == comp.data["stribeck"]["fs"]["velocity"]
    given = identify(Study(m, ds, terms=JOINT), methods=["ols"])  # no setting: the default is used and reported
    assert given.data["stribeck"] == {"fs": {"velocity": 0.1, "shape": 2.0, "fitted": False}}


def test_shape_1e6_is_a_step_without_overflow_warnings():
    """Issue 33 (minor): a Stribeck shape 1e6 surfaced as a numpy overflow warning; the factor is bounded and
    tends to the step (1 below the Stribeck velocity, 0 above)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        f = Stribeck(velocity=0.1, shape=1e6).factor(np.array([0.0, 0.05, 0.0999, 0.1001, 2.0, -3.0]))
    assert np.array_equal(f, [1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
