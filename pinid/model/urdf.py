"""One URDF document: the file read and parsed once; every module asks it instead of parsing again.

:class:`UrdfDocument` reads a URDF file (:meth:`UrdfDocument.read`: the size, encoding and XML checks, one
:class:`~pinid.errors.ModelError` line naming the file and what is wrong) or a URDF text
(:meth:`UrdfDocument.from_text`), keeps the text Pinocchio builds the model from and the parsed tree
(comments included), and answers what the other modules ask: joints, links, the child and parent link of
a joint, mimic joints, transmissions.  Writers (the identified URDF, the MJCF, the wearer's URDF) start
from :meth:`UrdfDocument.tree`, a copy they may edit, and write with :func:`xml_text`; the element
helpers below are the only XML code outside this module.

Why ElementTree and not yourdfpy (a project dependency): measured on the bundled URDFs (Python 3.12,
this machine), ElementTree parses exo_leg in 0.05 ms, apal_leg 0.14 ms, exo_lower_body 0.23 ms;
``yourdfpy.URDF.load(..., load_meshes=False, build_scene_graph=False, build_collision_scene_graph=False)``
takes 0.5, 0.7 and 2.0 ms and its import 0.8 s (trimesh and friends: ``pinid identify``'s start-up would
grow by that).  And yourdfpy writes back only what its dataclasses model: the comments and the unknown
elements (``<gazebo>`` in ur5: 8 of them, 6 comments in exo_leg) are lost, so the identified URDF would not
be the input URDF with its inertials replaced.
"""

from __future__ import annotations

import copy
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from pinid.errors import ModelError
from pinid.io import read_bounded_file

#: An XML element of a URDF (or of an MJCF being written); for type hints.
Element = ET.Element

#: Largest URDF file accepted [bytes].
MAX_URDF_BYTES = 50 * 1024 * 1024
#: Most joints accepted in a URDF (fixed ones included); deeper chains crash urdfdom's recursive parser.
MAX_URDF_JOINTS = 1000


def _parse(text: str) -> Element:
    """The element tree of ``text``, comments kept (the writers keep the input's comments)."""
    return ET.fromstring(text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))


class UrdfDocument:
    """A URDF read once: ``text`` (what Pinocchio reads), ``source`` (the file, or a description of the
    text) and the parsed tree, which callers do not edit (writers take :meth:`tree`, a copy)."""

    def __init__(self, text: str, root: Element, source: Path | str) -> None:
        self.text = text
        self.source = source
        self._root = root

    # ------------------------------------------------------------------ reading
    @classmethod
    def read(cls, path: Path) -> "UrdfDocument":
        """Read and check the URDF file ``path``: ModelError (one line naming the file) when it is missing,
        empty, binary, not UTF-8, declares a DOCTYPE/ENTITY (XML bombs), is not well-formed XML, has no
        ``<robot>`` root, or has joints urdfdom and Pinocchio would crash on or accept silently (too many, a
        link with two parents, a zero or infinite axis, lower limit above upper, a child link not declared).
        A parent link that is never declared (an exporter's "world") is declared, as the URDF spec asks."""
        raw = read_bounded_file(path, "URDF file", error=ModelError, limit=MAX_URDF_BYTES)
        if not raw:
            raise ModelError(f"{path}: file is empty, expected a URDF file")
        if b"\x00" in raw[:4096]:
            raise ModelError(f"{path}: binary file, expected a URDF (XML text)")
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise ModelError(f"{path}: not UTF-8 text (byte {exc.start}), expected a URDF in UTF-8") from None
        if re.search(r"<!ENTITY", text, re.IGNORECASE) or re.search(r"<!DOCTYPE", text, re.IGNORECASE):
            raise ModelError(f"{path}: contains a DOCTYPE/ENTITY declaration, which a URDF does not need; refused")
        try:
            root = _parse(text)
        except ET.ParseError as exc:
            raise ModelError(f"{path}: not well-formed XML ({exc}), expected a URDF") from None
        if root.tag != "robot":
            raise ModelError(f"{path}: root element is <{root.tag}>, expected <robot> (a URDF)")
        _check_joint_elements(root, path)
        declared = {link.get("name") for link in root.findall("link")}
        parents = {j.find("parent").get("link") for j in root.findall("joint") if j.find("parent") is not None}
        children = {j.find("child").get("link") for j in root.findall("joint") if j.find("child") is not None}
        missing_children = sorted(c for c in children if c not in declared)
        if missing_children:
            raise ModelError(f"{path}: joint child link(s) {missing_children} are not declared as <link>")
        # Many exporters weld the robot to a "world" link they never declare; urdfdom refuses that.
        # Declaring the missing root link is what the URDF spec asks for and changes nothing else.
        missing_roots = sorted(p for p in parents if p and p not in declared)
        if missing_roots:
            extra = "".join(f'<link name="{name}"/>' for name in missing_roots)
            text = re.sub(r"(<robot\b[^>]*>)", lambda m: m.group(1) + extra, text, count=1)
            for i, name in enumerate(missing_roots):  # the tree of that text (whitespace aside)
                root.insert(i, ET.Element("link", name=name))
        return cls(text, root, path)

    @classmethod
    def from_text(cls, text: str, source: str = "URDF text") -> "UrdfDocument":
        """The document of a URDF ``text`` already read (a saved model's, a wearer URDF just written);
        ModelError naming ``source`` when it is not well-formed XML."""
        if not isinstance(text, str):
            raise ModelError(f"{source}: got {type(text).__name__}, expected the URDF's text")
        try:
            root = _parse(text)
        except ET.ParseError as exc:
            raise ModelError(f"{source}: not well-formed XML ({exc}), expected a URDF") from None
        return cls(text, root, source)

    # ------------------------------------------------------------------ questions
    @property
    def name(self) -> str:
        """The ``<robot name>`` ("" when absent)."""
        return self._root.get("name") or ""

    def joints(self) -> list[Element]:
        """The ``<joint>`` elements, in file order (read them, do not edit them)."""
        return self._root.findall("joint")

    def links(self) -> list[Element]:
        """The ``<link>`` elements, in file order (read them, do not edit them)."""
        return self._root.findall("link")

    def transmissions(self) -> list[Element]:
        """The ``<transmission>`` elements, in file order (read them, do not edit them)."""
        return self._root.findall("transmission")

    def joint_names(self) -> set[str]:
        """Names of every joint (fixed ones included)."""
        return {j.get("name") for j in self.joints()}

    def mimic_joints(self) -> dict[str, str]:
        """``{joint: the joint it mimics}`` of the joints with a ``<mimic>`` element."""
        return {j.get("name"): m.get("joint") for j in self.joints() if (m := j.find("mimic")) is not None}

    def child_links(self) -> dict[str, str]:
        """``{joint: its child link}`` of the joints that name one."""
        return {j.get("name"): c.get("link") for j in self.joints() if (c := j.find("child")) is not None}

    def parent_joints(self) -> dict[str, Element]:
        """``{link: the joint whose child it is}``."""
        return {c.get("link"): j for j in self.joints() if (c := j.find("child")) is not None}

    def tree(self) -> Element:
        """A copy of the parsed tree (comments included) for a writer to edit."""
        return copy.deepcopy(self._root)

    def __repr__(self) -> str:
        return f"UrdfDocument({self.name!r}, source={str(self.source)!r})"


