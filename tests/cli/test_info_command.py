"""pinid info (pinid/cli/info.py): bad URDFs, drives and transmissions give one line and exit status 2."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_clean_error, load, run_cli

from pinid.errors import SpecError
from pinid.identification.identified import IdentifiedModel
from pinid.io import toml_loads
from pinid.model.base import base_parameters
from pinid.model.drives import Drives, Transmission
from pinid.model.regressor import parameter_names, standard_parameters
from pinid.model.robot import RobotModel
from pinid.model.terms import TermSelection

ROOT = Path(__file__).resolve().parents[2]
EXO = (ROOT / "urdf" / "exo_leg.urdf").read_text()


URDF_CASES = {
    "truncated": EXO[: len(EXO) // 2],
    "malformed": "<robot name='x'><link name='a'></robot>",
    "entity-expansion": (
        "<?xml version='1.0'?><!DOCTYPE lolz [<!ENTITY lol 'lol'>"
        "<!ENTITY lol2 '&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;&lol;'>"
        "<!ENTITY lol3 '&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;&lol2;'>]>"
        "<robot name='&lol3;'/>"
    ),
    "empty": "",
    "not-a-robot": "<html><body>hello</body></html>",
    "no-movable-joint": "<robot name='r'><link name='a'/></robot>",
    "nan-mass": EXO.replace('<mass value="4.0"', '<mass value="nan"', 1),
    "huge-mass": EXO.replace('<mass value="4.0"', '<mass value="1e300"', 1),
}


@pytest.mark.parametrize("case", sorted(URDF_CASES))
def test_bad_urdf_text(tmp_path, case):
    p = tmp_path / "robot.urdf"
    p.write_text(URDF_CASES[case])
    out = tmp_path / "out"
    assert_clean_error(run_cli("info", "--urdf", str(p), "--json", str(out / "info.json")), str(p))
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize(
    "payload",
    [b"\x7fELF\x02\x01\x01\x00" + os.urandom(256), "<robot name='é'/>".encode("utf-16")],
    ids=["binary", "utf-16"],
)
def test_bad_urdf_bytes(tmp_path, payload):
    p = tmp_path / "robot.urdf"
    p.write_bytes(payload)
    assert_clean_error(run_cli("info", "--urdf", str(p)), str(p))


def test_urdf_is_a_folder(tmp_path):
    assert_clean_error(run_cli("info", "--urdf", str(tmp_path)), "folder")


def _urdf(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_motor_named_like_a_joint_refused(tmp_path):
    """Item 1: a motor named 'knee' would make two parameters 'knee.fc' (drives file or URDF actuator):
    refused with motor terms; without them the robot loads and works as before (real URDFs do this)."""
    drives = tmp_path / "d.toml"
    drives.write_text(
        '[transmission]\njoints = ["hip", "knee"]\nmotors = ["hip", "knee"]\nmatrix = [[30, 0], [0, 25]]\n'
    )
    p = run_cli("info", "--urdf", "exo_leg", "--drives", str(drives), "--terms", "fc,motor_fc")
    assert_clean_error(p, "motor 'hip' has the name of a joint", "rename the motor")
    actuator = (
        '<transmission name="t"><type>transmission_interface/SimpleTransmission</type><joint name="knee"/>'
        '<actuator name="knee"><mechanicalReduction>25</mechanicalReduction></actuator></transmission></robot>'
    )
    robot = RobotModel.from_urdf(_urdf(tmp_path, "act.urdf", EXO.replace("</robot>", actuator)))
    assert parameter_names(robot, TermSelection.from_names("fc,fv"))[-1] == "knee.fv"  # joint terms: as before
    for terms in ("fc,motor_fc", "motor_fv"):
        with pytest.raises(SpecError, match="motor 'knee' has the name of a joint"):
            parameter_names(robot, TermSelection.from_names(terms))
    # names that differ keep their parameter names: 10 inertial per body, fc per joint, fc per motor
    other = EXO.replace("</robot>", actuator.replace('actuator name="knee"', 'actuator name="m_knee"'))
    names = parameter_names(
        RobotModel.from_urdf(_urdf(tmp_path, "ok.urdf", other)), TermSelection.from_names("fc,motor_fc")
    )
    assert names[20:] == ["hip.fc", "knee.fc", "m_knee.fc"] and len(set(names)) == len(names) == 23


def test_motor_name_with_newline_refused_and_toml_escaped(tmp_path):
    """Item 11: a motor name must be identifier-like; names written to TOML are escaped."""
    drives = tmp_path / "d.toml"
    drives.write_text('[transmission]\njoints = ["hip"]\nmotors = ["m\\nx"]\nmatrix = [[30]]\n')
    p = run_cli("info", "--urdf", "exo_leg", "--drives", str(drives), "--terms", "motor_fc")
    assert_clean_error(p, "motor name 'm\\nx' is not allowed")
    robot = load("exo_leg").with_inertial_parameters(load("exo_leg").inertial_parameters())
    for bad in ("a b", 'q"x', "", "m\x7f"):
        bad_robot = robot.with_drives(Drives(robot.joint_names, [Transmission(["hip"], [bad], np.array([[2.0]]))]))
        with pytest.raises(SpecError, match="is not allowed"):
            parameter_names(bad_robot, TermSelection.from_names("motor_fc"))
    # the identified drives TOML reads back (a name with the allowed punctuation)
    robot = robot.with_drives(
        Drives(robot.joint_names, [Transmission(["hip", "knee"], ["m.1/a:b-c", "m_2"], np.diag([30.0, 25.0]))])
    )
    terms = TermSelection.from_names("fc,motor_fc")
    text = IdentifiedModel(robot, terms, standard_parameters(robot, terms)).export_drives()
    d = toml_loads(text)
    assert d["transmission"][0]["motors"] == ["m.1/a:b-c", "m_2"] and set(d["motors"]) == {"m.1/a:b-c", "m_2"}
    from pinid.model.export import _q

    for name in ("a\nb", 'q"x', "b\\s", "\x7f\x01é"):
        assert toml_loads("k = " + _q(name))["k"] == name


def test_axis_whose_length_overflows_refused(tmp_path):
    """Item 7: xyz="0 -1e300 0" (x²+y²+z² overflows, urdfdom would make it zero) is refused; a long but
    finite one is normalised (the same model as "0 -1 0")."""
    for axis, fragment in (("0 -1e300 0", "overflows"), ("0 -inf 0", "not finite"), ("0 nan 0", "not finite")):
        path = _urdf(tmp_path, "a.urdf", EXO.replace('<axis xyz="0 -1 0"/>', f'<axis xyz="{axis}"/>', 1))
        assert_clean_error(run_cli("info", "--urdf", str(path)), "joint 'hip'", fragment)
    long = RobotModel.from_urdf(
        _urdf(tmp_path, "b.urdf", EXO.replace('<axis xyz="0 -1 0"/>', '<axis xyz="0 -1e100 0"/>'))
    )
    exo = load("exo_leg")
    terms = TermSelection.from_names("fc,fv")
    assert base_parameters(long, terms).names == base_parameters(exo, terms).names
    q, dq, ddq = exo.random_states(5, np.random.default_rng(1))
    np.testing.assert_allclose(long.rnea(q, dq, ddq), exo.rnea(q, dq, ddq), rtol=1e-12, atol=1e-12)


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def _with_transmission(tmp_path: Path, body: str) -> Path:
    path = tmp_path / "t.urdf"
    path.write_text(EXO.replace("</robot>", f"{body}</robot>"))
    return path


@pytest.mark.parametrize(
    "matrix", ["[[1e200, 0], [0, 1e200]]", pytest.param("[[2e6, 0], [0, 30]]", marks=pytest.mark.slow)]
)
def test_absurd_transmission_ratio_refused(tmp_path, matrix):
    (tmp_path / "d.toml").write_text(
        f'[transmission]\njoints = ["hip", "knee"]\nmotors = ["mh", "mk"]\nmatrix = {matrix}\n'
    )
    for cmd in (["info"], ["excite", "-o", str(tmp_path / "e.json")]):
        proc = run_cli(*cmd, "--urdf", "exo_leg", "--drives", str(tmp_path / "d.toml"), "--terms", "fc,fv,motor_fc")
        assert_clean_error(proc, "d.toml", "ratio", "at most 1e+06")
    assert _files(tmp_path) == ["d.toml"]


def test_absurd_mechanical_reduction_refused(tmp_path):
    urdf = _with_transmission(
        tmp_path,
        '<transmission name="t"><type>transmission_interface/SimpleTransmission</type><joint name="knee"/>'
        '<actuator name="mk"><mechanicalReduction>1e300</mechanicalReduction></actuator></transmission>',
    )
    assert_clean_error(
        run_cli("info", "--urdf", str(urdf), "--terms", "fc,fv,motor_fc"), "<transmission name='t'>", "ratio"
    )
    # a plausible ratio still loads, with the motor term
    urdf.write_text(urdf.read_text().replace("1e300", "50"))
    proc = run_cli("info", "--urdf", str(urdf), "--terms", "fc,fv,motor_fc")
    assert proc.returncode == 0, proc.stderr
    assert "mk.fc" in proc.stdout


def test_actuator_without_a_name_refused(tmp_path):
    urdf = _with_transmission(
        tmp_path,
        '<transmission name="t"><type>transmission_interface/SimpleTransmission</type><joint name="knee"/>'
        "<actuator><mechanicalReduction>50</mechanicalReduction></actuator></transmission>",
    )
    assert_clean_error(run_cli("info", "--urdf", str(urdf)), "<actuator> without a name")


def test_empty_transmission_list_refused(tmp_path):
    (tmp_path / "d.toml").write_text("transmission = []\n")
    proc = run_cli("info", "--urdf", "exo_leg", "--drives", str(tmp_path / "d.toml"), "--terms", "fc,fv,motor_fc")
    assert_clean_error(proc, "transmission = [] lists no transmission")
