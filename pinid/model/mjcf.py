"""The identified model as MuJoCo MJCF: where controllers are trained (see docs/mujoco.md).

The file describes the Pinocchio model pinid identified, body for body: one MJCF ``<body>`` per moving
Pinocchio body (a moving link with every link fixed or locked below it, as in the identified URDF), placed
at its joint frame relative to the parent body (``pos``, ``quat`` w x y z), with

* ``<inertial>``: the identified mass, the centre of mass ``c = h/m`` and the inertia about the centre of
  mass (``I_c = I − m·(|c|²·1 − c·cᵀ)``, pinid's standard parameters being about the *joint* frame), as
  principal moments (``diaginertia``) and the principal axes (``quat``): MuJoCo's ``fullinertia`` wants
  strictly positive eigenvalues and its own eigen-decomposition adds rounding;
* a ``hinge`` or ``slide`` joint along the Pinocchio joint's axis, with ``range`` from the URDF limits
  (continuous joints: none), ``armature`` (rotor inertia), ``damping`` (viscous friction ``fv``) and
  ``frictionloss`` (Coulomb friction ``fc``) — without an ``fc``/``fv`` term the URDF's ``<dynamics>`` value,
  as the identified URDF keeps it, marked "not identified (URDF value kept)" in both; motor-side terms of drives whose ``G`` has one joint per
  motor are reflected (``G²·Im``, ``G²·fv``, ``|G|·fc``);
* the URDF's box, cylinder and sphere ``<collision>`` shapes as geoms (contacts; MuJoCo never collides a
  body with its parent), its ``<visual>`` ones for display only (``contype="0" conaffinity="0"``,
  ``group="1"``); a body with neither gets a thin display capsule to its children.  Meshes are not exported.
* one ``<motor>`` per joint (gear 1: the control is the joint torque [N·m]), ``ctrlrange`` ± the URDF
  effort limit when there is one.

A fixed base is the URDF's root link as a body without joint (welded to the world); ``floating=True``
gives the root link a ``<freejoint/>`` and its inertia (with every link fixed to it) from the URDF, or, for
the standard parameters of a floating identification (:mod:`pinid.model.floating`: ``base.m`` … first, then
the joints' bodies, the terms per body with the base's first), the identified base-link inertia ``base.*``
(a free joint then always).
Constant offsets, asymmetric or Stribeck friction, passive moments and coupled drives have no MJCF
field: they are listed in the file's first comment (``not exported``) and not written.

MuJoCo needs every moving body's mass and principal moments to be positive and the moments to satisfy
the triangle inequality; a physically inconsistent set, or a degenerate one (a massless body, a zero
principal moment), is refused with a :class:`~pinid.errors.ModelError` naming the body.
"""

from __future__ import annotations

import os

import numpy as np
import pinocchio as pin

from pinid.checks import as_floats
from pinid.errors import DataError, ModelError
from pinid.io import write_text
from pinid.model import terms as _terms
from pinid.model.base import marks_summary
from pinid.model.export import friction_summary, kept_friction_text
from pinid.model.physical import NOISE, check_consistency, com_inertia, nonnegative_within_tolerance, tidy_inertial
from pinid.model.terms import TermSelection
from pinid.model.robot import INERTIAL_NAMES, MAX_BODY_MASS, RobotModel, as_robot
from pinid.model.terms import as_terms
from pinid.model.urdf import Element, UrdfDocument, is_element, new_element, sub_element, xml_comment, xml_text

#: Smallest mass [kg] and principal moment [kg·m²] written; MuJoCo refuses moving bodies below its mjMINVAL (1e-15).
MIN_VALUE = 1e-12
#: Terms written to MJCF joint fields: term name → (MJCF attribute, how a motor value reflects through |G|).
_FIELDS = {"armature": ("armature", 2), "fv": ("damping", 2), "fc": ("frictionloss", 1)}
#: Radius [m] of the display capsules of bodies without collision shapes.
CAPSULE_RADIUS = 0.02


