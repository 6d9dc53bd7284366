"""Which standard parameters the data determine (pinid.model.base.identifiability) and where the marks go:
the JSON outputs, the identified URDF and MJCF (as comments; both files still load), the report's table."""

from __future__ import annotations

import json
import re

import numpy as np
import pinocchio as pin
import pytest

from pinid import RobotModel, TermSelection, standard_parameters
from pinid.identification.study import Study
from pinid.errors import ModelError, SpecError
from pinid.identification.identified import IdentifiedModel
from pinid.identification.result import IdentificationResult
from pinid.model.base import base_parameters, identifiability
from pinid.model.export import identified_urdf
from pinid.model.mjcf import identified_mjcf
from pinid.model.regressor import regressor

from conftest import load

FRICTION = TermSelection(coulomb=True, viscous=True)

PENDULUM = """<robot name="pendulum">
  <link name="world"/>
  <link name="arm">
    <inertial><origin xyz="0.1 0.02 -0.3"/><mass value="2"/>
      <inertia ixx="0.05" ixy="0.001" ixz="0.002" iyy="0.04" iyz="0.003" izz="0.02"/></inertial>
  </link>
  <joint name="swing" type="revolute"><parent link="world"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="50" velocity="5"/></joint>
</robot>
"""


def test_marks_of_small_maps_by_hand():
    """e_i in the row space: identified; orthogonal to it: not identified; else partly.  Units do not matter."""
    assert identifiability(np.array([[1.0, 0.5, 0.0]])) == ["partly", "partly", "not identified"]
    assert identifiability(np.array([[1.0, 0, 0], [0, 1.0, 1.0]])) == ["identified", "partly", "partly"]
    assert identifiability(np.array([[1.0, 2.0], [0.0, 1.0]])) == ["identified", "identified"]
    scaled = np.array([[1.0, 0, 0], [0, 1e6, 3e-6]])  # columns in wildly different units
    assert identifiability(scaled) == ["identified", "partly", "partly"]
    assert identifiability(np.zeros((0, 2))) == ["not identified"] * 2


def test_nominal_base_values_drop_cancellation_round_off():
    """A combination whose terms cancel (0.3 − 0.1·3 = −5.6e-17 in floating point) is shown as 0; a value that is
    small by itself is kept."""
    from pinid.model.base import BaseParameters

    bp = BaseParameters(["a", "b", "c"], np.array([0, 2]), np.array([[1.0, -0.1, 0.0], [0.0, 0.0, 1.0]]), ["aR", "c"])
    theta = np.array([0.3, 3.0, 1e-20])
    assert bp.from_standard(theta)[0] != 0.0
    assert bp.shown(theta).tolist() == [0.0, 1e-20]


def test_exo_leg_marks_match_the_planar_physics():
    """The 2-DOF planar leg (axes along y): only m·x, m·z and Iyy of each body can act about y.  The hip's mass
    and its z moment enter only with the knee's mass (hip.mzR = hip.mz − 0.42·knee.m, hip.IyyR = hip.Iyy +
    0.1764·knee.m); the out-of-plane parameters never move a torque."""
    model = load("exo_leg")
    bp = base_parameters(model, FRICTION)
    marks = bp.marks()
    identified = {"hip.mx", "knee.mx", "knee.mz", "knee.Iyy", "hip.fc", "hip.fv", "knee.fc", "knee.fv"}
    partly = {"hip.mz", "hip.Iyy", "knee.m"}
    assert {n for n, v in marks.items() if v == "identified"} == identified
    assert {n for n, v in marks.items() if v == "partly"} == partly
    assert {n for n, v in marks.items() if v == "not identified"} == set(bp.standard_names) - identified - partly
    assert marks["hip.m"] == "not identified" and marks["knee.Ixx"] == "not identified"
    # ground truth: a not-identified parameter moves no torque at any state; an identified one is a combination
    # of base parameters (y·P = e_i exactly); a partly one is not
    q, dq, ddq = model.random_states(50, np.random.default_rng(7))
    W = regressor(model, q, dq, ddq, FRICTION)
    for i, n in enumerate(bp.standard_names):
        e = np.eye(len(bp.standard_names))[i]
        y, *_ = np.linalg.lstsq(bp.P.T, e, rcond=None)
        in_row_space = np.abs(bp.P.T @ y - e).max() < 1e-9
        assert in_row_space == (marks[n] == "identified"), n
        assert (np.abs(W[:, i]).max() < 1e-9) == (marks[n] == "not identified"), n


def test_one_body_pendulum(tmp_path):
    """A pendulum about y under gravity along −z: m·x, m·z, Iyy and the friction are identified, nothing is a
    combination, the rest (the mass itself, m·y, the other inertia entries) is not identified."""
    (tmp_path / "pendulum.urdf").write_text(PENDULUM)
    model = RobotModel.from_urdf(tmp_path / "pendulum.urdf")
    marks = base_parameters(model, FRICTION).marks()
    assert {n for n, v in marks.items() if v == "identified"} == {
        "swing.mx",
        "swing.mz",
        "swing.Iyy",
        "swing.fc",
        "swing.fv",
    }
    assert "partly" not in marks.values()
    assert marks["swing.m"] == marks["swing.my"] == marks["swing.Ixy"] == "not identified"


