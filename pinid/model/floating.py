"""Floating base: the robot's root link on a free flyer (Pinocchio's ``JointModelFreeFlyer``).

A :class:`FloatingRobotModel` is a :class:`~pinid.model.robot.RobotModel` of the actuated joints (so limits,
joint names, recordings and excitation work as for a fixed base: its ``pin_model`` is the robot with the base
link held still) that also carries ``ff_model``, the same robot on a free flyer.  Build it with
``RobotModel.from_urdf(path, base="floating")``.

Base state, one sample (the conventions of Pinocchio's free flyer):

==============  =====  ===================================================================================
``base_q``      (7,)   position of the base-link origin in the world [m], then its orientation as a unit
                       quaternion ``x, y, z, w`` (base frame → world)
``base_v``      (6,)   spatial velocity in the **base frame**, linear part first [m/s, rad/s]
``base_a``      (6,)   its time derivative [m/s², rad/s²] (``base_v`` differentiated as a vector)
==============  =====  ===================================================================================

Galilean invariance: the joint torques and contact wrenches depend on the base's linear motion only through
the *classical* acceleration of its origin ``a_o = a_lin + ω × v_lin`` (base frame), so ``base_v`` with a zero
linear part and ``base_a`` with ``a_o`` as linear part give the same regressor; that is how base motion known
from an IMU alone (no linear velocity) enters (:mod:`pinid.data.contacts`).

The model layer's functions take the model and dispatch, as Pinocchio's algorithms do (a free flyer is a root
joint): :func:`~pinid.model.regressor.parameter_names`, :func:`~pinid.model.regressor.standard_parameters`,
:func:`~pinid.model.regressor.regressor` (on the free-flyer state of :meth:`FloatingRobotModel.full_state`) and
:func:`~pinid.model.base.base_parameters` (``rows``) give the floating robot's; ``model.fixed_base`` is the
joints-only view with the base held still.

Parameters.  The standard parameter vector of a floating robot is that of its *body view*
(:func:`body_view`): the base link first, as a pseudo-joint named ``base`` (``base.m`` … ``base.Izz``, about
the base-link frame), then 10 per actuated joint's body, then the joint terms per joint of the body view.  The
terms' ``base.*`` columns are zero (a free flyer has no friction): they are listed as unidentifiable.

Rows.  Per sample ``6 + n``: the 6 base rows (the base link's Newton–Euler equations in the base frame,
force first: the sum of the external wrenches on the robot, expressed at the base) and the ``n`` joint rows,
``W θ = [0₆; τ] + Σ_c J_cᵀ f_c`` with the contact wrenches ``f_c`` (:func:`contact_forces`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from pinid.checks import as_floats, count
from pinid.errors import DataError, ModelError, SpecError
from pinid.model.robot import BASE_BUILDERS, JointInfo, RobotModel
from pinid.model.terms import TermSelection, as_terms

#: Name of the free flyer in parameter names (``base.m``, ``base.mx`` …).
BASE_NAME = "base"
#: Number of configuration coordinates of the free flyer (position, unit quaternion x y z w).
BASE_NQ = 7
#: Number of velocity coordinates of the free flyer (linear, angular; base frame).
BASE_NV = 6


def _robot_fields(model: RobotModel) -> dict:
    """The keyword fields of ``RobotModel(pin_model, joints, **fields)`` that rebuild ``model``'s joints-only robot."""
    names = ("coulomb", "viscous", "urdf_path", "urdf_text", "locked", "drives", "urdf_document", "settings")
    return {name: getattr(model, name) for name in names}