def _num(x: float) -> str:
    """The shortest text that reads back as exactly ``x``."""
    x = float(x)
    return "0" if x == 0 else repr(x)


def _vec(v) -> str:
    return " ".join(_num(x) for x in v)


def _quat(R: np.ndarray) -> np.ndarray:
    """MuJoCo's quaternion (w, x, y, z) of a rotation matrix."""
    x, y, z, w = pin.Quaternion(np.asarray(R, dtype=float)).coeffs()
    return np.array([w, x, y, z])


def _placement(el: Element, M: pin.SE3) -> None:
    if np.any(M.translation != 0):
        el.set("pos", _vec(M.translation))
    if not np.allclose(M.rotation, np.eye(3), rtol=0, atol=0):
        el.set("quat", _vec(_quat(M.rotation)))


def exported_pin_model(model: RobotModel, theta: np.ndarray, *, floating: bool = False) -> pin.Model:
    """The Pinocchio model the MJCF of :func:`identified_mjcf` describes: ``model``'s joints with the inertial
    parameters ``theta[:10·nv]`` (about the joint frames); with ``floating`` a free-flyer root (Pinocchio's
    convention: base velocity in the base frame) whose body is the URDF's root link and every link fixed to it.
    Armature, damping and friction of the returned model are zero."""
    model, theta = as_robot(model), as_floats(theta, "theta")
    if theta.ndim != 1 or theta.size < 10 * model.nv:
        raise ModelError(f"theta: shape {theta.shape}, expected at least {10 * model.nv} standard parameters")
    if not floating or any(j.nv == 6 for j in model.pin_model.joints):
        pm = pin.Model(model.pin_model)
    else:
        if not model.urdf_text:
            raise ModelError(f"{model.name}: no URDF text to build a floating base from")
        full = pin.buildModelFromXML(model.urdf_text, pin.JointModelFreeFlyer())
        q_ref = pin.neutral(full)
        lock = []
        for name, value in model.locked.items():
            jid = full.getJointId(name)
            j = full.joints[jid]
            if j.nq == 2:  # continuous: cos, sin
                q_ref[j.idx_q : j.idx_q + 2] = np.cos(value), np.sin(value)
            else:
                q_ref[j.idx_q] = value
            lock.append(jid)
        pm = pin.buildReducedModel(full, lock, q_ref) if lock else full
    for i, name in enumerate(model.joint_names):
        pm.inertias[pm.getJointId(name)] = pin.Inertia.FromDynamicParameters(theta[10 * i : 10 * i + 10])
    pm.armature[:] = 0.0
    pm.damping[:] = 0.0
    pm.friction[:] = 0.0
    return pm


def joint_fields(model: RobotModel, theta: np.ndarray, terms: TermSelection) -> tuple[dict[str, np.ndarray], list[str]]:
    """The MJCF joint fields ``{"armature" [kg·m²], "damping" [N·m·s/rad], "frictionloss" [N·m]: (nv,)}`` of the
    term block of ``theta``, and the non-zero identified terms that have no MJCF field (``"hip.offset = 0.3 N·m"``)."""
    model, terms, theta = as_robot(model), as_terms(terms), as_floats(theta, "theta")
    size = 10 * model.nv + _terms.term_count(model, terms)
    if theta.shape != (size,):
        raise DataError(
            f"theta: shape {theta.shape}, expected ({size},) standard parameters of {model.name} with these terms"
        )
    values = _terms.values(model, terms, theta[10 * model.nv :])
    out = {attr: np.zeros(model.nv) for attr, _ in _FIELDS.values()}
    lost = []
    G = model.drives.matrix if model.drives is not None else None
    for t in terms.joint + terms.motor:
        v = values[t.name]
        names = model.joint_names if t.space == "joint" else model.motor_names
        base = t.name if t.space == "joint" else t.name.removeprefix("motor_")
        if base not in _FIELDS:
            lost += [f"{n}.{t.suffix} = {x:.6g} {t.unit}" for n, x in zip(names, v) if x != 0]
            continue
        attr, power = _FIELDS[base]
        if t.space == "joint":
            out[attr] += v
            continue
        for m, row in enumerate(G):
            nz = np.flatnonzero(row)
            if len(nz) == 1:
                out[attr][nz[0]] += np.abs(row[nz[0]]) ** power * v[m]
            elif v[m] != 0:
                lost.append(f"{names[m]}.{t.suffix} = {v[m]:.6g} {t.unit} (motor coupled to several joints)")
    return out, lost


