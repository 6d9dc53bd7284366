"""What the commands print: aligned tables that fit 120 columns (pinid.report.text)."""

from __future__ import annotations

import numpy as np
import pytest

from pinid.errors import SpecError
from pinid.report.text import text_table


def _starts(line: str) -> list[int]:
    """Start of every cell (cells are separated by two or more spaces)."""
    import re

    return [m.start() for m in re.finditer(r"(?:(?<=  )|^)\S", line)]


def test_columns_align_with_long_names():
    """Long joint or model names widen their column instead of pushing the row out of line (pinid track)."""
    rows = [
        ["backstepping", "cad:30", "hip", "14.891"],
        ["computed-torque", "identified_model_of_the_left_leg.json", "left_hip_flexion_extension_joint", "0.035"],
    ]
    text = text_table(["controller", "model", "joint", "RMS [mrad]"], rows, keys=3)
    lines = text.splitlines()
    assert len(lines) == 4 and len({len(line) for line in lines}) == 1  # every line as wide: right edges align
    assert _starts(lines[0])[:3] == _starts(lines[2])[:3] == _starts(lines[3])[:3]


def test_wide_tables_split_to_fit_repeating_the_key_column():
    header = ["method"] + [f"panda_joint{k} |e| [N·m]" for k in range(1, 8)]
    rows = [[m] + ["0.05596 ± 0.1355"] * 7 for m in ("ols", "rls-pso", "ewoa")]
    text = text_table(header, rows, width=120)
    assert max(map(len, text.splitlines())) <= 120
    parts = text.split("\n\n")
    assert len(parts) >= 2
    for part in parts:
        assert part.splitlines()[0].startswith("method") and [line.split()[0] for line in part.splitlines()[2:]] == [
            "ols",
            "rls-pso",
            "ewoa",
        ]
    assert sum(part.splitlines()[0].count("panda_joint") for part in parts) == 7  # every column exactly once


def test_info_joint_table_has_units():
    """pinid info: limits, velocity and effort with their units; prismatic joints in m, m/s, N (issue 24)."""
    from pinid import TermSelection
    from pinid.model.describe import description_text

    row = dict(lower=-1.0, upper=1.0, velocity=2.0, effort=50.0)
    d = dict(robot="r", urdf="r.urdf", locked={}, drives=None, standard_parameters=20)
    d["base_parameters"] = [dict(name="a", expression="a", nominal=1.0, source="URDF")]
    d["joints"] = [dict(name="hip", type="revolute", **row)]
    header = description_text(d, TermSelection()).splitlines()[1]
    assert header.split()[2:] == ["lower", "[rad]", "upper", "[rad]", "velocity", "[rad/s]", "effort", "[N·m]"]
    d["joints"].insert(0, dict(name="slide", type="prismatic", **row))
    lines = description_text(d, TermSelection()).splitlines()
    assert lines[1].endswith("units") and lines[2].endswith("m, m/s, N") and lines[3].endswith("rad, rad/s, N·m")


def test_info_labels_nominal_values_by_their_source(tmp_path):
    """pinid info --drives: motor values come from the drives TOML, joint values from the URDF, and a base
    parameter merging both says so — not "(URDF: …)" for all (issue 24)."""
    from pinid import TermSelection, RobotModel
    from pinid.model.describe import describe, description_text

    toml = tmp_path / "my_drives.toml"
    toml.write_text(
        '[transmission]\njoints = ["hip", "knee"]\nmotors = ["m1", "m2"]\nmatrix = [[50, 0], [0, 50]]\n'
        "[motors.m1]\nfc = 0.01\narmature = 1e-5\n"
    )

    leg = RobotModel.from_urdf("exo_leg", drives=toml)
    terms = TermSelection.from_names("fc,fv,motor_fc,motor_armature")
    d = describe(leg, terms)
    source = {b["name"]: b["source"] for b in d["base_parameters"]}
    assert source["hip.fcR"] == "URDF + my_drives.toml" and source["hip.fv"] == "URDF", source
    assert source["m2.armature"] == "my_drives.toml", source
    text = description_text(d, terms)
    assert "(URDF + my_drives.toml: 1.7)" in text and "(my_drives.toml: 0)" in text, text


