"""An exoskeleton URDF with the wearer's leg segments strapped to it (``pinid wearer``).

Each human segment becomes a link ``wearer_<segment>`` fixed (joint ``wearer_<segment>_strap``) to
the exoskeleton link it is strapped to.  Placement, in the frame of that exo link (the frame of the
joint that moves it):

* the segment's proximal endpoint is the joint centre (joint centres aligned, offset zero) — except a
  foot strapped to the same link as the shank (an exo without an ankle joint): its proximal endpoint
  is the ankle, one shank length down the shank's axis, and its axis points forward;
* the segment's longitudinal axis ``d`` runs along the exo link: towards the origin of the link's first
  child joint; for a last link (no child joint) along the previous link's axis (the direction of its
  own joint's origin, in its frame at q = 0); failing that towards its centre of mass; else along −z;
* its transverse axis is the joint axis (made orthogonal to ``d``), its sagittal axis completes the
  right-handed frame — so for a sagittal-plane exo the table's transverse radius of gyration is the
  one that matters;
* a foot on its own link (an ankle joint) starts at the ankle joint centre and points forward: across the
  joint axis and the leg's direction (the previous link's), the heel taken under the ankle;
* the pelvis (de Leva's lower trunk, omphalion → mid-hip) has its distal endpoint at the midpoint of the
  hip joint centres (the two thighs' proximal endpoints, else the link's moving child joints' origins),
  its axis along the link's +z, its transverse axis along the line between the hips.

Two legs: a leg segment's name may carry its side (``l_thigh`` … ``r_foot``; link ``wearer_l_thigh``).
The default attach points are the robot's (:data:`ROBOT_ATTACH`: exo_lower_body gets the pelvis and both
legs), else :data:`DEFAULT_ATTACH`.

Pinocchio merges fixed links into the moving body, so the URDF loads as the exo with heavier links;
the wearer's share stays readable from the ``wearer_*`` links (:func:`wearer_links`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pinid.errors import SpecError
from pinid.model.export import inertial_element
from pinid.model.urdf import Element, UrdfDocument, sub_element, xml_comment, xml_text
from pinid.wearer.anthropometry import LEG_SEGMENTS, STRAPPED_SEGMENTS, Segment, check_person, segment

PREFIX = "wearer_"
#: Sides a leg segment's name may start with (``l_thigh``, ``r_foot``): two legs on one exoskeleton.
SIDES = ("l_", "r_")
#: The default ``--attach`` of a robot (by its URDF ``<robot name>``); others: :data:`DEFAULT_ATTACH`.
ROBOT_ATTACH = {
    "exo_lower_body": "pelvis:pelvis,l_hip_flexion:l_thigh,l_knee:l_shank,l_ankle:l_foot,"
    "r_hip_flexion:r_thigh,r_knee:r_shank,r_ankle:r_foot",
}
#: The default ``--attach`` of a robot not in :data:`ROBOT_ATTACH` (exo_leg's joint names).
DEFAULT_ATTACH = "hip:thigh,knee:shank"


def _table_name(name: str) -> str:
    """The table's segment of a strapped segment name: ``l_thigh`` → ``thigh``, ``pelvis`` → ``pelvis``."""
    for side in SIDES:
        if name.startswith(side) and name[len(side) :] in LEG_SEGMENTS:
            return name[len(side) :]
    return name


@dataclass(frozen=True)
class Placement:
    """A segment in its exo link's frame: centre of mass ``com`` [m], inertia about it ``inertia`` [kg·m²]."""

    segment: Segment
    link: str
    com: np.ndarray
    inertia: np.ndarray
    start: np.ndarray  # proximal endpoint [m]
    frame: np.ndarray  # columns: sagittal, transverse, longitudinal axis


def _parse_attach(text: str) -> list[tuple[str, str]]:
    """``"hip:thigh,knee:shank"`` → ``[("hip", "thigh"), ("knee", "shank")]`` (exo joint or link : segment)."""
    if not isinstance(text, str):
        raise SpecError(
            f"--attach: got {type(text).__name__}, expected POINT:SEGMENT pairs such as hip:thigh,knee:shank"
        )
    pairs = []
    for item in (s.strip() for s in text.split(",")):
        point, sep, seg = item.partition(":")
        if not item or not sep or not point.strip() or not seg.strip():
            raise SpecError(f"--attach {item!r}: expected POINT:SEGMENT, e.g. hip:thigh,knee:shank")
        pairs.append((point.strip(), seg.strip()))
    return check_pairs(pairs)


