"""The identified URDF reloads in Pinocchio and yourdfpy and gives the identified model's torques."""

from __future__ import annotations

import numpy as np
import pytest

from pinid import TermSelection, RobotModel, standard_parameters
from pinid.errors import ModelError
from pinid.model.export import identified_urdf
from pinid.identification.identified import IdentifiedModel

from conftest import load


def perturbed_theta(model, terms, seed=0):
    """A consistent standard vector different from the URDF's (each body's mass distribution moved)."""
    from pinid.simulation.cad import perturb

    theta = standard_parameters(perturb(model, 20.0, np.random.default_rng(seed)), terms)
    theta[10 * model.nv :] = np.random.default_rng(seed).uniform(0.05, 0.5, model.nv * len(terms))
    return theta


@pytest.mark.parametrize("name", ["exo_leg", "double_pendulum", "ur5", "panda"])
def test_exported_urdf_reloads_with_the_same_torques(name, tmp_path):
    import yourdfpy

    model = load(name)
    terms = TermSelection()
    theta = perturbed_theta(model, terms)
    ident = IdentifiedModel(model, terms, theta)
    path = tmp_path / f"{name}_identified.urdf"
    text = identified_urdf(model, theta, terms, path, comment="test")
    assert path.read_text() == text and "identified by pinid (test)" in text
    # "--" cannot stand inside an XML comment: a comment that holds one still gives a loadable file
    dashes = path.with_name("dashes.urdf")
    identified_urdf(model, theta, terms, dashes, comment="pinid simulate --perturb 30 -")
    RobotModel.from_urdf(dashes, joints=model.joint_names, locked=model.locked)
    back = RobotModel.from_urdf(path, joints=model.joint_names, locked=model.locked)
    q, dq, ddq = model.random_states(30, np.random.default_rng(1))
    expected = ident.inverse_dynamics(q, dq, ddq)
    got = back.rnea(q, dq, ddq) + back.coulomb * np.sign(dq) + back.viscous * dq
    np.testing.assert_allclose(got, expected, atol=1e-9 * max(1.0, np.abs(expected).max()))
    np.testing.assert_allclose(back.inertial_parameters(), theta[: 10 * model.nv], atol=1e-10)
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=False, build_collision_scene_graph=False)
    moving = {j.name: j.child for j in urdf.robot.joints}
    for i, j in enumerate(model.joint_names):
        assert urdf.link_map[moving[j]].inertial.mass == pytest.approx(theta[10 * i])


def test_merged_links_lose_their_inertial_and_say_so(tmp_path):
    model = load("panda")  # hand and fingers (locked) are merged into panda_joint7's body
    terms = TermSelection()
    text = identified_urdf(model, standard_parameters(model, terms), terms)
    assert "including merged link(s) panda_hand" in text
    assert text.count("inertial removed") >= 3
    assert "locked joints: panda_finger_joint1=0" in text


def test_nominal_parameters_export_the_urdf_inertials():
    """URDF link frame = joint frame: exporting the nominal parameters gives back the URDF's numbers."""
    import xml.etree.ElementTree as ET

    model = load("exo_leg")
    terms = TermSelection()
    text = identified_urdf(model, standard_parameters(model, terms), terms)
    new = ET.fromstring(text)
    old = ET.fromstring(model.urdf_text)
    for j in model.joint_names:
        child = old.find(f"joint[@name='{j}']/child").get("link")
        a, b = old.find(f"link[@name='{child}']/inertial"), new.find(f"link[@name='{child}']/inertial")
        assert float(b.find("mass").get("value")) == pytest.approx(float(a.find("mass").get("value")))
        if a.find("origin").get("rpy", "0 0 0").split() == ["0", "0", "0"]:
            np.testing.assert_allclose(
                [float(x) for x in b.find("origin").get("xyz").split()],
                [float(x) for x in a.find("origin").get("xyz").split()],
                atol=1e-12,
            )
            for k in ("ixx", "iyy", "izz", "ixy", "ixz", "iyz"):
                assert float(b.find("inertia").get(k)) == pytest.approx(float(a.find("inertia").get(k)), abs=1e-12)
        dyn = new.find(f"joint[@name='{j}']/dynamics")
        i = model.joint_index(j)
        assert float(dyn.get("friction")) == pytest.approx(model.coulomb[i])


def test_inconsistent_parameters_are_refused_unless_forced(tmp_path):
    model = load("exo_leg")
    terms = TermSelection(coulomb=True, viscous=True, armature=True)
    theta = standard_parameters(model, terms)
    theta[10] = -1.0  # knee mass
    with pytest.raises(ModelError, match="refusing to export physically inconsistent.*knee"):
        identified_urdf(model, theta, terms, tmp_path / "x.urdf")
    assert not (tmp_path / "x.urdf").exists()
    text = identified_urdf(model, theta, terms, tmp_path / "x.urdf", force=True)
    assert "physically consistent: NO (forced)" in text and "armature" in text


def test_identified_model_and_result_export(tmp_path):
    model = load("exo_leg")
    terms = TermSelection()
    ident = IdentifiedModel(model, terms, perturbed_theta(model, terms, seed=3), meta={"method": "sdp"})
    text = ident.export_urdf(tmp_path / "m.urdf")
    assert "method sdp" in text and (tmp_path / "m.urdf").is_file()


def test_export_refuses_urdf_pinid_cannot_read(leg):
    """Case 11: a parameter set that passes the consistency tolerance but gives a URDF pinid refuses
    (mass −1e-12 kg) is not exported."""
    from pinid.errors import ModelError
    from pinid.model.export import identified_urdf
    from pinid.model.physical import check_consistency

    theta = standard_parameters(leg).copy()
    theta[10:20] = [-1e-12, 0, 0, 0, 0.01, 0, 0.01, 0, 0, 0.01]  # knee mass −1e-12 kg as OLS gave on zero torques
    assert check_consistency(theta, leg.joint_names, ["fc", "fv"]).consistent  # within the tolerance
    with pytest.raises(ModelError, match="would not load back"):
        identified_urdf(leg, theta, TermSelection())
