"""Drive gains from currents with a known payload (issue 13): payload frames checked against a URDF with
the payload as a fixed link, gains recovered on the twin (noise-free ≤ 1e-6, 1 % noise ≤ 1 %), the CLI
and its one-line errors.  Ground truth: analytic Fourier motion and τ = rnea + friction (test_identification)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pinid import TermSelection, regressor, standard_parameters
from pinid.identification.study import Study
from pinid.data.dataset import Dataset
from pinid.data.formats import write_recording
from pinid.errors import DataError, SpecError
from pinid.identification.run import identify
from pinid.identification.gains import Payload, identify_gains
from pinid.model.robot import RobotModel

from conftest import assert_clean_error, load, run_cli
from test_identification import fourier_motion

TERMS = TermSelection(coulomb=True, viscous=True)
PAYLOAD = {"mass": 2.5, "com": [0.03, -0.02, -0.12], "inertia": [0.02, 0.03, 0.025, 0.002, -0.001, 0.003]}


def recording(m: RobotModel, gains, payload: Payload | None, seed: int, noise: float = 0.0) -> Dataset:
    """Currents τ/k of the robot (with the payload fixed to its link when given) on a random motion."""
    t, q, dq, ddq = fourier_motion(m, 20.0, 200.0, seed)
    theta = standard_parameters(m, TERMS)
    theta[10 * m.nv :] = np.tile([0.3, 0.2], m.nv)
    if payload is not None:
        j, phi = payload.body(m)
        theta[10 * j : 10 * j + 10] += phi
    tau = regressor(m, q, dq, ddq, TERMS) @ theta
    tau = tau.reshape(-1, m.nv)
    if noise:
        tau = tau + np.random.default_rng(100 + seed).normal(size=tau.shape) * noise * tau.std(axis=0)
    return Dataset(t, q, m.joint_names, dq=dq, ddq=ddq, tau=tau / gains, source=f"twin{seed}")


def test_payload_parameters_match_a_urdf_with_the_payload_as_a_fixed_link(tmp_path):
    exo = load("exo_leg")
    text = exo.urdf_text.replace(
        "</robot>",
        """
  <link name="box"><inertial><origin xyz="0.01 0.02 -0.05" rpy="0 0 0"/><mass value="2.5"/>
    <inertia ixx="0.02" iyy="0.03" izz="0.025" ixy="0.002" ixz="-0.001" iyz="0.003"/></inertial></link>
  <joint name="strap" type="fixed"><parent link="shank"/><child link="box"/><origin xyz="0.02 -0.04 -0.07" rpy="0 0 0"/></joint>