def test_urdf_and_mjcf_carry_the_marks_and_load(tmp_path):
    """A comment beside each body's inertial and each joint says what the data determined; round-off of the
    completion (c_y = −6.57e-22 m) is written as 0; Pinocchio loads the URDF, MuJoCo the MJCF, with the values."""
    mujoco = pytest.importorskip("mujoco")
    model = load("exo_leg")
    theta = standard_parameters(model, FRICTION)
    theta[2] = -6.57e-22 * theta[0]  # hip.my: m·c_y of a c_y that is round-off
    marks = base_parameters(model, FRICTION).marks()
    text = identified_urdf(model, theta, FRICTION, tmp_path / "m.urdf", marks=marks)
    hip = re.search(r"<link name=\"thigh\">(.*?)</link>", text, re.S)
    notes = re.findall(r"<!-- pinid, from these data \(standard parameters[^>]*-->", text)
    assert len(notes) == 2, notes
    assert "identified: mx; partly (in combinations): mz, Iyy; not identified" in notes[0]
    assert " m, my, Ixx" in notes[0]
    assert text.count("<!-- pinid, from these data: identified: fc, fv -->") == 2
    assert "e-22" not in text and notes[0] in hip.group(1)  # the hip's body is the thigh link
    pm = pin.buildModelFromUrdf(str(tmp_path / "m.urdf"))
    hip_id = pm.getJointId("hip")
    assert pm.inertias[hip_id].lever[1] == 0.0
    np.testing.assert_allclose(pm.inertias[hip_id].mass, theta[0], rtol=1e-15)
    xml = identified_mjcf(model, theta, FRICTION, tmp_path / "m.xml", marks=marks)
    assert xml.count("<!-- pinid, from these data (standard parameters") == 2
    assert xml.count("<!-- pinid, joint 'knee' terms from these data: identified: fc, fv -->") == 1
    assert "e-22" not in xml and "e-17" not in xml
    mj = mujoco.MjModel.from_xml_path(str(tmp_path / "m.xml"))
    np.testing.assert_allclose([mj.body("thigh").mass[0], mj.body("shank").mass[0]], theta[[0, 10]], rtol=1e-12)
    assert "pinid, from these data" not in identified_urdf(model, theta, FRICTION)  # no marks given: no comment


def test_marks_in_the_json_outputs_round_trip(tmp_path):
    """identification.json's result and model_<method>.json keep the marks; a tampered list is refused."""
    from test_identification import identify, truth_model, twin

    truth = truth_model("exo_leg")
    ident = identify(Study(truth, twin(truth, seconds=3, rate=200, seed=1)), methods=["ols"])
    r = ident.results["ols"]
    assert r.marks["hip.m"] == "not identified" and r.marks["knee.Iyy"] == "identified"
    d = json.loads(json.dumps(r.to_dict()))
    assert d["standard_marks"] == r.marks
    assert IdentificationResult.from_dict(d).marks == r.marks
    back = IdentifiedModel.load(r.model.save(tmp_path / "model_ols.json"))
    assert back.marks == r.marks
    d["standard_marks"]["hip.m"] = "maybe"
    with pytest.raises(SpecError, match="standard_marks"):
        IdentificationResult.from_dict(d)
    del d["standard_marks"]  # a file of an older pinid: no marks, no comments
    assert IdentificationResult.from_dict(d).marks is None
    from pinid.report.markdown import report_markdown

    table = report_markdown(ident).split("## Link parameters")[1]
    assert "| from these data |" in table
    assert "identified: mx, mz, Iyy, fc, fv; partly (in combinations): m; not identified" in table  # the knee


def test_rows_are_the_floating_bases_choice():
    """``rows`` picks a floating base's measured rows (the base rows alone: the total mass among the base
    parameters); on a fixed base anything but "all" is a SpecError, as are an unknown row set and a subset of
    joints with a floating base."""
    from pinid.model.floating import random_floating_states
    from pinid.model.regressor import parameter_names

    floating = RobotModel.from_urdf("exo_lower_body", base="floating")
    none = TermSelection.from_names("none")
    bp = base_parameters(floating, none, rows="base")
    assert bp.standard_names == parameter_names(floating, none) and bp.names[0] == "base.mR"
    theta = standard_parameters(floating, none)
    W = regressor(floating, *floating.full_state(*random_floating_states(floating, 5, np.random.default_rng(1))), none)
    base_rows = W.reshape(5, 6 + floating.nv, -1)[:, :6].reshape(-1, len(theta))
    np.testing.assert_allclose(bp.columns(base_rows) @ bp.from_standard(theta), base_rows @ theta, atol=1e-9)
    with pytest.raises(SpecError, match=r"rows='base': the rows of a floating base; exo_leg has a fixed base"):
        base_parameters(load("exo_leg"), rows="base")
    with pytest.raises(SpecError, match="rows='feet', expected one of all, base, joints"):
        base_parameters(floating, rows="feet")
    with pytest.raises(SpecError, match="not available with a floating base"):
        base_parameters(floating, joints=floating.joint_names[:2])


def test_overflowing_regressor_is_a_model_error(monkeypatch):
    """base.py itself refuses columns that overflow (whatever made them), instead of an IndexError."""
    import pinid.model.base as base

    real = base.regressor

    def overflowing(*args, **kwargs):
        W = real(*args, **kwargs)
        W[:, -1] = np.inf  # what a ratio of 1e200 made of the motor columns
        return W

    monkeypatch.setattr(base, "regressor", overflowing)
    with pytest.raises(ModelError, match=r"exo_leg: the regressor columns of knee.fv overflow"):
        base.base_parameters(load("exo_leg"))


def test_base_parameters_few_samples_message(leg):
    with pytest.raises(SpecError, match="expected at least 12 samples"):
        base_parameters(leg, samples=5)
    assert base_parameters(leg, samples=12).count == base_parameters(leg).count  # the minimum still works
