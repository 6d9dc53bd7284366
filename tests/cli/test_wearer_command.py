"""pinid wearer (pinid/cli/wearer.py): URDFs it cannot load are refused with one line and exit status 2, before
anything is written."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import assert_clean_error, run_cli

from pinid.errors import ModelError, SpecError
from pinid.model.robot import RobotModel
from pinid.wearer.attach import wearer_urdf

ROOT = Path(__file__).resolve().parents[2]
EXO = (ROOT / "urdf" / "exo_leg.urdf").read_text()
KNEE_ORIGIN = '<origin xyz="0 0 -0.42" rpy="0 0 0"/>'


def _urdf(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


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


@pytest.mark.parametrize(
    "change, fragment",
    [
        (lambda s: s.replace('<axis xyz="0 -1 0"/>', '<axis xyz="0 -1"/>', 1), "axis"),
        (
            lambda s: s.replace('<origin xyz="0 0 0" rpy="0 0 0"/>\n    <axis', '<origin xyz="a b c"/>\n    <axis', 1),
            "[a]",
        ),
        (lambda s: s.replace("</robot>", "<x>" * 200_000 + "</x>" * 200_000 + "</robot>"), "nesting"),
    ],
    ids=["axis-2", "xyz-text", "nested"],
)
def test_wearer_on_broken_urdf(tmp_path, change, fragment):
    bad = change(EXO)
    assert bad != EXO
    (tmp_path / "x.urdf").write_text(bad)
    out = tmp_path / "w.urdf"
    proc = run_cli(
        "wearer",
        "--urdf",
        str(tmp_path / "x.urdf"),
        "--mass",
        "75",
        "--height",
        "1.78",
        "--sex",
        "male",
        "-o",
        str(out),
    )
    assert_clean_error(proc, "x.urdf", fragment)
    assert not out.exists()
