"""The wearer on the whole exoskeleton (issue 27): the pelvis and both legs strapped to exo_lower_body."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli

from pinid import RobotModel
from pinid.errors import SpecError
from pinid.wearer import anthropometry as anth
from pinid.wearer.attach import ROBOT_ATTACH, wearer_links, wearer_urdf

PERSON = dict(mass=75.0, height=1.78, sex="male")
SIDED = {"pelvis": "pelvis", **{f"{s}_{x}": x for s in "lr" for x in anth.LEG_SEGMENTS}}


def total_mass(model) -> float:
    pm = getattr(model, "ff_model", model.pin_model)
    return float(sum(i.mass for i in pm.inertias))


def test_default_attaches_the_pelvis_and_both_legs(tmp_path):
    """The written URDF loads with a fixed and a floating base; its mass is the exo's plus the attached
    segments', each segment's mass that of de Leva's table; the pelvis is merged into the floating base."""
    exo = RobotModel.from_urdf("exo_lower_body")
    proc = run_cli("wearer", "--urdf", "exo_lower_body", "--mass", "75", "--height", "1.78", "--sex", "male",
                   "-o", "worn.urdf", cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    text = (tmp_path / "worn.urdf").read_text()
    links = wearer_links(text)
    assert set(links) == set(SIDED)
    for name, seg in SIDED.items():
        assert links[name][1] == pytest.approx(anth.segment(seg, **PERSON).mass, rel=1e-9)
    assert {links[f"{s}_{x}"][0] for s in "lr" for x in ("thigh", "shank", "foot")} == {
        f"{s}_{x}" for s in "lr" for x in ("thigh", "shank", "foot")
    }
    added = sum(m for _, m, _, _ in links.values())
    fixed = RobotModel.from_urdf(tmp_path / "worn.urdf")
    floating = RobotModel.from_urdf(tmp_path / "worn.urdf", base="floating")
    assert fixed.joint_names == exo.joint_names
    assert total_mass(fixed) == pytest.approx(total_mass(exo) + added, rel=1e-9)
    assert total_mass(floating) == pytest.approx(total_mass(exo) + added, rel=1e-9)
    base_exo = RobotModel.from_urdf("exo_lower_body", base="floating").ff_model.inertias[1].mass
    assert floating.ff_model.inertias[1].mass == pytest.approx(base_exo + links["pelvis"][1], rel=1e-9)
    # placement: the legs mirror each other; the feet point forward (+x); the pelvis's centre of mass lies
    # on the midline between the hip centres (0, ±0.12, -0.13 in the pelvis frame), above them
    for x in ("thigh", "shank", "foot"):
        np.testing.assert_allclose(links[f"l_{x}"][2], links[f"r_{x}"][2], atol=1e-12)
    foot = anth.segment("foot", **PERSON)
    np.testing.assert_allclose(links["l_foot"][2], [foot.com, 0, 0], atol=1e-9)
    pelvis = anth.segment("pelvis", **PERSON)
    np.testing.assert_allclose(links["pelvis"][2], [0, 0, -0.13 + pelvis.length - pelvis.com], atol=1e-9)


def test_attach_still_chooses_the_points(tmp_path):
    text = wearer_urdf("exo_lower_body", "l_hip_flexion:l_thigh,r_knee:r_shank", **PERSON)
    assert set(wearer_links(text)) == {"l_thigh", "r_shank"}
    assert ROBOT_ATTACH["exo_lower_body"].count(":") == 7


@pytest.mark.parametrize(
    "attach, words",
    [
        ("hip:thigh,knee:shank", "'hip' names no joint or link of exo_lower_body.urdf"),
        ("l_hip_flexion:l_thigh,r_hip_flexion:thigh", "segment 'thigh' without a side beside a sided one"),
        ("pelvis:l_pelvis", "segment 'l_pelvis' is not one of pelvis, thigh, shank, foot"),
        ("pelvis:pelvis,imu:pelvis", "segment 'pelvis' attached twice"),
        ("nowhere:pelvis", "'nowhere' names no joint or link"),
    ],
)
def test_bad_attach_is_one_line_and_writes_nothing(tmp_path, attach, words):
    with pytest.raises(SpecError, match=words):
        wearer_urdf("exo_lower_body", attach, **PERSON)
    proc = run_cli("wearer", "--urdf", "exo_lower_body", "--mass", "75", "--height", "1.78", "--sex", "male",
                   "--attach", attach, "-o", "x.urdf", cwd=tmp_path)  # fmt: skip
    assert_clean_error(proc, words)
    assert not (tmp_path / "x.urdf").exists()