</robot>""",
    )
    path = tmp_path / "loaded.urdf"
    path.write_text(text)
    loaded = RobotModel.from_urdf(path)
    payload = Payload.from_dict({**PAYLOAD, "link": "shank"})  # strap origin + the box's inertial origin
    j, phi = payload.body(exo)
    assert j == exo.nv - 1
    q, dq, ddq = exo.random_states(20, np.random.default_rng(0))
    y = regressor(exo, q, dq, ddq, TermSelection(names=[]))[:, 10 * j : 10 * j + 10] @ phi
    np.testing.assert_allclose(loaded.rnea(q, dq, ddq) - exo.rnea(q, dq, ddq), y.reshape(-1, exo.nv), atol=1e-10)
    # the default link: the last joint's child (the shank)
    shank = Payload.from_dict(PAYLOAD)
    np.testing.assert_allclose(shank.body(exo)[1], phi, atol=1e-12)


@pytest.mark.parametrize("name", ["exo_leg", "ur5"])
def test_noise_free_gains_recovered(name):
    m = load(name)
    gains = np.random.default_rng(7).uniform(0.5, 5.0, m.nv)
    payload = Payload.from_dict(PAYLOAD)
    g = identify_gains(m, [recording(m, gains, None, 1)], [recording(m, gains, payload, 2)], payload, terms=TERMS)
    np.testing.assert_allclose(g.gains, gains, rtol=1e-6)


def test_one_percent_noise_gains_within_one_percent():
    m = load("exo_leg")
    gains = np.array([2.0, 3.5])
    payload = Payload.from_dict(PAYLOAD)
    g = identify_gains(
        m, [recording(m, gains, None, 1, 0.01)], [recording(m, gains, payload, 2, 0.01)], payload, terms=TERMS
    )
    assert np.all(np.abs(g.gains / gains - 1) < 0.01), g.gains / gains
    assert np.all(g.std < 0.01 * gains)


def test_without_the_payload_the_gains_are_refused():
    m = load("exo_leg")
    gains = np.array([2.0, 3.5])
    payload = Payload.from_dict(PAYLOAD)
    with pytest.raises(DataError, match="payload"):
        identify_gains(m, [recording(m, gains, None, 1)], [], payload, terms=TERMS)


def test_identify_turns_currents_into_torques_and_reports_gains():
    m = load("exo_leg")
    gains = np.array([2.0, 3.5])
    payload = Payload.from_dict(PAYLOAD)
    ident = identify(
        Study(
            m,
            recording(m, gains, None, 1),
            validate=recording(m, gains, None, 3),
            payload=payload,
            payload_data=recording(m, gains, payload, 2),
        ),
        methods="ols",
    )
    np.testing.assert_allclose(ident.data["drive_gains"]["gains"], gains, rtol=1e-6)
    assert ident["ols"].validation.all["rms"] < 1e-6


@pytest.mark.parametrize(
    "table, message",
    [
        ({"mass": -1}, "mass"),
        ({"mass": 1, "com": [0, 0]}, "com"),
        ({"mass": 1, "inertia": [-1, 0, 0, 0, 0, 0]}, "negative principal moment"),
        ({"mass": 1, "colour": "red"}, "unknown key"),
        ({"mass": 1, "link": "nowhere"}, "not in"),
    ],
)
def test_bad_payloads(table, message):
    with pytest.raises(SpecError, match=message):
        Payload.from_dict(table).body(load("exo_leg"))


def _toml(d: dict) -> str:
    return "\n".join(f"{k} = {json.dumps(v)}" for k, v in d.items()) + "\n"


def _write_recordings(folder, gains) -> None:
    """run.csv (currents without the payload) and loaded.csv (with it) of exo_leg into ``folder``."""
    m = load("exo_leg")
    write_recording(folder / "run.csv", recording(m, gains, None, 1))
    write_recording(folder / "loaded.csv", recording(m, gains, Payload.from_dict(PAYLOAD), 2))


def _identify(folder, *extra: str):
    """``pinid identify`` (ols) on run.csv with ``extra`` options, into folder/out."""
    data = str(folder / "run.csv")
    return run_cli(
        "identify", "--urdf", "exo_leg", "--data", data, "--methods", "ols", *extra, "-o", str(folder / "out")
    )


def test_cli_identifies_drive_gains(tmp_path):
    gains = np.array([2.0, 3.5])
    _write_recordings(tmp_path, gains)
    (tmp_path / "payload.toml").write_text(_toml(PAYLOAD))
    r = _identify(
        tmp_path,
        "--payload",
        str(tmp_path / "payload.toml"),
        "--payload-data",
        str(tmp_path / "loaded.csv"),
        "--no-report",
    )
    assert r.returncode == 0, r.stderr
    assert "drive gains" in r.stdout
    out = json.loads((tmp_path / "out" / "identification.json").read_text())
    np.testing.assert_allclose(out["data"]["drive_gains"]["gains"], gains, rtol=1e-6)


@pytest.mark.parametrize(
    "extra, fragment",
    [
        (["--payload-data", "{d}/loaded.csv"], "--payload FILE"),
        (["--payload", "{d}/bad.toml", "--payload-data", "{d}/loaded.csv"], "mass"),
    ],
)
def test_cli_drive_gain_errors(tmp_path, extra, fragment):
    _write_recordings(tmp_path, np.ones(2))
    (tmp_path / "bad.toml").write_text("mass = 0\n")
    r = _identify(tmp_path, *[e.format(d=tmp_path) for e in extra])
    assert_clean_error(r, fragment)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "toml, fragment",
    [
        ("mass = 1e300", "expected a mass from 0.001 to 10000 kg"),
        ("mass = true", "mass = True, expected 1 finite number"),
        ('mass = "2"', "expected 1 finite number"),
        ("mass = 2\ncom = [0, 0, true]", "com = [0, 0, True]"),
        ("mass = 2\ncom = [1e200, 0, 0]", "within ±10 m"),
        ("mass = 2\ninertia = [1, 0.1, 0.1, 0, 0, 0]", "larger than the sum of the other two"),
        ("mass = 2\ninertia = [-1, 0, 0, 0, 0, 0]", "negative principal moment"),
        ("mass = 0.001\ninertia = [1, 1, 1, 0, 0, 0]", "above mass × (10 m)²"),
    ],
)
def test_payload_values_checked(tmp_path, toml, fragment):
    """Item 6: payload numbers are numbers (not booleans), finite, in physical ranges; a physical inertia."""
    path = tmp_path / "p.toml"
    path.write_text(toml + "\n")
    with pytest.raises(SpecError) as err:
        Payload.load(path)
    assert fragment in str(err.value) and str(path) in str(err.value)