def _mujoco_inertia(name: str, m: float, I: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Principal moments (3,) and axes (3, 3) of ``I`` [kg·m²] about the centre of mass as MuJoCo accepts them;
    ModelError for a mass or moment MuJoCo refuses."""
    e, V = np.linalg.eigh(0.5 * (I + I.T))
    if np.linalg.det(V) < 0:
        V[:, 2] = -V[:, 2]
    if not np.isfinite(m) or m > MAX_BODY_MASS:
        raise ModelError(
            f"the body of joint '{name}' has mass {m:.3g} kg; expected 0 to {MAX_BODY_MASS:.0e} kg; MJCF not written"
        )
    if m > MIN_VALUE and e[0] <= MIN_VALUE and nonnegative_within_tolerance(e[0], max(abs(e).max(), m)):
        # a body the consistency check accepts (a rounding-size negative moment, or a point mass): MuJoCo
        # needs moments above MIN_VALUE, so they are raised to it (a change of at most RTOL of the body's scale)
        e = np.maximum(e, MIN_VALUE)
    if not m > MIN_VALUE or not e[0] >= MIN_VALUE:
        what = (
            f"mass {m:.3g} kg" if not m > MIN_VALUE else f"principal moments {e[0]:.3g}, {e[1]:.3g}, {e[2]:.3g} kg·m²"
        )
        raise ModelError(
            f"the body of joint '{name}' has {what}; MuJoCo needs every moving body's mass and principal "
            f"moments of inertia above {MIN_VALUE:g} (identify with a margin, e.g. the SDP's); MJCF not written"
        )
    # the consistency check allows a rounding-size excess over the triangle inequality; MuJoCo allows none
    e[2] = min(e[2], e[0] + e[1])
    return e, V


def _urdf_links(document: UrdfDocument) -> tuple[dict[str, Element], dict[str, str], str]:
    """The URDF's links by name, the child link of every joint, and the root link."""
    links = {link.get("name"): link for link in document.links()}
    child = document.child_links()
    roots = [n for n in links if n not in set(child.values())]
    return links, child, (roots[0] if roots else next(iter(links)))


def _origin(el: Element | None) -> pin.SE3:
    if el is None:
        return pin.SE3.Identity()
    xyz = np.array([float(x) for x in (el.get("xyz") or "0 0 0").split()])
    rpy = [float(x) for x in (el.get("rpy") or "0 0 0").split()]
    return pin.SE3(pin.rpy.rpyToMatrix(*rpy), xyz)


#: Attributes of the geoms that are for display only (no contact, MuJoCo's group 1).
_DISPLAY = {"contype": "0", "conaffinity": "0", "group": "1", "rgba": "0.6 0.6 0.6 1"}


def _shape_geoms(link: Element, M_link: pin.SE3, prefix: str, kind: str = "collision") -> list[Element]:
    """MJCF geoms of a URDF link's box, cylinder and sphere shapes of ``kind`` ("collision": they collide;
    "visual": display only); ``M_link``: the link frame in the body."""
    out = []
    for k, col in enumerate(link.findall(kind)):
        geom = col.find("geometry")
        shape = None if geom is None else next(filter(is_element, geom), None)
        if shape is None or shape.tag not in ("box", "cylinder", "sphere"):
            continue
        try:
            if shape.tag == "box":
                size = [0.5 * float(x) for x in shape.get("size").split()]
            elif shape.tag == "cylinder":
                size = [float(shape.get("radius")), 0.5 * float(shape.get("length"))]
            else:
                size = [float(shape.get("radius"))]
        except (TypeError, ValueError, AttributeError):
            continue  # urdfdom checked what Pinocchio needs; a shape MuJoCo cannot use is left out
        if not all(np.isfinite(size)) or min(size) <= 0:
            continue
        el = new_element("geom", name=f"{prefix}_{kind}_{k}", type=shape.tag, size=_vec(size))
        if kind == "visual":
            el.attrib.update(_DISPLAY)
        _placement(el, M_link * _origin(col.find("origin")))
        out.append(el)
    return out


def identified_mjcf(
    model: RobotModel,
    theta: np.ndarray,
    terms: TermSelection,
    path: str | os.PathLike | None = None,
    *,
    floating: bool = False,
    comment: str | None = None,
    origin: str = "identified by pinid",
    marks: dict[str, str] | None = None,
) -> str:
    """The MJCF text of ``model`` with the standard parameters ``theta`` (see the module text).

    ``floating``: a free joint on the root link (default: the root link welded to the world).  Written
    atomically to ``path`` when given.  ModelError for a physically inconsistent set, a body MuJoCo refuses
    (massless, a zero principal moment) or a model without URDF text; nothing is written then.
    ``marks``: ``{standard name: mark}`` (:meth:`pinid.model.base.BaseParameters.marks`), written as a comment
    beside each identified body's inertial and each joint (which values the data determined).
    """
    model, terms, theta = as_robot(model), as_terms(terms), as_floats(theta, "theta", finite=False)
    nv, nt = model.nv, _terms.term_count(model, terms)
    base_theta, full = None, theta
    if getattr(model, "base", "fixed") == "floating" and theta.shape == (10 * (nv + 1) + len(terms.joint) * (nv + 1),):
        # a floating identification: the base link's 10 parameters first, the terms per body (base first)
        base_theta, theta, floating = theta[:10], _fixed_part(theta, nv, len(terms.joint)), True
    if theta.shape != (10 * nv + nt,):
        raise ModelError(f"expected {10 * nv + nt} standard parameters, got {full.size}")
    if not np.all(np.isfinite(full)):
        raise ModelError("identified parameters contain NaN or infinite values; MJCF not written")
    if base_theta is None:
        report = check_consistency(theta, model.joint_names, terms.names, model.motor_names)
    else:
        report = check_consistency(full, model.body_names, terms.names, [])
    if not report.consistent:
        raise ModelError(
            "refusing to export physically inconsistent parameters to MJCF ("
            + "; ".join(report.problems[:3])
            + "); MuJoCo needs positive masses and inertias: export a physically consistent method (sdp)"
        )
    if not model.urdf_text:
        raise ModelError(f"{model.name}: no URDF text to export")
    pm = exported_pin_model(model, theta, floating=floating)
    if base_theta is not None:  # the identified base link, with every link welded to it
        pm.inertias[1] = pin.Inertia.FromDynamicParameters(base_theta)
    fields, lost = joint_fields(model, theta, terms)
    kept = _terms.kept_friction(model, terms)  # the URDF's friction where no fc/fv was identified: as the URDF export
    for jname, values in kept.items():
        i = model.joint_names.index(jname)
        fields["frictionloss"][i] += values.get("fc", 0.0)
        fields["damping"][i] += values.get("fv", 0.0)
    links, child_link, root_link = _urdf_links(model.urdf_document)
    active = {name: i for i, name in enumerate(model.joint_names)}

    mj = new_element("mujoco", model=model.name)
    head = (
        f" {origin}{' (' + comment + ')' if comment else ''} from {model.name}: "
        f"{friction_summary(terms, kept, 'frictionloss', 'damping', no_field=False)}; armature (rotor inertia) "
        "where identified; "
        f"damping is viscous friction, frictionloss Coulomb friction; base {'floating (free joint)' if floating else 'fixed'}"
        + (f"; locked joints: {', '.join(f'{k}={v:g}' for k, v in model.locked.items())}" if model.locked else "")
        + f"; not exported: {'; '.join(lost) if lost else 'nothing'} "
    )
    mj.append(xml_comment(head))
    sub_element(mj, "compiler", angle="radian", inertiafromgeom="false", autolimits="true")
    sub_element(mj, "option", gravity=_vec(pm.gravity.linear))
    world = sub_element(mj, "worldbody")
    bodies: dict[int, Element] = {}
    names: dict[int, str] = {}
    pdata = pm.createData()
    pin.computeJointJacobians(pm, pdata, pin.neutral(pm))  # each joint's motion subspace: its axis

    def link_name(jid: int) -> str:
        if pm.joints[jid].nv == 6 or jid == 0:
            return root_link
        return child_link.get(pm.names[jid], pm.names[jid])

    # the bodies written: with a free joint, the root link is joint 1's body and the universe (0) has none, so
    # the root link's name is counted once (it was twice: the floating root body came out as "pelvis_1")
    ids = [j for j in range(pm.njoints) if not (floating and j == 0)]
    unique = dict(zip(ids, _unique_body_names([link_name(j) for j in ids], set(links))))

    def body_name(jid: int) -> str:
        return unique[jid]

    if not floating:  # the root link (and what is fixed to it), welded to the world
        bodies[0] = sub_element(world, "body", name=body_name(0))
        names[0] = body_name(0)
    for jid in range(1, pm.njoints):
        parent = bodies.get(pm.parents[jid], world)
        body = sub_element(parent, "body", name=body_name(jid))
        bodies[jid], names[jid] = body, body_name(jid)
        _placement(body, pm.jointPlacements[jid])
        jm = pm.joints[jid]
        jname = pm.names[jid]
        if jm.nv == 6:
            sub_element(body, "freejoint", name=jname)
        else:
            _joint(body, pm, pdata, jid, model, active[jname], fields)
        inertia = pm.inertias[jid]
        prefix = None
        if jname in active:  # the identified values, about the centre of mass
            m, c, I = tidy_inertial(*com_inertia(theta[10 * active[jname] : 10 * active[jname] + 10]))
            prefix = jname
        elif jm.nv == 6 and base_theta is not None:
            m, c, I = tidy_inertial(*com_inertia(base_theta))
            prefix = "base"
        else:
            m, c, I = inertia.mass, inertia.lever, inertia.inertia
        e, V = _mujoco_inertia(jname, m, I)
        note = marks_summary(marks, [f"{prefix}.{n}" for n in INERTIAL_NAMES]) if prefix else ""
        if note:
            body.append(
                xml_comment(f" pinid, from these data (standard parameters m, m·c, I about the joint): {note} ")
            )
        quat = _quat(V)
        quat[np.abs(quat) < NOISE] = 0.0  # round-off of the eigenvectors, not a rotation
        sub_element(body, "inertial", pos=_vec(c), quat=_vec(quat + 0.0), mass=_num(m), diaginertia=_vec(e))
        if jname in active and marks:
            own = [n for n in marks if n.split(".", 1)[0] == jname and n.split(".", 1)[-1] not in INERTIAL_NAMES]
            note = marks_summary(marks, own)
            if note:
                body.append(xml_comment(f" pinid, joint '{jname}' terms from these data: {note} "))
        if jname in kept:
            body.append(
                xml_comment(f" pinid, joint '{jname}': {kept_friction_text(kept[jname], 'frictionloss', 'damping')} ")
            )
    _geoms(pm, links, bodies, names)
    act = sub_element(mj, "actuator")
    for j in model.joints:
        el = sub_element(act, "motor", name=j.name, joint=j.name, gear="1")
        if np.isfinite(j.effort):
            el.set("ctrlrange", f"{_num(-j.effort)} {_num(j.effort)}")
    text = xml_text(mj)
    if path is not None:
        write_text(path, text)
    return text


def _unique_body_names(names: list[str], taken: set[str]) -> list[str]:
    """Body names MuJoCo accepts: "world" (MuJoCo's own world body) becomes "world_link", and a name another
    body or URDF link (``taken``) already has gets a suffix ``_1``, ``_2``, …"""
    used = set(taken) - {"world"}
    out = []
    for n in names:
        if n != "world" and n not in out:
            out.append(n)
            continue
        stem = "world_link" if n == "world" else n
        cand, k = stem, 0
        while cand in used or cand in out or cand == "world":
            k += 1
            cand = f"{stem}_{k}"
        out.append(cand)
    return out


def _fixed_part(theta: np.ndarray, nv: int, k: int) -> np.ndarray:
    """The fixed-base layout (joint bodies, then joint terms) of a floating standard parameter vector
    (``base.*`` first, ``k`` terms per body with the base's first)."""
    return np.r_[theta[10 : 10 * (nv + 1)], theta[10 * (nv + 1) + k :]]


def _joint(body: Element, pm: pin.Model, data: pin.Data, jid: int, model: RobotModel, i: int, fields: dict) -> None:
    """The MJCF joint of Pinocchio joint ``jid`` (active joint ``i``): type, axis, range, terms; ``data``
    holds the joint Jacobians (any configuration: a 1-DOF joint's axis is constant in its own frame)."""
    J = np.asarray(pin.getJointJacobian(pm, data, jid, pin.LOCAL)).reshape(6, pm.nv)  # 1-D when nv = 1
    S = J[:, pm.joints[jid].idx_v]  # (linear, angular)
    kind = "slide" if np.linalg.norm(S[:3]) > np.linalg.norm(S[3:]) else "hinge"
    axis = S[:3] if kind == "slide" else S[3:]
    axis = np.where(np.abs(axis) < 1e-15 * np.abs(axis).max(), 0.0, axis)  # composition leaves 1e-32s
    info = model.joints[i]
    el = sub_element(body, "joint", name=info.name, type=kind, axis=_vec(axis / np.linalg.norm(axis)))
    if info.kind != "continuous" and np.isfinite(info.lower) and np.isfinite(info.upper):
        el.set("range", f"{_num(info.lower)} {_num(info.upper)}")
    for attr in ("armature", "damping", "frictionloss"):
        if fields[attr][i] != 0:
            el.set(attr, _num(fields[attr][i]))


def _geoms(pm: pin.Model, links: dict, bodies: dict[int, Element], names: dict[int, str]) -> None:
    """Collision and visual shapes of every URDF link in the body it belongs to; display capsules for bodies
    with neither."""
    has = set()
    for f in pm.frames:
        if f.type != pin.FrameType.BODY or f.name not in links or f.parentJoint not in bodies:
            continue
        geoms = [g for kind in ("collision", "visual") for g in _shape_geoms(links[f.name], f.placement, f.name, kind)]
        body = bodies[f.parentJoint]
        pos = next((k for k, el in enumerate(body) if el.tag == "body"), len(body))
        for g in reversed(geoms):
            body.insert(pos, g)
        if geoms:
            has.add(f.parentJoint)
    for jid, body in bodies.items():
        if jid in has or jid == 0:
            continue
        ends = [pm.jointPlacements[k].translation for k in range(1, pm.njoints) if pm.parents[k] == jid]
        ends = [e for e in ends if np.linalg.norm(e) > 1e-6]
        pos = next((k for k, el in enumerate(body) if el.tag == "body"), len(body))
        extra = _DISPLAY
        if not ends:
            g = new_element("geom", name=f"{names[jid]}_display", type="sphere", size=_num(CAPSULE_RADIUS), **extra)
            body.insert(pos, g)
        for k, e in enumerate(ends):
            g = new_element(
                "geom",
                name=f"{names[jid]}_display_{k}",
                type="capsule",
                size=_num(CAPSULE_RADIUS),
                fromto=f"0 0 0 {_vec(e)}",
                **extra,
            )
            body.insert(pos, g)
