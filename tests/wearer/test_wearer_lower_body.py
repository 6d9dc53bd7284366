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


def test_each_legs_passive_moments_read_its_own_angles():
    """On two legs a joint's passive moment reads the hip, knee and ankle of its own leg (its kinematic
    branch): moving the right leg leaves the left moments as they are, the same angles on both legs give the
    same moments, and a hip abduction joint gets none (the published moments are about flexion axes).  Before,
    the last joint of each name won: the left knee read the right hip and ankle, and the abduction joints
    took the hip's flexion moment."""
    from pinid.wearer.passive import anatomy, column

    model = RobotModel.from_urdf("exo_lower_body")
    names = model.joint_names
    assert [k for k, _ in anatomy(model)] == [None, "hip", "knee", "ankle"] * 2
    rng = np.random.default_rng(5)
    lo, hi = np.array([j.lower for j in model.joints]), np.array([j.upper for j in model.joints])
    q = rng.uniform(lo, hi, (50, model.nv))
    left = [names.index(n) for n in ("l_hip_flexion", "l_knee", "l_ankle")]
    right = [names.index(n) for n in ("r_hip_flexion", "r_knee", "r_ankle")]
    moved = q.copy()
    moved[:, right] = rng.uniform(lo[right], hi[right], (50, 3))
    np.testing.assert_array_equal(column(moved, model)[:, left], column(q, model)[:, left])
    assert np.abs(column(moved, model)[:, right] - column(q, model)[:, right]).max() > 1e-3
    mirrored = q.copy()
    mirrored[:, right] = q[:, left]
    c = column(mirrored, model)
    np.testing.assert_allclose(c[:, right], c[:, left], rtol=1e-12, atol=1e-12)
    assert not c[:, [names.index("l_hip_abduction"), names.index("r_hip_abduction")]].any()


def test_stage2_identifies_both_legs_of_the_wearer(tmp_path):
    """Stage 2 on exo_lower_body with a fixed base and both legs strapped (the pelvis segment sits on the base
    link, which no joint moves): noise-free, every base parameter of the six segments and the eight passive
    scales comes back."""
    from pinid.identification.identified import IdentifiedModel
    from pinid.model.base import base_parameters
    from pinid.model.regressor import regressor, standard_parameters
    from pinid.model.terms import TermSelection
    from pinid.wearer.attach import ROBOT_ATTACH, wearer_urdf
    from pinid.wearer.prior import drawn, wearer_prior
    from pinid.wearer.stage import identify_wearer

    path = tmp_path / "eww.urdf"
    legs_only = ROBOT_ATTACH["exo_lower_body"].split(",", 1)[1]
    assert not legs_only.startswith("pelvis")
    wearer_urdf("exo_lower_body", legs_only, **PERSON, path=path)
    exo, robot = RobotModel.from_urdf("exo_lower_body"), RobotModel.from_urdf(path)
    stage1 = IdentifiedModel(exo, TermSelection(), standard_parameters(exo, TermSelection()))
    rng = np.random.default_rng(3)
    nv = robot.nv
    truth = np.zeros(11 * nv)
    priors = wearer_prior(path.read_text(), robot)
    for b in priors:
        truth[10 * b.index : 10 * b.index + 10] = drawn(b.theta, rng)
    truth[10 * nv :] = rng.uniform(0.7, 1.3, nv)
    lo, hi = np.array([j.lower for j in robot.joints]), np.array([j.upper for j in robot.joints])
    q = rng.uniform(lo, hi, (1500, nv))
    dq, ddq = rng.normal(0, 1, q.shape), rng.normal(0, 3, q.shape)
    terms = TermSelection.from_names("passive")
    tau = stage1.inverse_dynamics(q, dq, ddq) + (regressor(robot, q, dq, ddq, terms) @ truth).reshape(q.shape)
    fit = identify_wearer(stage1, path, q, dq, ddq, tau)
    want = base_parameters(robot, fit.terms).from_standard(truth)
    assert len(priors) == 6
    assert np.max(np.abs(fit.base - want) / np.maximum(np.abs(want), 1e-3)) <= 1e-6


def test_a_foot_on_the_sole_frame_points_forward_like_on_the_foot_link():
    """Issue 33 (round 4, 14): l_sole is fixed to l_foot with the same orientation (5 cm ahead, 7 cm down): a
    foot attached there points forward, as on l_foot, not sideways (a fixed joint has no axis: the limb's is
    used)."""
    person = dict(mass=75, height=1.78, sex="male")
    on_foot = wearer_links(wearer_urdf("exo_lower_body", "l_foot:l_foot", **person))["l_foot"]
    on_sole = wearer_links(wearer_urdf("exo_lower_body", "l_sole:l_foot", **person))["l_foot"]
    assert on_sole[0] == "l_sole" and on_foot[0] == "l_foot"
    np.testing.assert_allclose(on_sole[2], on_foot[2], atol=1e-12)  # the same CoM in each frame: forward (+x)
    assert on_sole[2][0] > 0.1 and abs(on_sole[2][1]) < 1e-12
    np.testing.assert_allclose(on_sole[3], on_foot[3], atol=1e-12)