def _check_joint_elements(root: Element, path: Path) -> None:
    """What urdfdom and Pinocchio would crash on, ignore or accept silently: too many joints, a link
    with two parent joints, a zero axis, lower limit above the upper one (mimic joints: the model's check)."""
    joints = root.findall("joint")
    if len(joints) > MAX_URDF_JOINTS:
        raise ModelError(
            f"{path}: {len(joints)} joints, more than pinid accepts ({MAX_URDF_JOINTS}); expected a robot URDF"
        )
    parent_of: dict[str, str] = {}
    for j in joints:
        name = j.get("name", "?")
        child = j.find("child")
        if child is not None and child.get("link") in parent_of:
            raise ModelError(
                f"{path}: link '{child.get('link')}' is the child of joints '{parent_of[child.get('link')]}' "
                f"and '{name}'; expected a tree (one parent joint per link, no closed loops)"
            )
        if child is not None:
            parent_of[child.get("link")] = name
        if j.get("type") in ("fixed", "floating", "planar"):
            continue
        axis = j.find("axis")
        if axis is not None and axis.get("xyz") is not None:
            try:
                xyz = [float(x) for x in axis.get("xyz").split()]
            except ValueError:
                xyz = []  # urdfdom says what is wrong with it
            with np.errstate(over="ignore", invalid="ignore"):
                squared = float(np.sum(np.square(xyz))) if len(xyz) == 3 else 1.0
            if not np.isfinite(squared):  # urdfdom normalises by sqrt(x² + y² + z²): inf, the axis becomes 0
                why = "is not finite" if not np.all(np.isfinite(xyz)) else "has a length that overflows"
                raise ModelError(
                    f"{path}: joint '{name}' has axis xyz=\"{axis.get('xyz')}\", which {why}; "
                    'expected a finite direction (it is normalised), e.g. "0 -1 0"'
                )
            if len(xyz) == 3 and not np.linalg.norm(xyz) > 1e-12:
                raise ModelError(
                    f"{path}: joint '{name}' has axis xyz=\"{axis.get('xyz')}\"; expected a non-zero direction"
                )
        limit = j.find("limit")
        if limit is not None and j.get("type") != "continuous":
            try:
                lo, hi = float(limit.get("lower", 0)), float(limit.get("upper", 0))
            except ValueError:
                continue  # urdfdom says what is wrong with it
            if lo > hi:
                raise ModelError(
                    f"{path}: joint '{name}' has lower limit {lo:g} above its upper limit {hi:g}; "
                    "expected lower <= upper"
                )


# ---------------------------------------------------------------------- writing (URDF and MJCF)
def new_element(tag: str, **attrib: str) -> Element:
    """A new XML element ``<tag attrib…/>``."""
    return ET.Element(tag, **attrib)


def sub_element(parent: Element, tag: str, **attrib: str) -> Element:
    """A new XML element ``<tag attrib…/>`` appended to ``parent``."""
    return ET.SubElement(parent, tag, **attrib)


def xml_comment(text: str) -> Element:
    """An XML comment; "--" may not appear inside one (the file would not parse), so it is spaced out."""
    while "--" in text:
        text = text.replace("--", "- -")
    return ET.Comment(text if not text.endswith("-") else text + " ")


def is_element(node: Element) -> bool:
    """True for an element, False for a comment (a tree from :meth:`UrdfDocument.tree` keeps comments)."""
    return isinstance(node.tag, str)


def xml_text(root: Element, header: str = "") -> str:
    """``root`` indented by two spaces as text: ``header`` (an XML declaration line, or "") then the
    document and a final newline.  Indents ``root`` in place."""
    ET.indent(root, space="  ")
    return header + ET.tostring(root, encoding="unicode") + "\n"
