"""The per-joint and per-motor terms of the dynamic model (friction, offset, rotor inertia, …): one registry.

A *term* adds one parameter per joint (``space="joint"``, named ``<joint>.<suffix>``, e.g. ``hip.fc``) or
per motor of the robot's drives (``space="motor"``, named ``<motor>.<suffix>``, e.g. ``m6.fc``).  Its
regressor column is a function of the motion in its own space, vectorised over samples:

* a joint term's column ``c(q, dq, ddq)`` (N, nv) enters joint ``j``'s row as ``c[:, j]``;
* a motor term's column is evaluated on the motor motion ``(G·q, G·dq, G·ddq)`` and enters joint ``j``'s
  row as ``G[m, j]·c[:, m]`` (``τ_joint = Gᵀ·τ_motor``; see :mod:`pinid.model.drives`).

Adding a term is one :func:`register` call (docs/architecture.md, "Adding a joint term"): give the selection
name used by ``--terms``, the parameter suffix, label, unit, the column function, and optionally the
nominal value per joint (read from the robot), the SDP sign constraint, the URDF ``<dynamics>`` /
drives TOML field, whether it is an inertia (its column is an acceleration), the torque the digital
twin's plant applies (default: value × column) and the name of the per-run model setting it reads
(``robot.setting(name)``, saved with the model through ``read_setting`` / ``write_setting``).
Terms of other modules and packages are plug-ins (:data:`PLUGIN_TERMS`, entry points of the group
``pinid.terms``: :mod:`pinid.plugins`): the wearer's passive moments, the position
ripple (:mod:`pinid.model.terms_ripple`, selected as a group: ``ripple``, :data:`TERM_GROUPS`) and the
load-dependent Coulomb friction ``fl`` (:mod:`pinid.model.terms_load`).

Parameter layout after the 10·nv inertial parameters: the joint block, joint-major (joint ``j``'s
terms together, in registry order), then the motor block, motor-major.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import NamedTuple
from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np
from pinid.checks import array_like, as_floats
from pinid.errors import DataError, ModelError, SpecError
from pinid.plugins import Registry


class Motion(NamedTuple):
    """What a column function sees: coordinates of one space, (N, n) arrays, and their names."""

    q: np.ndarray  # [rad or m]
    dq: np.ndarray  # [rad/s or m/s]
    ddq: np.ndarray  # [rad/s² or m/s²]
    names: Sequence[str]  # joint (or motor) names, one per column of q
    robot: object = None  # the RobotModel (for terms that need its structure)


@dataclass(frozen=True)
class Term:
    """One kind of per-joint or per-motor parameter (see the module text)."""

    name: str  # selection name (``--terms``): "fc", "motor_fc"
    suffix: str  # parameter name suffix: "fc" → "hip.fc" / "m6.fc"
    label: str
    unit: str
    column: Callable[[Motion], np.ndarray]  # (N, n) regressor column per joint (or motor)
    space: str = "joint"  # "joint" or "motor"
    nonnegative: bool = False  # SDP constraint and consistency check: value ≥ 0
    nominal: Callable[[object], np.ndarray] | None = None  # RobotModel → (nv,) nominal values (default 0)
    field: str | None = None  # URDF <dynamics> attribute (joint terms) or drives TOML key (motor terms)
    inertia: bool = False  # the column is an acceleration: the plant adds the value to the mass matrix
    plant: Callable[[np.ndarray, Motion, float], np.ndarray] | None = None  # (values, motion, v_s) → torque
    static: bool = False  # the column depends on q only (like gravity): a model's gravity(q) includes it
    velocity_step: bool = False  # the column jumps at zero velocity (Coulomb): ∂/∂dq taken as 0 elsewhere
    # the column reads the rigid-body load torque (fl): it depends on ddq, not as an inertia; the twin solves
    # its acceleration by fixed-point iteration, IdentifiedModel.friction(dq) leaves it out
    load: bool = False
    # the model setting the term reads (``robot.setting(name)``), saved with the model: "stribeck", "passive_exponents"
    setting: str | None = None
    read_setting: Callable[[object, str], object] | None = None  # (saved value, origin) → value; None: as saved
    write_setting: Callable[[object], object] | None = None  # value → JSON-able saved value; None: as it is
    note: str = ""  # a few words for the --terms help after the label: its law, what it replaces

    def torque(self, values: np.ndarray, motion: Motion, smoothing: float | None = None) -> np.ndarray:
        """Torque of this term [N·m] in its own space for per-joint/motor ``values``; the plant's law when
        ``smoothing`` (a velocity scale [rad/s]) is given and the term has one, else value × column."""
        if smoothing is not None and self.plant is not None:
            return self.plant(np.asarray(values, dtype=float), motion, smoothing)
        return np.asarray(values, dtype=float) * self.column(motion)


#: The in-tree plug-in terms, in their column order: terms of a module this one does not import (the wearer's
#: passive moments, a layer above; the position ripple and the load-dependent friction, loaded when used).
#: Each is an entry point of the group ``pinid.terms`` (pyproject.toml), loaded the first time the term is
#: asked for (:class:`pinid.plugins.Registry`); its place in the column order is kept from the start.
PLUGIN_TERMS: tuple[str, ...] = ("passive", *(f"ripple_{p}{k}" for k in (1, 2, 3) for p in "sc"), "fl", "fsig")
#: Selection names that stand for several terms (``--terms ripple``): the position ripple's harmonics
#: (:mod:`pinid.model.terms_ripple`: one term per sine and cosine amplitude of each harmonic).
TERM_GROUPS: dict[str, tuple[str, ...]] = {
    name: tuple(f"ripple_{p}{k}" for k in range(1, n + 1) for p in "sc")
    for name, n in (("ripple", 1), ("ripple2", 2), ("ripple3", 3))
}


class TermRegistry(Registry):
    """The known terms by name, in column order (registration order; a plug-in term of :data:`PLUGIN_TERMS`
    at the place reserved for it, one of another package at the end).  Asking for a plug-in term
    (``TERMS[name]``, ``name in TERMS``, its values) loads its entry point, which registers it; listing the
    names loads nothing."""

    def __init__(self) -> None:
        super().__init__("pinid.terms", "term", adopt=lambda name, obj: register(obj))


#: Every known term, in column order.
TERMS = TermRegistry()


def register(term: Term) -> Term:
    """Add a term to the registry (its name must be new); returns it."""
    if not isinstance(term, Term):
        raise SpecError(f"term: got {type(term).__name__}, expected a pinid.model.terms.Term")
    if TERMS.registered(term.name):
        raise ValueError(f"term {term.name!r} is already registered")
    if term.space not in ("joint", "motor"):
        raise ValueError(f"term {term.name!r}: space {term.space!r}, expected 'joint' or 'motor'")
    TERMS[term.name] = term
    return term


def _coulomb_plant(values: np.ndarray, m: Motion, vs: float) -> np.ndarray:
    return values * np.tanh(m.dq / vs)


register(
    Term(
        "fc",
        "fc",
        "Coulomb friction",
        "N·m",
        lambda m: np.sign(m.dq),
        nonnegative=True,
        nominal=lambda r: r.coulomb,
        field="friction",
        plant=_coulomb_plant,
        velocity_step=True,
    )
)
register(
    Term(
        "fv",
        "fv",
        "viscous friction",
        "N·m·s/rad",
        lambda m: m.dq,
        nonnegative=True,
        nominal=lambda r: r.viscous,
        field="damping",
    )
)
register(Term("offset", "offset", "constant torque", "N·m", lambda m: np.ones_like(m.dq)))
register(Term("armature", "armature", "rotor inertia", "kg·m²", lambda m: m.ddq, nonnegative=True, inertia=True))

register(
    Term(
        "fc_pos",
        "fc_pos",
        "Coulomb friction, positive velocity",
        "N·m",
        lambda m: (m.dq > 0).astype(float),
        nonnegative=True,
        plant=lambda v, m, vs: v * np.maximum(np.tanh(m.dq / vs), 0.0),
        velocity_step=True,
        note="with fc_neg, instead of fc",
    )
)
register(
    Term(
        "fc_neg",
        "fc_neg",
        "Coulomb friction, negative velocity",
        "N·m",
        lambda m: -(m.dq < 0).astype(float),
        nonnegative=True,
        plant=lambda v, m, vs: v * np.minimum(np.tanh(m.dq / vs), 0.0),
        velocity_step=True,
        note="with fc_pos, instead of fc",
    )
)

# the plug-ins' places: the wearer's passive moments (pinid.wearer.passive), the position ripple
# (pinid.model.terms_ripple) and the load-dependent Coulomb friction (pinid.model.terms_load)
for _name in PLUGIN_TERMS:
    TERMS.reserve(_name)

for _base in ("fc", "fv", "offset", "armature", "fc_pos", "fc_neg"):
    _t = TERMS[_base]
    register(
        Term(
            f"motor_{_base}",
            _base,
            f"motor {_t.label}",
            _t.unit,
            _t.column,
            space="motor",
            nonnegative=_t.nonnegative,
            nominal=lambda r, s=_base: r.drives.nominal(s),
            field=_base,
            inertia=_t.inertia,
            plant=_t.plant,
            velocity_step=_t.velocity_step,
        )
    )


# ---------------------------------------------------------------------------------------------- Stribeck
#: Default Stribeck velocity [rad/s or m/s, in the term's own space] and shape when the robot sets none.
STRIBECK_VELOCITY, STRIBECK_SHAPE = 0.1, 2.0


@dataclass(frozen=True)
class Stribeck:
    """Shape of a Stribeck term ``fs·sign(v)·exp(−(|v|/velocity)^shape)`` (on top of Coulomb ``fc·sign(v)``:
    the static friction is fc + fs).  ``velocity`` [rad/s or m/s] > 0 in the term's own space (joint or
    motor velocity), ``shape`` > 0 (2: Gaussian, 1: exponential)."""

    velocity: float = STRIBECK_VELOCITY
    shape: float = STRIBECK_SHAPE

    def __post_init__(self) -> None:
        for key, v, unit in (("velocity", self.velocity, " [rad/s]"), ("shape", self.shape, "")):
            if isinstance(v, bool) or not isinstance(v, (int, float, np.floating)) or not np.isfinite(v) or v <= 0:
                raise SpecError(f"Stribeck {key} {v!r}, expected a finite number > 0{unit}")
            object.__setattr__(self, key, float(v))

    def factor(self, v: np.ndarray) -> np.ndarray:
        """``exp(−(|v|/velocity)^shape)``: 1 at rest, → 0 at speed.  Bounded for any shape: a power that
        overflows (shape 1e6 above ``velocity``) is +inf, and its factor exactly 0 (the step it tends to)."""
        with np.errstate(over="ignore", under="ignore"):
            return np.exp(-((np.abs(v) / self.velocity) ** self.shape))


def stribeck(robot, name: str) -> Stribeck:
    """The Stribeck shape of term ``name`` (``fs``, ``motor_fs``) on ``robot`` (its ``stribeck`` dict),
    else the default (:data:`STRIBECK_VELOCITY`, :data:`STRIBECK_SHAPE`)."""
    if not isinstance(name, str):
        raise SpecError(
            f"name: got {type(name).__name__}, expected a Stribeck term name, one of {list(STRIBECK_TERMS)}"
        )
    return (getattr(robot, "stribeck", None) or {}).get(name) or Stribeck()


def stribeck_from_dict(d: dict, origin: str) -> dict[str, Stribeck]:
    """``{term: Stribeck}`` from ``{term: {"velocity": v, "shape": δ}}``; SpecError naming what is wrong."""
    if not isinstance(d, dict):
        raise SpecError(f"{origin}: got {type(d).__name__}, expected a table of Stribeck terms")
    out = {}
    for name, v in d.items():
        if name not in STRIBECK_TERMS or not isinstance(v, dict) or set(v) - {"velocity", "shape"}:
            raise SpecError(
                f"{origin}: {name!r}: {v!r}, expected one of {list(STRIBECK_TERMS)}: "
                "{velocity: number > 0, shape: number > 0}"
            )
        try:
            out[name] = Stribeck(**v)
        except SpecError as exc:
            raise SpecError(f"{origin}: {name}: {exc}") from None
    return out


def stribeck_to_dict(shapes: Mapping[str, Stribeck]) -> dict[str, dict[str, float]]:
    """``{term: {"velocity": v, "shape": δ}}`` of ``{term: Stribeck}`` (the saved form, :func:`stribeck_from_dict`)."""
    if not isinstance(shapes, Mapping) or not all(isinstance(s, Stribeck) for s in shapes.values()):
        raise SpecError(f"shapes: got {type(shapes).__name__}, expected {{term: Stribeck}}")
    return {k: {"velocity": s.velocity, "shape": s.shape} for k, s in shapes.items()}


def _stribeck_term(name: str, space: str) -> Term:
    """The Stribeck term ``name`` of ``space``: column sign(v)·exp(−(|v|/v_s)^δ), plant tanh(v/smoothing)·(…)."""

    def column(m: Motion) -> np.ndarray:
        return np.sign(m.dq) * stribeck(m.robot, name).factor(m.dq)

    def plant(values: np.ndarray, m: Motion, vs: float) -> np.ndarray:
        return values * np.tanh(m.dq / vs) * stribeck(m.robot, name).factor(m.dq)

    motor = space == "motor"
    return Term(
        name,
        "fs",
        "motor Stribeck friction" if motor else "Stribeck friction",
        "N·m",
        column,
        space=space,
        nonnegative=True,
        nominal=(lambda r: r.drives.nominal("fs")) if motor else None,
        field="fs" if motor else None,
        plant=plant,
        setting="stribeck",
        read_setting=stribeck_from_dict,
        write_setting=stribeck_to_dict,
        note=f"{name}·sign(v)·exp(−(|v|/v_s)^δ), on top of {'motor_fc' if motor else 'fc'}",
    )


register(_stribeck_term("fs", "joint"))
register(_stribeck_term("motor_fs", "motor"))
#: Names of the Stribeck terms (their shape is a robot setting: :func:`stribeck`, ``robot.stribeck``).
STRIBECK_TERMS: tuple[str, ...] = ("fs", "motor_fs")

#: The classic joint terms (``TermSelection``' keyword arguments), in column order.
JOINT_TERM_NAMES: tuple[str, ...] = ("fc", "fv", "offset", "armature")
_FLAGS = dict(zip(("coulomb", "viscous", "offset", "armature"), JOINT_TERM_NAMES))


class TermSelection:
    """Which terms enter the model — joint, motor and plug-in terms (the wearer's passive moments) alike
    (default: joint Coulomb and viscous friction).  Named ``JointTerms`` before issue 26; that name still
    works for one release with a DeprecationWarning.

    ``TermSelection(coulomb=True, viscous=True, offset=False, armature=False)`` selects the classic joint
    terms; ``TermSelection.from_names("fc,fv,motor_fc")`` any registered ones.  ``names`` is in column order.
    """

    __slots__ = ("_names",)

    def __init__(
        self,
        coulomb: bool = True,
        viscous: bool = True,
        offset: bool = False,
        armature: bool = False,
        *,
        names: Iterable[str] | None = None,
    ) -> None:
        if names is None:
            flags = (coulomb, viscous, offset, armature)
            names = [n for n, on in zip(JOINT_TERM_NAMES, flags) if on]
        if isinstance(names, str) or not isinstance(names, Iterable):
            raise SpecError(f"terms {names!r}: expected a list of term names, some of {list(TERMS)}")
        names = [x for n in names for x in (TERM_GROUPS.get(n, (n,)) if isinstance(n, str) else (n,))]
        unknown = [n for n in names if not isinstance(n, str) or n not in TERMS]
        if unknown:
            raise SpecError(f"unknown term(s) {unknown}, expected some of {list(TERMS)}")
        self._names = tuple(n for n in TERMS if n in names)

    @classmethod
    def from_names(cls, names: str | Iterable[str]) -> "TermSelection":
        """Build from ``"fc,fv,offset"`` or a list of term names (or groups of :data:`TERM_GROUPS`: ``ripple``);
        ``""`` or ``"none"`` for no term."""
        if isinstance(names, str):
            names = [n.strip() for n in names.split(",") if n.strip() and n.strip() != "none"]
        elif not isinstance(names, (list, tuple)):
            raise SpecError(f'terms {names!r}: expected "fc,fv" or a list of term names, some of {list(TERMS)}')
        return cls(names=names)

    @property
    def names(self) -> list[str]:
        """Names of the selected terms, in column order."""
        return list(self._names)

    @property
    def joint(self) -> list[Term]:
        """The selected joint-side terms."""
        return [TERMS[n] for n in self._names if TERMS[n].space == "joint"]

    @property
    def motor(self) -> list[Term]:
        """The selected motor-side terms."""
        return [TERMS[n] for n in self._names if TERMS[n].space == "motor"]

    coulomb = property(lambda self: "fc" in self._names, doc="Joint Coulomb friction selected.")
    viscous = property(lambda self: "fv" in self._names, doc="Joint viscous friction selected.")
    offset = property(lambda self: "offset" in self._names, doc="Joint constant torque selected.")
    armature = property(lambda self: "armature" in self._names, doc="Joint rotor inertia selected.")

    def __contains__(self, name: str) -> bool:
        return name in self._names

    def __len__(self) -> int:
        return len(self._names)

    def __eq__(self, other) -> bool:
        return isinstance(other, TermSelection) and other._names == self._names

    def __hash__(self) -> int:
        return hash(self._names)

    def __repr__(self) -> str:
        return f"TermSelection.from_names({','.join(self._names)!r})"


def as_terms(terms: TermSelection | str | Iterable[str] | None) -> TermSelection:
    """Joint terms from a :class:`TermSelection`, ``"fc,fv"``, a list of names, None or ``"default"`` (Coulomb and
    viscous friction: where recordings are at hand, ``identify`` adds a constant offset to ``"default"`` when
    they say it wins, :mod:`pinid.identification.term_choice`); SpecError for anything else or an unknown name."""
    if isinstance(terms, TermSelection):
        return terms
    if terms is None or (isinstance(terms, str) and terms.strip().lower() == "default"):
        return TermSelection()
    return TermSelection.from_names(terms)


def _robot(robot) -> None:
    """ModelError unless ``robot`` looks like a RobotModel (joint names and nv): cheap, for per-chunk calls."""
    if not (hasattr(robot, "joint_names") and hasattr(robot, "nv")):
        raise ModelError(f"robot: got {type(robot).__name__}, expected a pinid RobotModel")


def _names(x, name: str) -> None:
    """SpecError naming ``name`` unless ``x`` is a list, tuple or array of names."""
    if not isinstance(x, (list, tuple, np.ndarray)) or not all(isinstance(n, str) for n in x):
        raise SpecError(f"{name}: got {type(x).__name__}, expected a list of names")


class TermParameter(NamedTuple):
    """One term parameter: its name, its term, and the index of its joint (or motor) in its space."""

    name: str
    term: Term
    index: int


def layout(joints: Sequence[str], motors: Sequence[str], terms: TermSelection | Iterable[str]) -> list[TermParameter]:
    """The term parameters in order (joint block joint-major, then motor block motor-major).  With motor
    terms, SpecError for a motor name that is not allowed or is a joint's (their parameters would clash:
    :func:`pinid.model.drives.check_motor_names`)."""
    from pinid.model.drives import check_motor_names

    _names(joints, "joints")
    _names(motors, "motors")
    terms = terms if isinstance(terms, TermSelection) else TermSelection(names=terms)
    if terms.motor and not motors:
        raise ValueError(f"motor term(s) {[t.name for t in terms.motor]} need drives (none given)")
    if terms.motor:
        check_motor_names(motors, joints, "drives")
    out = [TermParameter(f"{j}.{t.suffix}", t, i) for i, j in enumerate(joints) for t in terms.joint]
    out += [TermParameter(f"{m}.{t.suffix}", t, i) for i, m in enumerate(motors) for t in terms.motor]
    return out


def _motors(robot) -> list[str]:
    drives = getattr(robot, "drives", None)
    return list(drives.motor_names) if drives is not None else []


def robot_layout(robot, terms: TermSelection) -> list[TermParameter]:
    """:func:`layout` for a RobotModel (its joints and its drives' motors); ModelError if motor terms have no drives."""
    _robot(robot)
    terms = as_terms(terms)
    if terms.motor and _motors(robot):
        from pinid.model.drives import check_motor_names

        check_motor_names(_motors(robot), robot.joint_names, robot.drives.origin)
    try:
        return layout(robot.joint_names, _motors(robot), terms)
    except ValueError as exc:
        raise ModelError(
            f"{robot.name}: {exc}; give the robot's transmissions (URDF <transmission> or --drives FILE)"
        ) from None


def term_count(robot, terms: TermSelection) -> int:
    """Number of term parameters of ``robot`` with ``terms``."""
    _robot(robot)
    terms = as_terms(terms)
    return len(terms.joint) * robot.nv + len(terms.motor) * len(_motors(robot))


def term_parameter_names(robot, terms: TermSelection) -> list[str]:
    """Names of the term parameters (``hip.fc``, ``m6.fc``), in column order."""
    return [p.name for p in robot_layout(robot, terms)]


def nominal(robot, terms: TermSelection) -> np.ndarray:
    """Nominal term values: the robot's own (URDF ``<dynamics>``, drives file) where it has them, else 0."""
    layout_ = robot_layout(robot, terms)
    cache = {
        t.name: (np.asarray(t.nominal(robot), dtype=float) if t.nominal else None) for t in {p.term for p in layout_}
    }
    return np.array([0.0 if cache[p.term.name] is None else cache[p.term.name][p.index] for p in layout_])


def nonnegative(robot, terms: TermSelection) -> np.ndarray:
    """Boolean mask over the term parameters: True where the value must be ≥ 0."""
    return np.array([p.term.nonnegative for p in robot_layout(robot, terms)], dtype=bool)


def motion(robot, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, space: str = "joint") -> Motion:
    """The (N, ·) motion in joint space or motor space (``G·q``, ``G·dq``, ``G·ddq``)."""
    _robot(robot)
    for key, x in (("q", q), ("dq", dq), ("ddq", ddq)):
        array_like(x, key)
    if space == "joint":
        return Motion(q, dq, ddq, robot.joint_names, robot)
    if space != "motor":
        raise SpecError(f"space={space!r}, expected 'joint' or 'motor'")
    G = robot.drives.matrix
    return Motion(q @ G.T, dq @ G.T, ddq @ G.T, robot.drives.motor_names, robot)


def _same_motion_shape(robot, q, dq, ddq) -> None:
    """DataError unless ``q``, ``dq`` and ``ddq`` are (N, nv) arrays of one shape (a cheap check: no copy)."""
    want = robot.nv
    for name, x in (("q", q), ("dq", dq), ("ddq", ddq)):
        shape = np.shape(x)
        if len(shape) != 2 or shape[1] != want or shape != np.shape(q):
            raise DataError(
                f"{name}: shape {shape}, expected (N, {want}) for joints {list(robot.joint_names)}, "
                f"the shape of q {np.shape(q)}"
            )


def columns(
    robot, terms: TermSelection, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    """Regressor columns of the terms, (N, nv, count) for (N, nv) joint motion (vectorised over samples);
    written into ``out`` (a zeroed (N, nv, count) array or view) when given."""
    _robot(robot)
    terms = as_terms(terms)
    q = np.asarray(array_like(q, "q"))
    _same_motion_shape(robot, q, dq, ddq)
    n, nv = q.shape
    joint, motor = terms.joint, terms.motor
    nm = len(_motors(robot)) if motor else 0
    if out is None:
        out = np.zeros((n, nv, len(joint) * nv + len(motor) * nm))
    if joint:
        mj = motion(robot, q, dq, ddq)
        rows = np.arange(nv)
        for t, term in enumerate(joint):
            out[:, rows, rows * len(joint) + t] = term.column(mj)
    if motor:
        robot_layout(robot, terms)  # raises when there are no drives
        mm = motion(robot, q, dq, ddq, "motor")
        G = robot.drives.matrix
        start = len(joint) * nv
        for t, term in enumerate(motor):
            c = term.column(mm)  # (N, nm)
            for m in range(nm):
                np.multiply(c[:, m, None], G[m], out=out[:, :, start + m * len(motor) + t])
    return out


def values(robot, terms: TermSelection, theta_terms: np.ndarray) -> dict[str, np.ndarray]:
    """``{term name: per-joint (or per-motor) values}`` of the term block ``theta_terms``; unselected
    classic joint terms are zero arrays."""
    _robot(robot)
    terms = as_terms(terms)
    theta_terms = as_floats(theta_terms, "theta_terms", finite=False)
    layout = robot_layout(robot, terms)
    if theta_terms.shape != (len(layout),):
        raise DataError(
            f"theta_terms: shape {theta_terms.shape}, expected ({len(layout)},) values of the terms "
            f"{', '.join(p.name for p in layout[:6]) or '(none)'}{' …' if len(layout) > 6 else ''}"
        )
    out: dict[str, np.ndarray] = {n: np.zeros(robot.nv) for n in JOINT_TERM_NAMES}
    for t in terms.joint + terms.motor:
        out[t.name] = np.zeros(robot.nv if t.space == "joint" else len(_motors(robot)))
    for p, v in zip(layout, theta_terms):
        out[p.term.name][p.index] = v
    return out


def kept_friction(robot, terms: TermSelection) -> dict[str, dict[str, float]]:
    """``{joint: {"fc": value, "fv": value}}``: the URDF's ``<dynamics>`` friction [N·m] and damping [N·m·s/rad]
    (``robot.coulomb``, ``robot.viscous``) of the joint terms that ``terms`` does not identify (``fc`` or ``fv``
    not selected), non-zero ones only.  The identified URDF and MJCF both keep these values, marked "not
    identified (URDF value kept)", so that the two files of one result carry the same friction."""
    _robot(robot)
    terms = as_terms(terms)
    out: dict[str, dict[str, float]] = {}
    for name, nominal in (("fc", getattr(robot, "coulomb", None)), ("fv", getattr(robot, "viscous", None))):
        if name in terms or nominal is None:
            continue
        for joint, v in zip(robot.joint_names, np.asarray(nominal, dtype=float)):
            if v != 0:
                out.setdefault(joint, {})[name] = float(v)
    return out


def torque(
    robot,
    terms: TermSelection,
    theta_terms: np.ndarray | dict[str, np.ndarray],
    q,
    dq,
    ddq,
    *,
    smoothing: float | None = None,
) -> np.ndarray:
    """Joint torque (N, nv) [N·m] of the terms with values ``theta_terms`` (the term block, or its
    :func:`values` dict): joint terms plus ``Gᵀ·``(motor terms); with ``smoothing`` [rad/s] each term's
    plant law (e.g. Coulomb ``fc·tanh(dq/v_s)``)."""
    _robot(robot)
    terms = as_terms(terms)
    if not isinstance(theta_terms, dict):
        array_like(theta_terms, "theta_terms")
    q, dq, ddq = (
        np.atleast_2d(np.asarray(array_like(x, k), dtype=float)) for k, x in (("q", q), ("dq", dq), ("ddq", ddq))
    )
    _same_motion_shape(robot, q, dq, ddq)
    vals = theta_terms if isinstance(theta_terms, dict) else values(robot, terms, theta_terms)
    tau = np.zeros_like(q)
    if terms.joint:
        mj = motion(robot, q, dq, ddq)
        for t in terms.joint:
            tau += t.torque(vals[t.name], mj, smoothing)
    if terms.motor:
        mm = motion(robot, q, dq, ddq, "motor")
        tau_m = sum(t.torque(vals[t.name], mm, smoothing) for t in terms.motor)
        tau += tau_m @ robot.drives.matrix
    return tau


def _spec_items(spec, names: Sequence[str], what: str) -> dict[str, object]:
    """``{term: value}`` of a Stribeck setting: one value for every name, ``"fs=0.05,motor_fs=auto"`` or a dict."""
    if isinstance(spec, str) and "=" in spec:
        items = {}
        for part in (p.strip() for p in spec.split(",") if p.strip()):
            key, _, value = part.partition("=")
            items[key.strip()] = value.strip()
    elif isinstance(spec, dict):
        items = dict(spec)
    else:
        items = {n: spec for n in names}
    if not names:
        raise SpecError(
            f"Stribeck {what} given, but no Stribeck term is selected: add one of {list(STRIBECK_TERMS)} to the terms"
        )
    bad = [k for k in items if k not in names]
    if bad:
        raise SpecError(
            f"Stribeck {what} for {bad}: expected Stribeck term(s) selected in the terms ({', '.join(names)})"
        )
    return items


def stribeck_settings(
    robot, terms: TermSelection, velocity=None, shape=None
) -> tuple[dict[str, Stribeck], dict[str, bool]]:
    """``({term: Stribeck}, {term whose velocity is fitted: its shape is fitted too})`` for the selected
    Stribeck terms.

    ``velocity`` [rad/s, in the term's space]: a number for every selected Stribeck term, ``"auto"`` (fitted:
    :mod:`pinid.identification.stribeck`), ``"fs=0.05,motor_fs=auto"`` or ``{"fs": 0.05}``; ``shape`` the
    same (``"auto"`` only with the velocity ``"auto"``).  Unset values keep the robot's (:func:`stribeck`).
    SpecError for a value that is not a number > 0 or a term that is not a selected Stribeck term."""
    _robot(robot)
    terms = as_terms(terms)
    names = [n for n in terms.names if n in STRIBECK_TERMS]
    out = {n: stribeck(robot, n) for n in names}
    auto: dict[str, bool] = {}
    for what, spec in (("velocity", velocity), ("shape", shape)):
        if spec is None:
            continue
        for name, value in _spec_items(spec, names, what).items():
            if isinstance(value, str) and value.strip() == "auto":
                if what == "shape" and name not in auto:
                    raise SpecError(
                        f"Stribeck shape of {name} 'auto': fitted only with the velocity 'auto' "
                        "(--stribeck-velocity auto), else expected a number > 0"
                    )
                auto[name] = what == "shape"
                continue
            try:
                number = float(value)
            except (TypeError, ValueError):
                number = None
            if number is None or not np.isfinite(number) or number <= 0:
                raise SpecError(
                    f"Stribeck {what} of {name} {value!r}, expected a number > 0"
                    + (" [rad/s]" if what == "velocity" else "")
                    + " or 'auto'"
                )
            out[name] = Stribeck(**{**out[name].__dict__, what: number})
    return out, auto


#: Old public names and their new ones; they still work for one release (issue 26: the selection holds
#: motor and plug-in terms too, not only joint terms).
_DEPRECATED = {"JointTerms": "TermSelection"}


def __getattr__(name: str):
    if name in _DEPRECATED:
        warnings.warn(f"{name} is deprecated, use {_DEPRECATED[name]}", DeprecationWarning, stacklevel=2)
        return globals()[_DEPRECATED[name]]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
