"""The URDF document: read once per model, one place for the XML and its errors (pinid.model.urdf)."""

from __future__ import annotations

import ast
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from pinid.errors import ModelError, PinidError
from pinid.model.drives import urdf_transmissions
from pinid.model.export import identified_urdf
from pinid.model.mjcf import identified_mjcf
from pinid.model.regressor import standard_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.model.urdf import UrdfDocument
from pinid.wearer.attach import wearer_links, wearer_urdf
from pinid.wearer.prior import wearer_prior

ROOT = Path(__file__).resolve().parents[2]
PINID = ROOT / "pinid"
TERMS = TermSelection.from_names(["fc", "fv"])


@pytest.fixture
def parses(monkeypatch):
    """Counts every XML parse in the process (ElementTree's fromstring, parse and XMLParser)."""
    calls = []
    for name in ("fromstring", "XML", "parse", "XMLParser", "iterparse"):
        real = getattr(ET, name)

        def counted(*a, _real=real, _name=name, **k):
            calls.append(_name)
            return _real(*a, **k)

        monkeypatch.setattr(ET, name, counted)
    return calls


def _xml_importers() -> list[str]:
    out = []
    for p in sorted(PINID.rglob("*.py")):
        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            if any(n.startswith(("xml.etree", "xml.dom", "lxml", "yourdfpy")) for n in names):
                out.append(str(p.relative_to(ROOT)))
                break
    return out


def test_only_the_urdf_module_imports_an_xml_parser():
    assert _xml_importers() == ["pinid/model/urdf.py"]


def test_a_model_parses_its_urdf_once(parses):
    model = RobotModel.from_urdf("exo_leg")
    assert parses == ["XMLParser", "fromstring"]  # the document; Pinocchio reads the text itself
    parses.clear()
    theta = standard_parameters(model, TERMS)
    identified_urdf(model, theta, TERMS, force=True)
    identified_mjcf(model, theta, TERMS)
    urdf_transmissions(model.urdf_document, model.joint_names)
    assert model.with_inertial_parameters(model.inertial_parameters()).urdf_document is model.urdf_document
    assert parses == []  # writers and readers ask the model's document


def test_the_floating_model_and_its_urdf_reuse_the_document(parses):
    from pinid.model.export import floating_urdf
    from pinid.model.regressor import standard_parameters

    model = RobotModel.from_urdf("exo_leg", base="floating")
    assert parses.count("fromstring") == 1
    floating_urdf(model, standard_parameters(model, TERMS), TERMS)
    assert parses.count("fromstring") == 1


def test_the_wearer_urdf_starts_from_the_exoskeleton_document(parses):
    text = wearer_urdf("exo_leg", None, mass=70, height=1.75, sex="male")
    # the exoskeleton read once; the written URDF read back once to check it loads
    assert parses.count("fromstring") == 2
    parses.clear()
    assert set(wearer_links(text)) == {"thigh", "shank"} and parses.count("fromstring") == 1


def test_wearer_prior_asks_the_robots_document(tmp_path, parses):
    p = tmp_path / "w.urdf"
    p.write_text(wearer_urdf("exo_leg", None, mass=70, height=1.75, sex="male"))
    robot = RobotModel.from_urdf(p)
    parses.clear()
    assert [b.joint for b in wearer_prior(robot.urdf_text, robot)] == ["hip", "knee"]
    assert parses == []


def test_the_document_answers_what_the_modules_ask():
    doc = RobotModel.from_urdf("exo_leg").urdf_document
    assert doc.name == "exo_leg" and doc.source == ROOT / "pinid" / "resources" / "urdf" / "exo_leg.urdf"
    assert {"hip", "knee"} <= doc.joint_names()
    assert doc.child_links()["knee"] in {lk.get("name") for lk in doc.links()}
    assert doc.parent_joints()[doc.child_links()["knee"]].get("name") == "knee"
    assert doc.mimic_joints() == {} and doc.transmissions() == []
    tree = doc.tree()
    tree.remove(tree.find("link"))  # a writer's copy: the document stays as read
    assert len(tree.findall("link")) == len(doc.links()) - 1


def test_mimic_joints_and_transmissions_come_from_the_document():
    doc = UrdfDocument.from_text(
        "<robot name='r'><link name='a'/><link name='b'/><link name='c'/>"
        "<joint name='j' type='revolute'><parent link='a'/><child link='b'/></joint>"
        "<joint name='k' type='revolute'><parent link='b'/><child link='c'/><mimic joint='j'/></joint>"
        "<transmission name='t'><type>transmission_interface/SimpleTransmission</type><joint name='j'/>"
        "<actuator name='m'><mechanicalReduction>50</mechanicalReduction></actuator></transmission></robot>"
    )
    assert doc.mimic_joints() == {"k": "j"}
    (t,) = urdf_transmissions(doc, ["j"])
    assert t.motors == ["m"] and np.allclose(t.matrix, [[50.0]])


def test_undeclared_root_link_is_declared_in_text_and_tree(tmp_path):
    p = tmp_path / "w.urdf"
    p.write_text(
        "<robot name='w'><!-- c --><joint name='j' type='fixed'><parent link='world'/><child link='a'/></joint>"
        "<link name='a'/></robot>"
    )
    doc = UrdfDocument.read(p)
    assert doc.text.startswith("<robot name='w'><link name=\"world\"/><!-- c -->")
    assert [lk.get("name") for lk in doc.links()] == ["world", "a"]
    assert ET.tostring(doc.tree()) == ET.tostring(
        ET.fromstring(doc.text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    )


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (None, "no such URDF file"),
        ("", "file is empty, expected a URDF file"),
        ("<robot name='x'><link name='a'></robot>", "not well-formed XML (mismatched tag: line 1, column 33)"),
        ("<foo/>", "root element is <foo>, expected <robot> (a URDF)"),
        ("<!DOCTYPE x><robot name='x'/>", "contains a DOCTYPE/ENTITY declaration"),
        ("\ufeff<robot\x00", "binary file, expected a URDF"),
        (
            "<robot name='w'><link name='b'/><joint name='j' type='fixed'><parent link='b'/><child link='a'/></joint>"
            "</robot>",
            "joint child link(s) ['a'] are not declared as <link>",
        ),
    ],
)
def test_read_errors_are_one_line_naming_the_file(tmp_path, text, message):
    p = tmp_path / "r.urdf"
    if text is not None:
        p.write_text(text, encoding="utf-8")
    with pytest.raises(ModelError, match="^" + str(p).replace("\\", "\\\\")) as info:
        RobotModel.from_urdf(p)
    assert message in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("call", [wearer_links, lambda t: urdf_transmissions(t, ["a"]), UrdfDocument.from_text])
def test_malformed_text_is_a_pinid_error(call):
    with pytest.raises(PinidError, match="not well-formed XML"):
        call("<robot")