class FloatingRobotModel(RobotModel):
    """A robot whose base link floats (free flyer).  ``pin_model`` / ``rnea`` / ``nv`` are those of the actuated
    joints with the base held still (as for a fixed base); ``ff_model`` is the free-flyer model (``nq = 7 + n``,
    ``nv = 6 + n``); ``base_link`` names the root link."""

    base = "floating"

    def __init__(self, fixed: RobotModel, ff_model: pin.Model, base_link: str) -> None:
        if not isinstance(fixed, RobotModel):
            raise ModelError(
                f"FloatingRobotModel: fixed is {type(fixed).__name__}, expected a RobotModel "
                "(build one with pinid.RobotModel.from_urdf(urdf, base='floating'))"
            )
        if not isinstance(ff_model, pin.Model):
            raise ModelError(f"FloatingRobotModel: ff_model is {type(ff_model).__name__}, expected a pinocchio.Model")
        if not isinstance(base_link, str) or not base_link:
            raise ModelError(f"FloatingRobotModel: base_link is {base_link!r}, expected the root link's name")
        super().__init__(fixed.pin_model, fixed.joints, **_robot_fields(fixed))
        self.ff_model = ff_model
        self.ff_data = ff_model.createData()
        self.base_link = base_link
        self._bodies: RobotModel | None = None
        self._fixed: RobotModel | None = None

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        state.pop("ff_data", None)
        state["_fixed"] = None  # built again on use
        return state

    def __setstate__(self, state: dict) -> None:
        super().__setstate__(state)
        self.ff_data = self.ff_model.createData()
        self._fixed = None

    def _copy_with(self, **attributes) -> "FloatingRobotModel":
        out = super()._copy_with(**attributes)
        out._bodies = out._fixed = None  # the views carry the settings: built again for the copy
        return out

    @property
    def bodies(self) -> RobotModel:
        """The body view (:func:`body_view`), built once."""
        if self._bodies is None:
            self._bodies = body_view(self)
        return self._bodies

    @property
    def fixed_base(self) -> RobotModel:
        """The same robot with its base link held still: a fixed-base :class:`RobotModel` of the actuated joints,
        built once.  The model-layer functions dispatch on the model (:func:`pinid.model.regressor.regressor`
        takes a floating model's free-flyer state); this is the joints-only view for what treats the robot as fixed
        (``pinid excite --base floating`` designs on it)."""
        if self._fixed is None:
            self._fixed = RobotModel(self.pin_model, self.joints, **_robot_fields(self))
            self._fixed.repair_inertia = self.repair_inertia
        return self._fixed

    @property
    def body_names(self) -> list[str]:
        """``base`` then the actuated joints: one name per moving body."""
        return [BASE_NAME, *self.joint_names]

    def frame_id(self, name: str, what: str = "frame") -> int:
        """Pinocchio frame id of a link (or any URDF frame) of ``ff_model``; DataError naming the links if unknown."""
        if isinstance(name, str) and self.ff_model.existFrame(name):
            fid = self.ff_model.getFrameId(name)
            if self.ff_model.frames[fid].type in (
                pin.FrameType.BODY,
                pin.FrameType.FIXED_JOINT,
                pin.FrameType.OP_FRAME,
            ):
                return fid
        links = [f.name for f in self.ff_model.frames if f.type == pin.FrameType.BODY]
        raise DataError(f"{what} '{name}' is not a link of {self.name} (its links: {', '.join(links)})")

    def floating_parameters(self) -> np.ndarray:
        """Standard inertial parameters of every moving body, base first (10·(n + 1))."""
        return np.concatenate(
            [self.ff_model.inertias[i].toDynamicParameters() for i in range(1, self.ff_model.njoints)]
        )

    def with_floating_parameters(self, theta: np.ndarray) -> "FloatingRobotModel":
        """A copy with other inertial parameters for every body (``theta``: 10·(n + 1), base first)."""
        theta = as_floats(theta, "theta").reshape(-1)
        if theta.shape != (10 * (self.nv + 1),):
            raise DataError(f"theta: {theta.size} values, expected {10 * (self.nv + 1)} (10 per body, base first)")
        fixed = self.with_inertial_parameters(theta[10:])
        ff = pin.Model(self.ff_model)
        for i in range(self.nv + 1):
            ff.inertias[i + 1] = pin.Inertia.FromDynamicParameters(theta[10 * i : 10 * i + 10])
        return FloatingRobotModel(fixed, ff, self.base_link)

    def full_state(self, base_q, base_v, base_a, q, dq, ddq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pinocchio's ``(N, 7 + nq_joints)``, ``(N, 6 + n)``, ``(N, 6 + n)`` of base and joint states (checked)."""
        q = np.atleast_2d(as_floats(q, "q"))
        n = len(q)
        arrays = {}
        for name, x, width in (
            ("base_q", base_q, BASE_NQ),
            ("base_v", base_v, BASE_NV),
            ("base_a", base_a, BASE_NV),
            ("dq", dq, self.nv),
            ("ddq", ddq, self.nv),
        ):
            a = np.atleast_2d(as_floats(x, name))
            if a.shape != (n, width):
                raise DataError(f"{name}: shape {a.shape}, expected ({n}, {width})")
            if not np.all(np.isfinite(a)):
                raise DataError(f"{name}: NaN or infinite values")
            arrays[name] = a
        if q.shape != (n, self.nv):
            raise DataError(f"q: shape {q.shape}, expected ({n}, {self.nv}) (joints {', '.join(self.joint_names)})")
        norms = np.linalg.norm(arrays["base_q"][:, 3:], axis=1)
        bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-6)
        if bad.size:
            k = int(bad[0])
            raise DataError(
                f"base_q: quaternion of sample {k} has norm {norms[k]:.6g}, expected a unit quaternion (x, y, z, w)"
            )
        qj = q if not self.continuous else np.array([self.configuration(x) for x in q])
        Q = np.hstack([arrays["base_q"], qj])
        V = np.hstack([arrays["base_v"], arrays["dq"]])
        A = np.hstack([arrays["base_a"], arrays["ddq"]])
        return Q, V, A


