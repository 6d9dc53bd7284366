"""Loading URDFs: bundled legs, example-robot-data robots, locking and choosing joints, bad input."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from pinid import JointError, ModelError, RobotModel
from pinid.errors import ModelWarning
from pinid.model.urdf import MAX_URDF_JOINTS

from conftest import assert_clean_error, load, run_cli

ROOT = Path(__file__).resolve().parents[2]


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_exo_leg_has_table2_limits(exo):
    assert exo.joint_names == ["hip", "knee"]
    np.testing.assert_allclose(exo.lower, [-0.087, -1.658])
    np.testing.assert_allclose(exo.upper, [1.309, -0.087])
    np.testing.assert_allclose(exo.velocity_limit, [1.645, 1.645])
    assert np.all(exo.coulomb > 0) and np.all(exo.viscous > 0)


def test_exo_leg_hangs_down_at_zero(exo):
    """At q = 0 the leg hangs straight down: gravity torque is nearly zero, and grows with hip flexion."""
    g0 = exo.rnea(np.zeros(2), np.zeros(2), np.zeros(2))
    g1 = exo.rnea(np.array([0.5, 0.0]), np.zeros(2), np.zeros(2))
    assert np.all(np.abs(g0) < 0.2 * np.abs(g1).max())


def test_panda_fingers_locked_by_preset():
    panda = load("panda")
    assert panda.nv == 7 and "panda_finger_joint1" in panda.locked


def test_choose_active_joints_and_lock_others():
    m = RobotModel.from_urdf("ur5", joints=["shoulder_lift_joint", "elbow_joint"], locked={"wrist_1_joint": 0.3})
    assert m.joint_names == ["shoulder_lift_joint", "elbow_joint"]
    assert m.locked["wrist_1_joint"] == 0.3
    assert m.inertial_parameters().shape == (20,)


def test_locked_joint_mass_merges_into_parent():
    full = load("ur5")
    reduced = RobotModel.from_urdf("ur5", joints=["shoulder_pan_joint", "shoulder_lift_joint"])
    m_full = full.inertial_parameters()[::10].sum()
    m_red = reduced.inertial_parameters()[::10].sum()
    assert m_red == pytest.approx(m_full)


def test_continuous_joints_use_angles():
    m = RobotModel.from_urdf(load("double_pendulum").urdf_path.with_name("double_pendulum_continuous.urdf"))
    assert [j.kind for j in m.joints] == ["continuous", "continuous"]
    q = np.array([0.3, -1.2])
    np.testing.assert_allclose(m.configuration(q), [np.cos(0.3), np.sin(0.3), np.cos(-1.2), np.sin(-1.2)])


@pytest.mark.parametrize(
    "content, fragment",
    [
        ("", "empty"),
        ("not xml at all", "not well-formed XML"),
        ("<html><body/></html>", "expected <robot>"),
        ("<robot name='r'><link name='a'/></robot>", "no movable joint"),
        ("<?xml version='1.0'?><!DOCTYPE r [<!ENTITY a 'aaaa'>]><robot name='r'>&a;</robot>", "ENTITY"),
        (
            "<robot name='r'><link name='a'/><link name='b'/><joint name='j' type='revolute'><parent link='a'/>"
            "<child link='zzz'/><axis xyz='0 0 1'/><limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>",
            "not declared",
        ),
    ],
)
def test_bad_urdf_gives_model_error(tmp_path, content, fragment):
    p = tmp_path / "bad.urdf"
    p.write_text(content)
    with pytest.raises(ModelError, match=fragment):
        RobotModel.from_urdf(p)


def test_binary_and_wrong_encoding(tmp_path):
    p = tmp_path / "bin.urdf"
    p.write_bytes(b"\x89PNG\x00\x00\x01garbage")
    with pytest.raises(ModelError, match="binary"):
        RobotModel.from_urdf(p)
    p.write_bytes("<robot name='é'/>".encode("utf-16"))
    with pytest.raises(ModelError):
        RobotModel.from_urdf(p)


def test_unknown_joint_and_out_of_range_lock():
    with pytest.raises(JointError, match="'ankle' is not in"):
        RobotModel.from_urdf("exo_leg", joints=["hip", "ankle"])
    with pytest.raises(ModelError, match="outside its limits"):
        RobotModel.from_urdf("exo_leg", joints=["hip"], locked={"knee": 0.5})


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["--urdf", "no/such/file.urdf"], "no such URDF file"),
        (["--urdf", "exo_leg", "--joints", "hip,ankle"], "'ankle' is not in"),
        (["--urdf", "exo_leg", "--joints", "hip", "--lock", "knee=0.5"], "outside its limits"),
        (["--urdf", "exo_leg", "--lock", "knee"], "expected JOINT=VALUE"),
        (["--urdf", "exo_leg", "--terms", "fc,magic"], "unknown term"),
    ],
)
def test_cli_info_bad_input(args, fragment):
    assert_clean_error(run_cli("info", *args), fragment)


def test_cli_info_not_urdf_and_no_joint(tmp_path):
    (tmp_path / "a.urdf").write_text("hello")
    assert_clean_error(run_cli("info", "--urdf", str(tmp_path / "a.urdf")), "not well-formed XML")
    (tmp_path / "b.urdf").write_text("<robot name='r'><link name='a'/></robot>")
    assert_clean_error(run_cli("info", "--urdf", str(tmp_path / "b.urdf")), "no movable joint")


def test_cli_info_prints_base_parameters_and_writes_json(tmp_path):
    out = tmp_path / "info.json"
    proc = run_cli("info", "--urdf", "exo_leg", "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "10 base parameters" in proc.stdout and "hip" in proc.stdout and "1.309" in proc.stdout
    import json

    d = json.loads(out.read_text())
    assert len(d["base_parameters"]) == 10 and d["joints"][0]["upper"] == 1.309


def test_undeclared_world_link_is_declared_for_urdfdom(tmp_path):
    """CAD exporters weld to a 'world' link they never declare; pinid declares it instead of failing."""
    text = (
        "<robot name='r'><joint name='weld' type='fixed'><parent link='world'/><child link='a'/></joint>"
        "<link name='a'/><link name='b'><inertial><mass value='1'/><inertia ixx='1' iyy='1' izz='1' ixy='0' "
        "ixz='0' iyz='0'/></inertial></link><joint name='j' type='continuous'><parent link='a'/>"
        "<child link='b'/><axis xyz='0 0 1'/></joint></robot>"
    )
    p = tmp_path / "w.urdf"
    p.write_text(text)
    assert RobotModel.from_urdf(p).joint_names == ["j"]


def test_urdfdom_complaints_become_one_line(tmp_path):
    p = tmp_path / "nolimit.urdf"
    p.write_text(
        "<robot name='r'><link name='a'/><link name='b'/><joint name='j' type='revolute'>"
        "<parent link='a'/><child link='b'/><axis xyz='0 0 1'/></joint></robot>"
    )
    assert_clean_error(run_cli("info", "--urdf", str(p)), "not a valid URDF", "limit")


def test_written_files_have_usual_permissions(tmp_path):
    import os

    from pinid.io import write_text

    write_text(tmp_path / "x.txt", "hello")
    umask = os.umask(0)
    os.umask(umask)
    assert (tmp_path / "x.txt").stat().st_mode & 0o777 == 0o666 & ~umask


def test_exo_lower_body_is_a_pelvis_with_two_four_joint_legs():
    """The bundled lower-body exoskeleton: 8 revolute joints, 21.8 kg, inertias of its boxes and cylinders."""
    import pinocchio as pin

    model = RobotModel.from_urdf("exo_lower_body")
    sides = [f"{s}_{j}" for s in "lr" for j in ("hip_abduction", "hip_flexion", "knee", "ankle")]
    assert model.joint_names == sides
    assert all(j.kind == "revolute" and np.isfinite([j.lower, j.upper, j.effort]).all() for j in model.joints)
    full = pin.buildModelFromUrdf(str(model.urdf_path))
    assert sum(i.mass for i in full.inertias) == pytest.approx(21.8)
    thigh = full.inertias[full.getJointId("l_hip_flexion")]  # cylinder r 0.04, L 0.42, 3.5 kg
    assert np.diag(thigh.inertia) == pytest.approx(
        [3.5 * (3 * 0.04**2 + 0.42**2) / 12] * 2 + [3.5 * 0.04**2 / 2], rel=1e-5
    )


def test_a_model_is_built_once_and_read_only_afterwards(tmp_path):
    """Drives, Stribeck shapes and passive exponents are given at construction; with_* returns a new model and
    the original keeps its own (issue 26: nothing writes into a built model)."""
    from pinid.model.drives import Drives, Transmission
    from pinid.model.terms import Stribeck

    m = RobotModel.from_urdf("exo_leg")
    for name, value in (("drives", None), ("stribeck", {}), ("passive_exponents", {}), ("continuous", ())):
        with pytest.raises(AttributeError):
            setattr(m, name, value)
    with pytest.raises(TypeError):
        m.stribeck["fs"] = Stribeck()
    drives = Drives(m.joint_names, [Transmission(["hip"], ["m_hip"], np.array([[30.0]]))])
    shaped = m.with_drives(drives).with_stribeck({"fs": Stribeck(0.2, 1.0)})
    assert shaped.drives is drives and shaped.stribeck == {"fs": Stribeck(0.2, 1.0)}
    assert m.drives is None and m.stribeck == {}
    assert shaped.with_drives(None).drives is None and shaped.drives is drives
    toml = tmp_path / "d.toml"
    toml.write_text('[transmission]\njoints = ["knee"]\nmotors = ["m_knee"]\nmatrix = [[25]]\n')
    built = RobotModel.from_urdf("exo_leg", drives=toml)
    assert built.motor_names == ["m_knee"] and m.with_drives(toml).motor_names == ["m_knee"]
    assert m.with_passive_exponents({"knee": np.zeros((2, 4))}).passive_exponents.keys() == {"knee"}
    assert not m.passive_exponents
    moved = m.with_urdf_path("/elsewhere/exo_leg.urdf")
    assert moved.urdf_path == Path("/elsewhere/exo_leg.urdf") and m.urdf_path != moved.urdf_path
    assert moved.urdf_text == m.urdf_text and m.with_urdf_path(None).urdf_path is None


EXO = (ROOT / "urdf" / "exo_leg.urdf").read_text()


def _chain(n: int) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = "".join(
        f'<joint name="j{i}" type="fixed"><parent link="l{i}"/><child link="l{i + 1}"/></joint>' for i in range(n)
    )
    movable = (
        '<link name="tip"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" '
        f'izz="0.1"/></inertial></link><joint name="q" type="revolute"><parent link="l{n}"/><child link="tip"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
    )
    return f'<robot name="chain">{links}{joints}{movable}</robot>'


def _exo_with(old: str, new: str) -> str:
    assert old in EXO, old
    return EXO.replace(old, new, 1)


_KNEE_JOINT = '<joint name="knee" type="revolute">'


URDF_CASES = {
    # 3: urdfdom recurses once per joint and crashes (segfault) on thousands of them
    "6000 fixed joints": (_chain(6000), f"more than pinid accepts ({MAX_URDF_JOINTS})"),
    # 4
    "lower above upper": (
        _exo_with('lower="-0.087" upper="1.309"', 'lower="1.309" upper="-0.087"'),
        "joint 'hip' has lower limit 1.309 above its upper limit -0.087",
    ),
    "two parent joints": (
        _exo_with(
            "</robot>",
            '<joint name="loop" type="revolute"><parent link="trunk"/>'
            '<child link="shank"/><axis xyz="0 1 0"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>',
        ),
        "link 'shank' is the child of joints 'knee' and 'loop'",
    ),
    "zero axis": (_exo_with('<axis xyz="0 -1 0"/>', '<axis xyz="0 0 0"/>'), "joint 'hip' has axis xyz=\"0 0 0\""),
}


def _bad_inertia(text: str, ixx: str, iyy: str, izz: str) -> str:
    import re

    return re.sub(
        r"<inertia [^>]*/>", f'<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/>', text, count=2
    )


URDF_CASES["negative moment"] = (_bad_inertia(EXO, "-0.1", "0.1", "0.1"), "a negative principal moment")


URDF_CASES["triangle inequality"] = (
    _bad_inertia(EXO, "0.01", "0.01", "0.5"),
    "one moment larger than the sum of the other two",
)


@pytest.mark.parametrize("case", sorted(URDF_CASES))
def test_bad_urdf_is_refused(tmp_path, case):
    text, fragment = URDF_CASES[case]
    p = tmp_path / "robot.urdf"
    p.write_text(text)
    with pytest.raises(ModelError, match=None) as info:
        RobotModel.from_urdf(p)
    assert fragment in str(info.value)
    assert_clean_error(run_cli("info", "--urdf", str(p), "--json", str(tmp_path / "i.json")), fragment)
    assert_clean_error(
        run_cli(
            "simulate", "--urdf", str(p), "--excitation", "zha2019-1", "--seconds", "1", "-o", str(tmp_path / "s.csv")
        ),
        fragment,
    )
    assert _files(tmp_path) == ["robot.urdf"]


def test_urdf_joint_limit_boundary_and_deep_elements(tmp_path):
    p = tmp_path / "chain.urdf"
    p.write_text(_chain(MAX_URDF_JOINTS - 1))  # 1000 joints in all: loads (in about 0.04 s)
    assert RobotModel.from_urdf(p).joint_names == ["q"]
    deep = tmp_path / "deep.urdf"  # deeply nested elements (not joints): the XML parser's own limit
    deep.write_text(EXO.replace("</robot>", "<a>" * 200000 + "</a>" * 200000 + "</robot>"))
    assert_clean_error(run_cli("info", "--urdf", str(deep)), "nesting is too deep")


def test_inertia_tolerance_accepts_rounding_and_thin_rods(tmp_path):
    p = tmp_path / "robot.urdf"
    # a thin rod (Izz = 0, Ixx = Iyy: the triangle inequality holds with equality) and a CAD rounding below 1e-6
    p.write_text(_bad_inertia(EXO, "0.02", "0.0200000001", "0"))
    assert RobotModel.from_urdf(p).nv == 2


@pytest.mark.parametrize("name", ["exo_leg", "apal_leg", "tracker_2dof", "ur5", "panda", "double_pendulum"])
def test_shipped_and_example_robots_still_load(name):
    assert RobotModel.from_urdf(name).nv >= 2  # panda: its mimic finger joint is locked


# 10: a mimic joint is locked (issue 28: without --joints), refused when named active
MIMIC_KNEE = _exo_with(_KNEE_JOINT, _KNEE_JOINT + '<mimic joint="hip" multiplier="1"/>')


def test_locked_mimic_joint_is_fine(tmp_path):
    p = tmp_path / "robot.urdf"
    p.write_text(MIMIC_KNEE)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # locked by the user: no word
        assert RobotModel.from_urdf(p, locked={"knee": -0.5}).joint_names == ["hip"]
    # locked at its neutral value, and said so (issue 47)
    with pytest.warns(ModelWarning, match=r"mimic joint\(s\) locked: 'knee' \(mimics 'hip'\) at -0.87"):
        assert RobotModel.from_urdf(p).joint_names == ["hip"]
    with pytest.raises(ModelError, match="mimic joints are not supported: joint 'knee' mimics 'hip'"):
        RobotModel.from_urdf(p, joints=["hip", "knee"])


def test_ok_urdf_through_identify_refused_when_inertia_bad(tmp_path, rec):
    p = tmp_path / "robot.urdf"
    p.write_text(URDF_CASES["triangle inequality"][0])
    proc = run_cli("identify", "--urdf", str(p), "--data", str(rec), "--methods", "ols", "-o", str(tmp_path / "r"))
    assert_clean_error(proc, "one moment larger than the sum")
    assert _files(tmp_path) == ["robot.urdf"]
