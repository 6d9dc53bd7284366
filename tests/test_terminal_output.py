"""What the commands print: aligned tables that fit 120 columns (pinid.report.text)."""

from __future__ import annotations

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
    from pinid import JointTerms
    from pinid.model.describe import description_text

    row = dict(lower=-1.0, upper=1.0, velocity=2.0, effort=50.0)
    d = dict(robot="r", urdf="r.urdf", locked={}, drives=None, standard_parameters=20)
    d["base_parameters"] = [dict(name="a", expression="a", nominal=1.0, source="URDF")]
    d["joints"] = [dict(name="hip", type="revolute", **row)]
    header = description_text(d, JointTerms()).splitlines()[1]
    assert header.split()[2:] == ["lower", "[rad]", "upper", "[rad]", "velocity", "[rad/s]", "effort", "[N·m]"]
    d["joints"].insert(0, dict(name="slide", type="prismatic", **row))
    lines = description_text(d, JointTerms()).splitlines()
    assert lines[1].endswith("units") and lines[2].endswith("m, m/s, N") and lines[3].endswith("rad, rad/s, N·m")


def test_info_labels_nominal_values_by_their_source(tmp_path):
    """pinid info --drives: motor values come from the drives TOML, joint values from the URDF, and a base
    parameter merging both says so — not "(URDF: …)" for all (issue 24)."""
    from pinid import JointTerms, RobotModel
    from pinid.model.describe import describe, description_text

    toml = tmp_path / "my_drives.toml"
    toml.write_text(
        '[transmission]\njoints = ["hip", "knee"]\nmotors = ["m1", "m2"]\nmatrix = [[50, 0], [0, 50]]\n'
        "[motors.m1]\nfc = 0.01\narmature = 1e-5\n"
    )
    from pinid.model.drives import attach

    leg = attach(RobotModel.from_urdf("exo_leg"), toml)
    terms = JointTerms.from_names("fc,fv,motor_fc,motor_armature")
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