def build_floating(fixed: RobotModel, text: str, path) -> FloatingRobotModel:
    """The free-flyer model of the URDF ``text`` with the joints ``fixed`` locks held at the same values."""
    full = pin.buildModelFromXML(text, pin.JointModelFreeFlyer())
    to_lock = [full.getJointId(n) for n in fixed.locked]
    if to_lock:
        q_ref = pin.neutral(full)
        for n, value in fixed.locked.items():
            j = full.joints[full.getJointId(n)]
            if j.nq == 2:
                q_ref[j.idx_q : j.idx_q + 2] = np.cos(value), np.sin(value)
            else:
                q_ref[j.idx_q] = value
        full = pin.buildReducedModel(full, to_lock, q_ref)
    names = [full.names[i] for i in range(2, full.njoints)]
    if names != fixed.joint_names:
        raise ModelError(f"{path}: the floating model's joints {names} differ from {fixed.joint_names}")
    if BASE_NAME in names:
        raise ModelError(f"{path}: a joint is named '{BASE_NAME}', the name pinid gives the floating base; rename it")
    full.armature[:] = 0.0
    full.damping[:] = 0.0
    full.friction[:] = 0.0
    base_link = next(f.name for f in full.frames if f.type == pin.FrameType.BODY and f.parentJoint == 1)
    return FloatingRobotModel(fixed, full, base_link)


def body_view(model: FloatingRobotModel) -> RobotModel:
    """A RobotModel whose joints are the moving bodies: the free flyer ``base`` (kind ``floating``), then the
    actuated joints; ``pin_model`` is ``ff_model``.  It gives the floating robot's standard parameters their
    names, nominal values and layout (what estimators and the consistency checks read); its kinematic methods
    (``rnea``, ``configuration``) are not meant to be called."""
    inf = np.inf
    joints = [JointInfo(BASE_NAME, "floating", -inf, inf, inf, inf), *model.joints]
    view = RobotModel(
        model.ff_model,
        joints,
        coulomb=np.r_[0.0, model.coulomb],
        viscous=np.r_[0.0, model.viscous],
        urdf_path=model.urdf_path,
        urdf_text=model.urdf_text,
        locked=model.locked,
        urdf_document=model.urdf_document,
        settings=model.settings,
    )
    return view


def free_flyer_terms(model: FloatingRobotModel, terms: TermSelection) -> TermSelection:
    """``terms`` (a TermSelection or names) if a free flyer takes them: ModelError for motor-side terms and the
    wearer's passive term."""
    terms = as_terms(terms)
    if terms.motor:
        raise ModelError(
            f"{model.name}: motor-side terms ({', '.join(t.name for t in terms.motor)}) with a floating base are "
            "not supported; use joint-side terms"
        )
    if "passive" in terms.names:
        raise ModelError(f"{model.name}: the wearer's passive term with a floating base is not supported")
    return terms


def as_floating(model) -> FloatingRobotModel:
    """``model`` if it is a FloatingRobotModel; ModelError saying how to load one otherwise."""
    if not isinstance(model, FloatingRobotModel):
        raise ModelError(
            f"model: got {type(model).__name__}, expected a floating-base robot "
            "(RobotModel.from_urdf(path, base='floating'))"
        )
    return model


def floating_rnea(model: FloatingRobotModel, base_q, base_v, base_a, q, dq, ddq) -> np.ndarray:
    """Rigid-body inverse dynamics on the free flyer, ``(N, 6 + n)``: base wrench [N, N·m], joint torques [N·m]."""
    model = as_floating(model)
    Q, V, A = model.full_state(base_q, base_v, base_a, q, dq, ddq)
    m, d = model.ff_model, model.ff_data
    return np.array([pin.rnea(m, d, a, b, c).copy() for a, b, c in zip(Q, V, A)])


@dataclass(frozen=True)
class Wrench:
    """An external wrench on a link over time: ``values`` (N, 6) ``fx, fy, fz, tx, ty, tz`` [N, N·m].

    ``frame = "local"``: in the frame of ``link`` (moment about its origin), as a foot F/T sensor measures;
    ``"world"``: in world axes with the moment about the world origin (a force plate's wrench moved there)."""

    link: str
    values: np.ndarray
    frame: str = "local"


