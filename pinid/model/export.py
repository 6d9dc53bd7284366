"""The identified URDF: the input URDF with its ``<inertial>`` and ``<dynamics>`` tags replaced.

Frames.  Pinocchio's body frame of an active joint is the joint frame, which in a URDF is the frame
of the joint's child link.  The identified standard parameters of body ``i`` (mass, first moments
``m·c`` and inertia about that frame) become the child link's ``<inertial>``: ``<origin xyz="c"
rpy="0 0 0"/>``, ``<mass>`` and the inertia about the centre of mass (``I_c = I − m·(|c|²·1 − c·cᵀ)``).

Merged links.  Pinocchio merges into one body a moving link and every link attached below it by
fixed joints or by joints held *locked* during identification; the data only see their sum.  The
export puts that whole identified inertia on the moving link and removes the ``<inertial>`` of the
merged links (a comment in each says so), so that the file loads back to exactly the identified
model.  The export is therefore valid for the locked configuration used in identification; links
fixed to the world are left as they are (they do not move).

Joint terms.  Coulomb (``fc``) and viscous (``fv``) friction go to ``<dynamics friction=… damping=…/>``
of each active joint when they are in the model (otherwise the URDF's values stay, marked "not identified
(URDF value kept)", and the MJCF export carries the same values: :func:`pinid.model.terms.kept_friction`).  Armature and
a constant offset have no URDF field: they are written as a comment in the joint element (and kept in
the JSON outputs).

A physically inconsistent set is refused unless ``force=True``.  Comments of the input are kept.

A floating base (:func:`floating_urdf`): the base link's ``<inertial>`` is the identified ``base.*`` body too.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

from pinid.errors import ModelError
from pinid.checks import as_floats, number as finite_number
from pinid.model.floating import FloatingRobotModel, as_floating, free_flyer_terms
from pinid.model.regressor import parameter_names
from pinid.model.robot import RobotModel, as_robot
from pinid.model.base import marks_summary
from pinid.model.physical import check_consistency, com_inertia, tidy_inertial
from pinid.model.robot import INERTIAL_NAMES
from pinid.model import terms as _terms
from pinid.model.terms import TermSelection
from pinid.io import write_text
from pinid.model.urdf import Element, xml_comment, new_element, sub_element, xml_text


def _num(x: float) -> str:
    x = float(x)
    return "0" if x == 0 else f"{x:.17g}"


def _link_owners(root: Element, active: list[str]) -> tuple[dict[str, str | None], dict[str, str]]:
    """For every link, the active joint whose body it is merged into (None: fixed to the world);
    and for every active joint, its child link."""
    parent_joint = {}
    child_of = {}
    for j in root.findall("joint"):
        child, parent = j.find("child"), j.find("parent")
        if child is None or parent is None:
            continue
        parent_joint[child.get("link")] = j
        if j.get("name") in active:
            child_of[j.get("name")] = child.get("link")
    owners = {}
    for link in root.findall("link"):
        name = link.get("name")
        owner, cur, seen = None, name, set()
        while cur in parent_joint and cur not in seen:
            seen.add(cur)
            j = parent_joint[cur]
            if j.get("name") in active:
                owner = j.get("name")
                break
            cur = j.find("parent").get("link")
        owners[name] = owner
    return owners, child_of


def identified_urdf(
    model: RobotModel,
    theta: np.ndarray,
    terms: TermSelection,
    path: str | os.PathLike | None = None,
    *,
    force: bool = False,
    comment: str | None = None,
    origin: str = "identified by pinid",
    marks: dict[str, str] | None = None,
) -> str:
    """The URDF text of ``model`` with the standard parameters ``theta`` (see the module text).

    Written atomically to ``path`` when given.  The file's first comment reads ``origin (comment)``.  Raises
    ModelError for an inconsistent set unless ``force``, or when the model has no URDF text.
    """
    root = identified_urdf_tree(model, theta, terms, force=force, comment=comment, origin=origin, marks=marks)
    text = xml_text(root, '<?xml version="1.0" encoding="utf-8"?>\n')
    if not force:
        _check_loads(text, model)
    if path is not None:
        write_text(path, text)
    return text


def identified_urdf_tree(
    model: RobotModel,
    theta: np.ndarray,
    terms: TermSelection,
    *,
    force: bool = False,
    comment: str | None = None,
    origin: str = "identified by pinid",
    marks: dict[str, str] | None = None,
) -> Element:
    """The element tree of :func:`identified_urdf` (the model's URDF document edited), for a writer that
    edits it further (:func:`floating_urdf`); not yet checked to load back.
    ``marks``: ``{standard name: mark}`` (:meth:`pinid.model.base.BaseParameters.marks`), written as a
    comment beside each inertial and joint's friction."""
    model = as_robot(model)
    theta = np.asarray(theta, dtype=float)
    nv, nt = model.nv, _terms.term_count(model, terms)
    if theta.shape != (10 * nv + nt,):
        raise ModelError(f"expected {10 * nv + nt} standard parameters, got {theta.size}")
    report = check_consistency(theta, model.joint_names, terms.names, model.motor_names)
    if not report.consistent and not force:
        raise ModelError(
            "refusing to export physically inconsistent parameters ("
            + "; ".join(report.problems[:3])
            + "); force the export to write them anyway"
        )
    if not model.urdf_text:
        raise ModelError(f"{model.name}: no URDF text to edit")
    root = model.urdf_document.tree()
    active = model.joint_names
    owners, child_of = _link_owners(root, active)
    links = {link.get("name"): link for link in root.findall("link")}
    joints = {j.get("name"): j for j in root.findall("joint")}
    missing = [j for j in active if j not in child_of]
    if missing:
        raise ModelError(f"{model.name}: joint(s) {missing} not found in the URDF text")
    for i, jname in enumerate(active):
        link = links[child_of[jname]]
        m, c, I = tidy_inertial(*com_inertia(theta[10 * i : 10 * i + 10]))
        _set_inertial(link, m, c, I)
        note = marks_summary(marks, [f"{jname}.{n}" for n in INERTIAL_NAMES])
        if note:
            link.insert(
                0, xml_comment(f" pinid, from these data (standard parameters m, m·c, I about the joint): {note} ")
            )
        merged = sorted(n for n, o in owners.items() if o == jname and n != child_of[jname])
        if merged:
            link.insert(
                0,
                xml_comment(
                    f" pinid: identified inertia of body '{jname}', including merged link(s) {', '.join(merged)} "
                ),
            )
    for name, link in links.items():
        owner = owners.get(name)
        if owner is None or name == child_of.get(owner):
            continue
        for el in link.findall("inertial"):
            link.remove(el)
        link.insert(0, xml_comment(f" pinid: inertial removed; it is part of the identified body of joint '{owner}' "))
    params = _terms.robot_layout(model, terms)
    kept = _terms.kept_friction(model, terms)
    for i, jname in enumerate(active):
        jel = joints[jname]
        mine = [(p.term, theta[10 * nv + k]) for k, p in enumerate(params) if p.term.space == "joint" and p.index == i]
        fields = [(t, v) for t, v in mine if t.field]
        if fields:
            dyn = jel.find("dynamics")
            if dyn is None:
                dyn = sub_element(jel, "dynamics")
            for t, v in sorted(fields, key=lambda tv: tv[0].field):
                dyn.set(t.field, _num(v))
        extra = [f"{t.suffix} {_num(v)} {t.unit}" for t, v in mine if not t.field]
        if extra:
            jel.append(xml_comment(f" pinid: {', '.join(extra)} (no URDF field) "))
        note = marks_summary(marks, [f"{jname}.{t.suffix}" for t, _ in mine])
        if note:
            jel.append(xml_comment(f" pinid, from these data: {note} "))
        if jname in kept:
            jel.append(xml_comment(f" pinid: {kept_friction_text(kept[jname], 'friction', 'damping')} "))
    head = (
        f" {origin}{' (' + comment + ')' if comment else ''}: {friction_summary(terms, kept, 'friction', 'damping')}"
        f"; physically consistent: {'yes' if report.consistent else 'NO (forced)'}"
        + (f"; locked joints: {', '.join(f'{k}={v:g}' for k, v in model.locked.items())}" if model.locked else "")
        + " "
    )
    root.insert(0, xml_comment(head))
    return root


def _check_kept(kept, coulomb, viscous) -> None:
    """ModelError unless ``kept`` is ``{"fc" | "fv": number}`` and the field names are text."""
    if not isinstance(coulomb, str) or not isinstance(viscous, str):
        raise ModelError("coulomb, viscous: expected the file's field names (text), e.g. 'friction', 'damping'")
    if not isinstance(kept, Mapping) or not all(
        k in ("fc", "fv") and isinstance(v, (int, float)) and not isinstance(v, bool) for k, v in kept.items()
    ):
        raise ModelError(f"kept: got {type(kept).__name__}, expected {{'fc' or 'fv': value}} of one joint")


def kept_friction_text(kept: dict[str, float], coulomb: str, viscous: str) -> str:
    """``"friction 1.2, damping 0.8: not identified (URDF value kept)"`` for one joint's :func:`kept_friction`
    values, with the file's own field names (URDF ``friction``/``damping``, MJCF ``frictionloss``/``damping``)."""
    _check_kept(kept, coulomb, viscous)
    fields = {"fc": coulomb, "fv": viscous}
    values = ", ".join(f"{fields[k]} {_num(v) if len(_num(v)) < 12 else f'{v:.6g}'}" for k, v in kept.items())
    return f"{values}: not identified (URDF value kept; no {', '.join(kept)} term in this identification)"


def friction_summary(terms: TermSelection, kept: dict, coulomb: str, viscous: str, *, no_field: bool = True) -> str:
    """What the file's first comment says of the inertials and the joint friction: replaced, or the URDF's
    values kept (:func:`pinid.model.terms.kept_friction`), and the friction terms that have no field."""
    terms = _terms.as_terms(terms)
    if not isinstance(kept, Mapping):
        raise ModelError(f"kept: got {type(kept).__name__}, expected {{joint: {{term: value}}}} (kept_friction)")
    for values in kept.values():
        _check_kept(values, coulomb, viscous)
    replaced = [f for t, f in (("fc", coulomb), ("fv", viscous)) if t in terms]
    kept_names = sorted({f for values in kept.values() for f in ({"fc": coulomb, "fv": viscous}[k] for k in values)})
    out = "inertials of the moving links" + (f" and joint {', '.join(replaced)}" if replaced else "") + " replaced"
    if kept_names:
        out += f"; joint {', '.join(kept_names)}: the URDF's values kept, not identified (see each joint)"
    nofield = [t.name for t in terms.joint if not t.field]
    if nofield and no_field:
        out += f"; identified terms with no URDF field (a comment in each joint): {', '.join(nofield)}"
    return out


def _check_loads(text: str, model: RobotModel) -> None:
    """ModelError unless pinid reads ``text`` back as a model of the same joints (a URDF pinid wrote but
    cannot load — a mass of −1e-12 kg — is never written)."""
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "identified.urdf"
        path.write_text(text, encoding="utf-8")
        try:
            RobotModel.from_urdf(path, joints=model.joint_names, locked=model.locked or None)
        except ModelError as exc:
            raise ModelError(
                f"the identified URDF would not load back in pinid ({str(exc).replace(str(path), 'URDF')}); not written"
            ) from None


def _set_inertial(link: Element, m: float, c: np.ndarray, I: np.ndarray) -> None:
    for el in link.findall("inertial"):
        link.remove(el)
    link.insert(0, inertial_element(m, c, I))


def inertial_element(mass: float, com, inertia, number=_num) -> Element:
    """A URDF ``<inertial>``: ``mass`` [kg], ``com`` (3,) [m] in the link frame, ``inertia`` (3, 3) [kg·m²]
    about the centre of mass in link axes; ``number`` formats each value (default: all 17 digits)."""
    mass = finite_number(mass, "mass")
    I = np.asarray(inertia, dtype=float)
    inertial = new_element("inertial")
    sub_element(inertial, "origin", xyz=" ".join(number(x) for x in com), rpy="0 0 0")
    sub_element(inertial, "mass", value=number(mass))
    sub_element(
        inertial,
        "inertia",
        ixx=number(I[0, 0]),
        ixy=number(I[0, 1]),
        ixz=number(I[0, 2]),
        iyy=number(I[1, 1]),
        iyz=number(I[1, 2]),
        izz=number(I[2, 2]),
    )
    return inertial


def identified_drives(
    model: RobotModel,
    theta: np.ndarray,
    terms: TermSelection,
    path: str | os.PathLike | None = None,
    *,
    comment: str | None = None,
) -> str | None:
    """The drives TOML of ``model`` with the motor-term values of the standard parameters ``theta``
    (``[motors.<name>]`` fc, fv, offset, armature; URDF has no field for them); None without motor terms.
    Written atomically to ``path`` when given.  Read it back with ``--drives``."""
    model = as_robot(model)
    if not terms.motor or model.drives is None:
        return None
    theta = np.asarray(theta, dtype=float)
    values = _terms.values(model, terms, theta[10 * model.nv :])
    lines = [
        f"# drives identified by pinid{' (' + comment + ')' if comment else ''}: q_motor = matrix · q_joint; "
        "motor terms in SI units (N·m, N·m·s/rad, kg·m²)"
    ]
    for t in model.drives.transmissions:
        lines += [
            "",
            "[[transmission]]",
            f"joints = [{', '.join(_q(j) for j in t.joints)}]",
            f"motors = [{', '.join(_q(m) for m in t.motors)}]",
            "matrix = [" + ", ".join("[" + ", ".join(_num(x) for x in row) + "]" for row in t.matrix) + "]",
        ]
    for i, m in enumerate(model.motor_names):
        lines += ["", f"[motors.{_q(m)}]"] + [f"{t.suffix} = {_num(values[t.name][i])}" for t in terms.motor]
    text = "\n".join(lines) + "\n"
    if path is not None:
        from pinid.io import write_text

        write_text(path, text)
    return text


def _q(name: str) -> str:
    """``name`` as a TOML basic string: backslash and quote escaped, control characters as ``\\uXXXX``."""
    out = []
    for c in name:
        if c in '"\\':
            out.append("\\" + c)
        elif ord(c) < 0x20 or ord(c) == 0x7F:
            out.append(f"\\u{ord(c):04X}")
        else:
            out.append(c)
    return '"' + "".join(out) + '"'


def floating_urdf(
    model: FloatingRobotModel,
    theta: np.ndarray,
    terms: TermSelection = TermSelection(),
    path=None,
    *,
    force: bool = False,
    comment: str | None = None,
    marks: dict[str, str] | None = None,
) -> str:
    """The URDF text of ``model`` with the floating standard parameters ``theta`` (base link first, as
    :func:`~pinid.model.regressor.parameter_names`): the joints' bodies and friction as
    :func:`pinid.model.export.identified_urdf` writes them, and the base link's ``<inertial>`` from ``theta[:10]``
    (the links welded to it — fixed joints, locked joints — lose theirs: they are part of that body).  ModelError
    for a physically inconsistent set unless ``force``.  Written atomically to ``path`` when given."""
    model = as_floating(model)
    terms = free_flyer_terms(model, terms)
    theta = as_floats(theta, "theta").reshape(-1)
    names = parameter_names(model, terms)
    if theta.shape != (len(names),):
        raise ModelError(f"expected {len(names)} floating standard parameters, got {theta.size}")
    report = check_consistency(theta, model.body_names, terms.names, [])
    if not report.consistent and not force:
        raise ModelError(
            "refusing to export physically inconsistent parameters (" + "; ".join(report.problems[:3]) + ")"
        )
    k = len(terms.joint)
    fixed = np.r_[theta[10 : 10 * (model.nv + 1)], theta[10 * (model.nv + 1) + k :]]
    root = identified_urdf_tree(
        model, fixed, terms, force=True, comment=comment, origin="identified by pinid (floating base)", marks=marks
    )
    links = {link.get("name"): link for link in root.findall("link")}
    welded, changed = {model.base_link}, True
    while changed:  # links reached from the base link through joints that are not active
        changed = False
        for j in root.findall("joint"):
            parent, child = j.find("parent").get("link"), j.find("child").get("link")
            if parent in welded and child not in welded and j.get("name") not in model.joint_names:
                welded.add(child)
                changed = True
    for name in welded:
        for el in links[name].findall("inertial"):
            links[name].remove(el)
    m, c, I = tidy_inertial(*com_inertia(theta[:10]))
    links[model.base_link].insert(0, inertial_element(m, c, I))
    note = marks_summary(marks, [f"base.{n}" for n in INERTIAL_NAMES])
    if note:
        links[model.base_link].insert(
            0, xml_comment(f" pinid, from these data (standard parameters m, m·c, I about the base frame): {note} ")
        )
    links[model.base_link].insert(
        0,
        xml_comment(
            f" pinid: identified inertia of the floating base, links welded to it: {', '.join(sorted(welded))} "
        ),
    )
    out = xml_text(root, '<?xml version="1.0" encoding="utf-8"?>\n')
    if path is not None:
        write_text(path, out)
    return out
