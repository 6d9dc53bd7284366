"""Issue 25, items 1-11 ("silently wrong or lost"): each case gives one line on stderr and exit status 2
from the CLI with nothing written or replaced, a PinidError subclass from Python, or the right answer.
docs/checks.md lists them."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from conftest import assert_clean_error, load, run_cli
from pinid.data.dataset import Dataset
from pinid.data.formats import read_recording, time_digits, write_recording
from pinid.errors import ModelError, OutputError, SpecError
from pinid.identification.gains import Payload
from pinid.identification.identified import IdentifiedModel
from pinid.io import Artefacts, toml_loads
from pinid.model.base import base_parameters
from pinid.model.drives import Drives, Transmission
from pinid.model.regressor import parameter_names, standard_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.wearer.attach import wearer_urdf

ROOT = Path(__file__).resolve().parents[2]
EXO = (ROOT / "urdf" / "exo_leg.urdf").read_text()
KNEE_ORIGIN = '<origin xyz="0 0 -0.42" rpy="0 0 0"/>'
EXCITATION = str(ROOT / "excitation" / "exo_leg.json")


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def _urdf(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# ------------------------------------------------------------------------- 1, 11: motor names
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


# ------------------------------------------------------------------------- 2: outputs on resolved paths
def test_outputs_through_a_symlinked_folder_collide(tmp_path):
    """Item 2: -o link/e.json and --csv target/e.json are one file."""
    (tmp_path / "target").mkdir()
    (tmp_path / "link").symlink_to("target")
    p = run_cli(
        "excite",
        "--urdf",
        "exo_leg",
        "-o",
        str(tmp_path / "link" / "e.json"),
        "--csv",
        str(tmp_path / "target" / "e.json"),
    )
    assert_clean_error(p, "two outputs of this run would be written to the same file")
    assert _files(tmp_path) == []
    (tmp_path / "target" / "a.txt").write_text("old")
    os.link(tmp_path / "target" / "a.txt", tmp_path / "b.txt")  # a hard link: one file, two names
    out = Artefacts(overwrite=True)
    out.add(tmp_path / "b.txt", "1")
    out.add(tmp_path / "link" / "a.txt", "2")
    with pytest.raises(OutputError, match="same file"):
        out.write()
    assert (tmp_path / "b.txt").read_text() == "old"


# ------------------------------------------------------------------------- 3, 4, 5: stage 2
@pytest.fixture(scope="module")
def stage2_files(tmp_path_factory, recording):
    """An exo + wearer URDF, the stage-1 model (exo_leg, consistent), a tampered one (knee.m = -50), one of
    apal_leg, and one of apal_leg's kinematics named exo_leg; the conftest recording and a copy of it."""
    d = tmp_path_factory.mktemp("stage2")
    wearer_urdf("exo_leg", "hip:thigh,knee:shank", mass=75, height=1.78, sex="male", path=d / "eww.urdf")
    terms = TermSelection.from_names("fv")
    for name, urdf in (("exo", "exo_leg"), ("apal", "apal_leg")):
        r = RobotModel.from_urdf(urdf)
        IdentifiedModel(r, terms, standard_parameters(r, terms)).save(d / f"{name}.json")
    m = json.loads((d / "exo.json").read_text())
    m["standard_parameters"]["knee.m"] = -50.0
    (d / "tampered.json").write_text(json.dumps(m))
    apal = RobotModel.from_urdf("apal_leg")
    text = apal.urdf_text.replace(f'name="{apal.name}"', 'name="exo_leg"', 1)
    renamed = RobotModel.from_urdf(_urdf(d, "apal_as_exo.urdf", text))
    assert renamed.name == "exo_leg"
    IdentifiedModel(renamed, terms, standard_parameters(renamed, terms)).save(d / "apal_as_exo.json")
    (d / "copy.csv").write_bytes(Path(recording).read_bytes())
    return d


def _stage2(d: Path, out: Path, *extra: str, exo: str = "exo.json", data=None) -> tuple:
    data = data or [str(d / "copy.csv")]
    args = ("identify", "--stage", "wearer", "--exo", str(d / exo), "--urdf", str(d / "eww.urdf"), "--no-report")
    return (*args, *(a for x in data for a in ("--data", x)), "-o", str(out), *extra)


def test_stage2_refuses_inconsistent_or_foreign_stage1_model(stage2_files, tmp_path):
    """Item 3: a tampered (knee.m = -50) or another robot's stage-1 model is refused."""
    d = stage2_files
    cases = [
        ("tampered.json", "not physically consistent", "knee"),
        ("apal.json", "of robot 'apal_leg'", "wearer URDF"),
        ("apal_as_exo.json", "another placement or axis", "joint 'hip'"),
    ]
    for exo, *fragments in cases:
        assert_clean_error(run_cli(*_stage2(d, tmp_path / "out", exo=exo)), *fragments)
    assert _files(tmp_path) == []


def test_stage2_refuses_stage1_options(stage2_files, tmp_path, recording):
    """Item 4: options stage 2 does not use are refused, not ignored (and stage 2's in stage 1)."""
    d = stage2_files
    for extra in (
        ("--payload", "p.toml"),
        ("--payload-data", str(recording)),
        ("--methods", "ols"),
        ("--terms", "fc"),
        ("--option", "sdp.regularization=1"),
    ):
        assert_clean_error(run_cli(*_stage2(d, tmp_path / "out", *extra)), extra[0], "does not apply to stage 2")
    p = run_cli("identify", "--data", str(recording), "--prior-weight", "0", "-o", str(tmp_path / "out"))
    assert_clean_error(p, "--prior-weight does not apply to stage 1")
    assert _files(tmp_path) == []