def contact_forces(model: FloatingRobotModel, base_q, q, wrenches: Sequence[Wrench]) -> np.ndarray:
    """Generalised forces ``Σ_c J_cᵀ f_c`` ``(N, 6 + n)`` of external wrenches (what they add to the RNEA's
    right-hand side: ``RNEA(q, v, a) = [0₆; τ] + Σ J_cᵀ f_c``)."""
    model = as_floating(model)
    bq = np.atleast_2d(as_floats(base_q, "base_q"))
    qj = np.atleast_2d(as_floats(q, "q"))
    n = len(bq)
    Q = np.hstack([bq, qj if not model.continuous else np.array([model.configuration(x) for x in qj])])
    m, d = model.ff_model, model.ff_data
    items = []
    for w in wrenches:
        vals = np.asarray(w.values, dtype=float)
        if vals.shape != (n, 6):
            raise DataError(f"wrench on '{w.link}': shape {vals.shape}, expected ({n}, 6)")
        if w.frame not in ("local", "world"):
            raise DataError(f"wrench on '{w.link}': frame {w.frame!r}, expected 'local' or 'world'")
        items.append((model.frame_id(w.link, "wrench link"), pin.LOCAL if w.frame == "local" else pin.WORLD, vals))
    # every wrench in world axes about the world origin, then J_worldᵀ f on the joints that support its body
    nvf = BASE_NV + model.nv
    J = np.empty((n, 6, nvf))
    world = [np.array(vals, copy=True) for _, _, vals in items]
    local = [i for i, (_, ref, _) in enumerate(items) if ref == pin.LOCAL]
    for k in range(n):
        J[k] = pin.computeJointJacobians(m, d, Q[k])
        for i in local:
            fid = items[i][0]
            frame = m.frames[fid]
            X = d.oMi[frame.parentJoint] * frame.placement
            world[i][k] = X.act(pin.Force(items[i][2][k])).vector
    out = np.zeros((n, nvf))
    for (fid, _, _), f in zip(items, world):
        support = np.zeros(nvf, bool)
        for jid in m.supports[m.frames[fid].parentJoint]:
            if jid > 0:
                j = m.joints[jid]
                support[j.idx_v : j.idx_v + j.nv] = True
        out[:, support] += np.einsum("nrc,nr->nc", J[:, :, support], f)
    return out


def random_floating_states(model: FloatingRobotModel, n: int, rng: np.random.Generator, *, acceleration: float = 5.0):
    """``n`` random ``(base_q, base_v, base_a, q, dq, ddq)``: uniform orientations, joints inside their limits."""
    n = count(n, "n", low=1)
    q, dq, ddq = model.random_states(n, rng, acceleration=acceleration)
    quat = rng.normal(size=(n, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    base_q = np.hstack([rng.uniform(-1, 1, (n, 3)), quat])
    base_v = rng.uniform(-1, 1, (n, BASE_NV))
    base_a = rng.uniform(-acceleration, acceleration, (n, BASE_NV))
    return base_q, base_v, base_a, q, dq, ddq


#: Which rows a floating base-parameter set is computed from.
ROW_SETS = ("all", "base", "joints")


def row_mask(nv: int, rows: str) -> np.ndarray:
    """(6 + nv,) booleans: the rows of one sample in the row set ``rows`` ("all", "base" or "joints")."""
    if rows not in ROW_SETS:
        raise SpecError(f"rows={rows!r}, expected one of {', '.join(ROW_SETS)}")
    mask = np.ones(BASE_NV + nv, bool)
    if rows == "base":
        mask[BASE_NV:] = False
    elif rows == "joints":
        mask[:BASE_NV] = False
    return mask


BASE_BUILDERS["floating"] = build_floating

#: Names this module had, removed (issue 32: one function dispatching on the model, as Pinocchio's algorithms do)
#: or moved, with what to use instead.
_REMOVED = {
    "floating_parameter_names": "pinid.model.regressor.parameter_names(model, terms)",
    "floating_standard_parameters": "pinid.model.regressor.standard_parameters(model, terms)",
    "floating_regressor": "pinid.model.regressor.regressor(model, *model.full_state(base_q, base_v, base_a, q, dq, "
    "ddq), terms)",
    "floating_base_parameters": "pinid.model.base.base_parameters(model, terms, rows=...)",
    "floating_urdf": "pinid.model.export.floating_urdf",
}


def __getattr__(name: str):
    if name in _REMOVED:
        raise AttributeError(f"pinid.model.floating.{name} is gone: use {_REMOVED[name]} (CHANGELOG, issue 32)")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