def test_track_table_prints_the_settling_band():
    """pinid track: the settling time comes with the band it settled into (2 % of the range, ≥ 1 mrad)."""
    import numpy as np

    from pinid.control.controllers import TrackingResult
    from pinid.control.tracking import tracking_table

    t = np.linspace(0.0, 2 * np.pi, 401)
    q_d = np.c_[0.5 * np.cos(t)]  # range 1 rad
    q = q_d + 0.01 * (t < 1.0)[:, None]
    run = TrackingResult(t=t, q_d=q_d, q=q, dq=0 * q, tau=0 * q, joints=["hip"])
    m = run.metrics(after=2.0)
    assert abs(m["hip"]["band"] - 0.02) < 1e-12  # 2 % of the 1 rad range: 20 mrad, wider than the 10 mrad error
    table = tracking_table({"backstepping": {"nominal": {"metrics": m}}})
    header, _, row = table.splitlines()
    assert "settle [s]" in header and "band [mrad]" in header
    assert row.split()[-2:] == ["0.00", "20"], row


def test_identify_checks_its_inputs_before_saying_what_it_identifies(tmp_path):
    """A bad input gives the one error line on stderr and nothing on stdout: no "identifying …" first."""
    from conftest import assert_clean_error, run_cli

    bad = tmp_path / "run.csv"
    bad.write_text("t,q_hip,q_knee,tau_hip\n0,0,0,0\n0.001,0,0,0\n")  # tau_knee missing
    proc = run_cli("identify", "--data", str(bad), "--methods", "ols", "-o", str(tmp_path / "out"))
    assert_clean_error(proc, "run.csv")
    assert proc.stdout == "", proc.stdout
    assert not (tmp_path / "out").exists()


def test_simulate_summary_of_a_six_joint_arm_is_wrapped_and_aligned():
    """pinid simulate on the UR5: not one 330-column line but labelled blocks within 100 columns, every
    continuation starting where the first line's items start."""
    import numpy as np

    from pinid.data.dataset import Dataset
    from pinid.simulation.outputs import simulation_text

    joints = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint"]
    joints.append("wrist_3_joint")
    truth = {
        "tracking": {"rms_error": {j: 1.234e-4 * (k + 1) for k, j in enumerate(joints)}},
        "rates": {"sample": 5000},
        "standard": {"names": ["x"] * 72},
        "base": {"names": ["x"] * 36},
    }
    recording = Dataset(t=np.arange(26000) / 5000, q=np.zeros((26000, 6)), joints=joints)
    text = simulation_text(recording, truth, "data/ur5_train.csv")
    lines = text.splitlines()
    assert max(map(len, lines)) <= 100, text
    assert lines[0] == "wrote data/ur5_train.csv (26000 samples at 5000 Hz)" and lines[-1].startswith("wrote ")
    block = lines[1:-1]
    column = len(block[0]) - len(block[0][2:].split("  ", 1)[1].lstrip())  # where the items start
    assert all(line[:column].strip() in ("", "joints", "tracking error rms [rad]") for line in block), text
    assert all(line[column] != " " and line[column - 1] == " " for line in block), text
    for j in joints:  # every joint named once per block, never split
        assert sum(line.count(j) for line in block) == 2, (j, text)
    two = {**truth, "tracking": {"rms_error": {"hip": 1e-4, "knee": 2e-4}}}
    text = simulation_text(
        Dataset(t=np.arange(6000) / 1000, q=np.zeros((6000, 2)), joints=["hip", "knee"]), two, "run.csv"
    )
    assert text.splitlines()[1:3] == [
        f"  {'joints':<26}hip, knee",
        f"  {'tracking error rms [rad]':<26}hip 0.0001, knee 0.0002",
    ]


def test_demo_summary_continuation_is_aligned():
    """The demo's closing list: each description, continuation lines included, starts in one column."""
    from pinid.cli.demo import summary_text

    for out in ("demo", "/tmp/a/much/longer/folder"):
        lines = summary_text(out).splitlines()
        starts = {len(line) - len(line.lstrip()) if line.startswith("   ") else _starts(line)[1] for line in lines}
        assert len(starts) == 1, summary_text(out)
        assert any(line.startswith(" " * 10) for line in lines)  # the continuation line is there


def test_the_tracking_table_says_what_its_statistics_cover():
    from pinid.control.controllers import TrackingResult
    from pinid.control.tracking import tracking_table

    t = np.linspace(0.0, 4.0, 401)
    q_d = np.c_[0.5 * np.cos(t)]
    run = TrackingResult(t=t, q_d=q_d, q=q_d + 0.05 * (t < 1.0)[:, None], dq=0 * q_d, tau=0 * q_d, joints=["hip"])
    table = {"backstepping": {"nominal": {"metrics": run.metrics(after=1.5)}}}
    text = tracking_table(table, after=1.5)
    assert "over t ≥ 1.5 s (--after" in text and "at least 1 mrad" in text
    assert max(len(line) for line in text.splitlines()) <= 100
    assert tracking_table(table) == text.split("\nRMS, max")[0]
    with pytest.raises(SpecError, match="after"):
        tracking_table(table, after="1.5")