def test_duplicate_recordings_refused(stage2_files, tmp_path, recording):
    """Item 5: the same recording twice (same path, or a copy) in stage 2 and as --payload-data."""
    d = stage2_files
    p = run_cli(*_stage2(d, tmp_path / "a", data=[str(d / "copy.csv"), str(d / "copy.csv")]))
    assert_clean_error(p, "given twice as training data")
    p = run_cli(*_stage2(d, tmp_path / "b", data=[str(recording), str(d / "copy.csv")]))
    assert_clean_error(p, "given twice as training data", "same contents")
    payload = tmp_path / "p.toml"
    payload.write_text("mass = 2.0\ncom = [0.0, 0.0, -0.3]\n")
    p = run_cli(
        "identify", "--data", str(recording), "--payload", str(payload), "--payload-data", str(d / "copy.csv"),
        "--payload-data", str(d / "copy.csv"), "-o", str(tmp_path / "c"),
    )  # fmt: skip
    assert_clean_error(p, "given twice as payload data")
    assert _files(tmp_path) == ["p.toml"]


# ------------------------------------------------------------------------- 6: payload values
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


def test_payload_value_refused_from_the_command_line(tmp_path, recording):
    path = tmp_path / "p.toml"
    path.write_text("mass = 1e300\n")
    p = run_cli(
        "identify", "--data", str(recording), "--payload", str(path), "--payload-data", str(recording),
        "-o", str(tmp_path / "out"),
    )  # fmt: skip
    assert_clean_error(p, "p.toml", "expected a mass from")
    assert _files(tmp_path) == ["p.toml"]


# ------------------------------------------------------------------------- 7: axes
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


# ------------------------------------------------------------------------- 8: epoch time stamps
def test_epoch_time_written_exactly(tmp_path):
    """Item 8: t = 1.7e9 s in 1 ms steps is written with every digit and read back exactly."""
    t = 1.7e9 + np.arange(3000) * 1e-3
    q = np.c_[np.sin(t - 1.7e9), np.cos(t - 1.7e9)]
    path = write_recording(tmp_path / "epoch.csv", Dataset(t, q, ["hip", "knee"], tau=2 * q))
    back = read_recording(path)
    np.testing.assert_array_equal(back.t, t)
    np.testing.assert_array_equal(back.q, np.asarray([[float(f"{v:.12g}") for v in row] for row in q]))
    assert time_digits(np.arange(1500) / 500.0, 12) == 12  # ordinary time stamps: written as before


# ------------------------------------------------------------------------- 9: twin that cannot track
def test_simulate_refuses_a_run_that_leaves_the_limits(tmp_path):
    """Item 9: a knee 1e6 m below the hip: the twin says it did not track, and why, and writes nothing."""
    path = _urdf(tmp_path, "far.urdf", EXO.replace(KNEE_ORIGIN, '<origin xyz="0 0 -1e6" rpy="0 0 0"/>'))
    out = tmp_path / "out"
    p = run_cli("simulate", "--urdf", str(path), "--excitation", EXCITATION, "--seconds", "1", "-o", str(out / "r.csv"))
    assert_clean_error(p, "failed to track", "joint 'knee'", "outside its limits", "1e+06 m from its parent joint")
    assert not out.exists()


# ------------------------------------------------------------------------- 10: pinid wearer
def test_wearer_refuses_urdfs_it_cannot_load(tmp_path):
    """Item 10: NaN origin, lower > upper: refused before anything is written; two attach points on one
    segment from Python too; a mimic joint is locked, so what is written loads."""
    knee_limit = '<limit lower="-1.658" upper="-0.087"'
    cases = [
        (EXO.replace(KNEE_ORIGIN, '<origin xyz="0 0 -0.42" rpy="nan nan nan"/>'), "nan"),
        (EXO.replace(knee_limit, '<limit lower="-0.087" upper="-1.658"'), "lower limit -0.087 above"),
    ]
    for i, (text, fragment) in enumerate(cases):
        src = _urdf(tmp_path, f"in{i}.urdf", text)
        out = tmp_path / f"out{i}.urdf"
        p = run_cli("wearer", "--urdf", str(src), "--mass", "75", "--height", "1.78", "--sex", "male", "-o", str(out))
        assert_clean_error(p, fragment)
        assert not out.exists()
    # a mimic joint is locked when the robot loads (issue 28), so the written URDF loads back: written, not refused
    src = _urdf(tmp_path, "mimic.urdf", EXO.replace(knee_limit, '<mimic joint="hip"/>' + knee_limit))
    out = tmp_path / "mimic_out.urdf"
    p = run_cli("wearer", "--urdf", str(src), "--mass", "75", "--height", "1.78", "--sex", "male", "-o", str(out))
    assert p.returncode == 0, p.stderr
    assert RobotModel.from_urdf(out).joint_names == ["hip"]
    with pytest.raises(SpecError, match="segment 'thigh' attached twice"):
        wearer_urdf("exo_leg", [("hip", "thigh"), ("knee", "thigh")], mass=75, height=1.78, sex="male")
    with pytest.raises((ModelError, SpecError)):
        wearer_urdf(tmp_path / "in0.urdf", "hip:thigh", mass=75, height=1.78, sex="male")


def test_consistency_check_names_problem():
    """Item 3 from Python: identify_wearer refuses the inconsistent model before reading any data."""
    from pinid.wearer.stage import check_stage1

    exo = load("exo_leg")
    terms = TermSelection.from_names("fv")
    theta = standard_parameters(exo, terms)
    theta[10] = -50.0
    bad = IdentifiedModel(exo, terms, theta)
    with pytest.raises(SpecError, match="knee: pseudo-inertia"):
        check_stage1(bad, exo)
    check_stage1(IdentifiedModel(exo, terms, standard_parameters(exo, terms)), exo)  # the exo itself passes