def check_pairs(pairs) -> list[tuple[str, str]]:
    """``pairs`` as a list of (point, segment) name pairs, each segment one of :data:`LEG_SEGMENTS` and
    attached once (two ``wearer_thigh`` links would make a URDF nothing loads); SpecError otherwise."""
    try:
        pairs = [tuple(p) for p in pairs]
    except TypeError:
        pairs = []
    if not pairs or not all(len(p) == 2 and all(isinstance(x, str) for x in p) for p in pairs):
        raise SpecError(f"--attach {pairs!r}: expected (point, segment) pairs of names, e.g. hip:thigh,knee:shank")
    segs = [s for _, s in pairs]
    for s in segs:
        if _table_name(s) not in STRAPPED_SEGMENTS:
            raise SpecError(
                f"--attach: segment {s!r} is not one of {', '.join(STRAPPED_SEGMENTS)} "
                f"(a leg segment may name its side: {', '.join(SIDES[0] + x for x in LEG_SEGMENTS)}, r_…)"
            )
        if segs.count(s) > 1:
            raise SpecError(f"--attach: segment {s!r} attached twice, expected once")
        if s in LEG_SEGMENTS and any(x != s and _table_name(x) == s for x in segs):
            raise SpecError(f"--attach: segment {s!r} without a side beside a sided one, expected l_{s} and r_{s}")
    return pairs


def _default_attach(root: Element) -> str:
    """The default ``--attach`` of the URDF tree ``root``: :data:`ROBOT_ATTACH` by its robot name, else
    :data:`DEFAULT_ATTACH`."""
    return ROBOT_ATTACH.get(root.get("name") or "", DEFAULT_ATTACH)


def _vec(text: str | None, default=(0.0, 0.0, 0.0)) -> np.ndarray:
    return np.array([float(x) for x in text.split()]) if text else np.array(default, dtype=float)


def _unit(v: np.ndarray) -> np.ndarray | None:
    n = np.linalg.norm(v)
    return v / n if n > 1e-9 else None


def _frame(d: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Columns: sagittal, transverse (joint axis ⟂ d), longitudinal (d)."""
    y = _unit(axis - axis @ d * d)
    if y is None:  # joint axis along the segment: any transverse direction
        y = _unit(np.cross(d, [1.0, 0, 0])) if abs(d[0]) < 0.9 else _unit(np.cross(d, [0, 1.0, 0]))
    return np.column_stack([np.cross(y, d), y, d])


def place(root: Element, pairs, *, mass: float, height: float, sex: str, source: str = "URDF") -> list[Placement]:
    """Where each (point, segment) pair goes in the URDF tree ``root`` (see the module docstring)."""
    check_person(mass, height, sex)
    links = {lk.get("name"): lk for lk in root.findall("link")}
    joints = {j.get("name"): j for j in root.findall("joint")}
    parent_joint = {j.find("child").get("link"): j for j in joints.values() if j.find("child") is not None}
    out, shank_on = [], {}
    pelvis = [p for p in pairs if p[1] == "pelvis"]
    legs = sorted((p for p in pairs if p[1] != "pelvis"), key=lambda p: LEG_SEGMENTS.index(_table_name(p[1])))
    for point, name in legs:
        seg = _table_name(name)
        if point in joints and joints[point].find("child") is not None:
            link = joints[point].find("child").get("link")
        elif point in links:
            link = point
        else:
            raise SpecError(
                f"--attach {point}:{name}: {point!r} names no joint or link of {source} "
                f"(joints: {', '.join(joints)}; links: {', '.join(links)})"
            )
        pj = parent_joint.get(link)
        mj, to_link = _moving_parent(link, parent_joint)  # a frame on a fixed joint (a sole) takes its limb's axis
        axis_el = mj.find("axis") if mj is not None else None
        axis = _unit(to_link @ _vec(axis_el.get("xyz") if axis_el is not None else None, (1.0, 0, 0)))
        axis = axis if axis is not None else np.array([1.0, 0, 0])
        children = [j for j in joints.values() if j.find("parent") is not None and j.find("parent").get("link") == link]
        d = None
        for j in children:
            o = j.find("origin")
            d = d if d is not None else _unit(_vec(o.get("xyz") if o is not None else None))
        if d is None and pj is not None and pj.find("origin") is not None:  # last link: continue the chain
            o = pj.find("origin")
            R0 = pin.rpy.rpyToMatrix(*_vec(o.get("rpy")))
            d = _unit(R0.T @ _vec(o.get("xyz")))
        if d is None:
            io = links[link].find("inertial/origin")
            d = _unit(_vec(io.get("xyz") if io is not None else None))
        d = d if d is not None else np.array([0.0, 0.0, -1.0])
        s = segment(seg, mass=mass, height=height, sex=sex)
        s = Segment(name, s.mass, s.length, s.com, s.radii, s.source)
        start = np.zeros(3)
        if seg == "foot" and link in shank_on:
            start = shank_on[link][0] * shank_on[link][1]
            forward = _unit(np.cross(axis, d))
            d = forward if forward is not None else d
        elif seg == "foot" and mj is not None and mj.find("origin") is not None:  # its own link: the ankle
            o = mj.find("origin")  # the leg's direction continued (the shank's), the foot forward of it
            leg = _unit(to_link @ pin.rpy.rpyToMatrix(*_vec(o.get("rpy"))).T @ _vec(o.get("xyz")))
            forward = None if leg is None else _unit(np.cross(axis, leg))
            d = forward if forward is not None else d
        if seg == "shank":
            shank_on[link] = (s.length, d)
        R = _frame(d, axis)
        out.append(Placement(s, link, start + s.com * d, R @ np.diag(s.inertia) @ R.T, start, R))
    for point, _ in pelvis:
        out.insert(0, _place_pelvis(root, point, out, mass=mass, height=height, sex=sex, source=source))
    return out


def _moving_parent(link: str, parent_joint: dict) -> tuple[Element | None, np.ndarray]:
    """The nearest joint above ``link`` that moves (not ``fixed``), and the rotation taking a vector in that
    joint's child frame into ``link``'s frame (the fixed joints between; identity when it is ``link``'s own)."""
    to_link, pj = np.eye(3), parent_joint.get(link)
    while pj is not None and pj.get("type") == "fixed":
        o = pj.find("origin")
        to_link = to_link @ pin.rpy.rpyToMatrix(*_vec(o.get("rpy") if o is not None else None)).T
        parent = pj.find("parent")
        pj = parent_joint.get(parent.get("link")) if parent is not None else None
    return pj, to_link


def _chain_origin(root: Element, top: str, link: str) -> np.ndarray | None:
    """Origin of ``link`` in the frame of its ancestor ``top`` at q = 0 (the joint origins composed), or None
    when ``top`` is not an ancestor."""
    parent_joint = {j.find("child").get("link"): j for j in root.findall("joint") if j.find("child") is not None}
    M = pin.SE3.Identity()
    while link != top:
        j = parent_joint.get(link)
        if j is None:
            return None
        o = j.find("origin")
        xyz, rpy = (_vec(o.get("xyz")), _vec(o.get("rpy"))) if o is not None else (np.zeros(3), np.zeros(3))
        M = pin.SE3(pin.rpy.rpyToMatrix(*rpy), xyz) * M
        link = j.find("parent").get("link")
    return M.translation


def _place_pelvis(root: Element, point: str, legs: list[Placement], *, mass, height, sex, source) -> Placement:
    """The pelvis (de Leva's lower trunk, omphalion → mid-hip) on the exo link ``point`` (the base link):
    its distal end at the midpoint of the hip joint centres — the thighs' proximal endpoints when both are
    attached below it, else the mean of the origins of the link's moving child joints — its axis along the
    link's +z (up, the URDF convention) and its transverse axis along the line between the hips (else y)."""
    links = {lk.get("name") for lk in root.findall("link")}
    joints = {j.get("name"): j for j in root.findall("joint")}
    if point in joints and joints[point].find("child") is not None:
        link = joints[point].find("child").get("link")
    elif point in links:
        link = point
    else:
        raise SpecError(
            f"--attach {point}:pelvis: {point!r} names no joint or link of {source} "
            f"(joints: {', '.join(joints)}; links: {', '.join(sorted(links))})"
        )
    thighs = [p for p in legs if _table_name(p.segment.name) == "thigh"]
    hips = [o + p.start for p in thighs if (o := _chain_origin(root, link, p.link)) is not None]
    if len(hips) < 2:
        hips = [
            _vec(j.find("origin").get("xyz") if j.find("origin") is not None else None)
            for j in joints.values()
            if j.find("parent") is not None and j.find("parent").get("link") == link and j.get("type") != "fixed"
        ] or [np.zeros(3)]
    mid = np.mean(hips, axis=0)
    across = _unit(hips[0] - hips[-1]) if len(hips) > 1 else None
    up = np.array([0.0, 0.0, 1.0])
    s = segment("pelvis", mass=mass, height=height, sex=sex)
    R = _frame(-up, across if across is not None else np.array([0.0, 1.0, 0.0]))
    start = mid + s.length * up  # the omphalion: the proximal endpoint
    return Placement(s, link, start - s.com * up, R @ np.diag(s.inertia) @ R.T, start, R)


def _num(x: float) -> str:
    return "0" if abs(x) < 1e-15 else f"{float(x):.10g}"


def wearer_urdf(
    urdf: str | os.PathLike,
    attach: str | list[tuple[str, str]] | None,
    *,
    mass: float,
    height: float,
    sex: str,
    path: str | os.PathLike | None = None,
) -> str:
    """The URDF ``urdf`` (file or robot name) with the wearer's segments fixed to it; written to ``path`` if given.

    ``attach``: ``"hip:thigh,knee:shank"`` or pairs (exo joint or link, segment: ``pelvis``, ``thigh``,
    ``shank``, ``foot``, a leg segment with its side ``l_thigh`` … ``r_foot``); None: the robot's default
    (:data:`ROBOT_ATTACH`: both legs and the pelvis on exo_lower_body; ``hip:thigh,knee:shank`` otherwise);
    ``mass`` [kg], ``height`` [m], ``sex`` ``"male"`` / ``"female"`` (de Leva 1996).  Raises SpecError on bad
    input before writing anything.
    """
    if not isinstance(urdf, (str, os.PathLike)):
        raise SpecError(f"urdf: got {type(urdf).__name__}, expected a URDF path or a bundled robot name")
    from pinid.model.bundled import resolve_robot

    from pinid.model.robot import RobotModel

    if attach is not None:
        pairs = _parse_attach(attach) if isinstance(attach, str) else check_pairs(attach)
    file, _ = resolve_robot(urdf)

    # the exoskeleton must be a URDF pinid loads (size, numbers, axes, nesting); its document is the start
    root = RobotModel.from_urdf(file).urdf_document.tree()
    if attach is None:
        pairs = _parse_attach(_default_attach(root))
    if root.find(f"link[@name='{PREFIX}thigh']") is not None or any(
        (lk.get("name") or "").startswith(PREFIX) for lk in root.findall("link")
    ):
        raise SpecError(f"{file}: already carries a wearer (links named {PREFIX}*), expected a bare exoskeleton")
    placements = place(root, pairs, mass=mass, height=height, sex=sex, source=file.name)
    root.append(
        xml_comment(
            f" pinid wearer: {sex}, {mass:g} kg, {height:g} m, de Leva 1996 (pinid/resources/anthropometry/"
            "de_leva_1996.toml); segments fixed to the exo links, proximal endpoint at the joint centre "
            "(the pelvis: distal endpoint at the mid-hip point) "
        )
    )
    for p in placements:
        s = p.segment
        name = f"{PREFIX}{s.name}"
        link = sub_element(root, "link", name=name)
        link.append(
            xml_comment(
                f" {s.source}: mass {s.mass:.4g} kg, length {s.length:.4g} m, CoM {s.com:.4g} m "
                f"from the proximal end; inertia about the CoM in the frame of '{p.link}' "
            )
        )
        link.append(inertial_element(s.mass, p.com, p.inertia, _num))
        d = p.frame[:, 2]  # the segment as a cylinder (√2·longitudinal radius of gyration): also what
        visual = sub_element(link, "visual", name="segment")  # wearer_prior reads its extent from
        sub_element(
            visual,
            "origin",
            xyz=" ".join(_num(x) for x in p.start + 0.5 * s.length * d),
            rpy=" ".join(_num(x) for x in pin.rpy.matrixToRpy(p.frame)),
        )
        sub_element(
            sub_element(visual, "geometry"), "cylinder", radius=_num(np.sqrt(2.0) * s.radii[2]), length=_num(s.length)
        )
        joint = sub_element(root, "joint", name=f"{name}_strap", type="fixed")
        sub_element(joint, "parent", link=p.link)
        sub_element(joint, "child", link=name)
        sub_element(joint, "origin", xyz="0 0 0", rpy="0 0 0")
    text = xml_text(root, '<?xml version="1.0"?>\n')
    _check_loads(text, file)
    if path is not None:
        from pinid.io import write_text

        write_text(path, text)
    return text


def _check_loads(text: str, source) -> None:
    """ModelError unless pinid loads the exo + wearer URDF ``text`` it is about to return (never write a
    URDF nothing else loads)."""
    import tempfile
    from pathlib import Path

    from pinid.errors import ModelError
    from pinid.model.robot import RobotModel

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "wearer.urdf"
        path.write_text(text, encoding="utf-8")
        try:
            RobotModel.from_urdf(path)
        except ModelError as exc:
            raise ModelError(
                f"{source}: the URDF with the wearer would not load ({str(exc).replace(str(path), 'URDF')}); "
                "not written"
            ) from None


def wearer_links(urdf_text: str) -> dict[str, tuple[str, float, np.ndarray, np.ndarray]]:
    """The wearer segments of a URDF written by :func:`wearer_urdf`:
    ``{segment: (exo link, mass [kg], CoM [m], inertia about the CoM [kg·m²])}`` in the exo link's frame."""
    if not isinstance(urdf_text, str):
        raise SpecError(
            f"urdf_text: got {type(urdf_text).__name__}, expected the text of a URDF written by pinid wearer"
        )
    document = UrdfDocument.from_text(urdf_text, "urdf_text")
    parent = {
        j.find("child").get("link"): j.find("parent").get("link")
        for j in document.joints()
        if j.find("child") is not None
    }
    out = {}
    for lk in document.links():
        name = lk.get("name") or ""
        if not name.startswith(PREFIX):
            continue
        i = lk.find("inertial")
        g = {k: float(i.find("inertia").get(k)) for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
        I = np.array([[g["ixx"], g["ixy"], g["ixz"]], [g["ixy"], g["iyy"], g["iyz"]], [g["ixz"], g["iyz"], g["izz"]]])
        out[name[len(PREFIX) :]] = (
            parent[name],
            float(i.find("mass").get("value")),
            _vec(i.find("origin").get("xyz")),
            I,
        )
    return out


def wearer_segments(urdf_text: str) -> dict[str, dict]:
    """The wearer segments of a URDF written by :func:`wearer_urdf`, to draw:
    ``{segment: {"link": exo link, "mass": [kg], "com", "start", "end": [m]}}`` in the exo link's frame
    (``start``/``end``: the segment's proximal and distal endpoints, from its cylinder)."""
    found = wearer_links(urdf_text)  # checks urdf_text
    links = {lk.get("name"): lk for lk in UrdfDocument.from_text(urdf_text, "urdf_text").links()}
    out = {}
    for seg, (link, mass, com, _) in found.items():
        lk = links[f"{PREFIX}{seg}"]
        origin, cylinder = lk.find("visual/origin"), lk.find("visual/geometry/cylinder")
        if origin is None or cylinder is None:
            raise SpecError(f"urdf_text: link {PREFIX}{seg} has no <visual> cylinder, expected pinid wearer's")
        centre = _vec(origin.get("xyz"))
        axis = pin.rpy.rpyToMatrix(_vec(origin.get("rpy")))[:, 2]
        half = 0.5 * float(cylinder.get("length")) * axis
        out[seg] = {"link": link, "mass": mass, "com": com, "start": centre - half, "end": centre + half}
    return out


def attachment_png(urdf_text: str) -> bytes:
    """A PNG of where the wearer's segments of ``urdf_text`` (a URDF of :func:`wearer_urdf`) attach: the
    robot in its zero pose, each segment, its exo link frame and its CoM
    (:func:`pinid.report.plot_wearer.attachment_figure`)."""
    from pinid.report.figures import figure_png
    from pinid.report.plot_wearer import attachment_figure

    segments = wearer_segments(urdf_text)  # checks urdf_text
    name = UrdfDocument.from_text(urdf_text, "urdf_text").name
    title = f"{name} + wearer: where the segments attach (zero pose)"
    return figure_png(attachment_figure(urdf_text, segments, title=title))
