"""Flexible joints (seed 003): a motor drives the link through a nonlinear spring and a damper.

Any active joint of a URDF can be given a *drive*.  For a **flexible** drive with reduction ratio
``r`` (motor angle / link angle, ``r > 0``), link angle ``q`` and motor angle ``qm`` (motor side), the
deflection and the transmission torque on the link are (seed 003 Eqs. (7)-(10))::

    Δ  = qm/r − q                                   [rad, link side]
    τs = K1·Δ + K2·Δ³ + C·(dqm/r − dq)              [N·m, link side]

the link side is the rigid-body dynamics of the URDF (Pinocchio's, seed Eqs. (11), (13))::

    M(q)·ddq + c(q, dq) + g(q) = τs − b·dq − fcl·σ(dq)

and the motor side (seed Eqs. (12), (14)) is::

    Jm·ddqm = T − (Bm + fv)·dqm − fc·σ(dqm) − τs/r

with ``T`` the motor torque [N·m] (or ``kv·u`` for a voltage ``u`` [V], see below).  A **rigid** drive
locks the motor to the link (``qm = r·q``): the rotor adds ``r²·Jm`` to the joint's inertia and the
link receives ``r·T − r²(Bm + fv)·dq − r·fc·σ(r·dq)``.  Joints without a drive are rigid, ratio 1,
no rotor, with the URDF's friction: they are driven by a joint torque directly.

Parameters of a drive (names ``<joint>.<name>``; the flexible ones only for flexible drives):

========  ===========  ==========================================================================
name      unit         meaning
========  ===========  ==========================================================================
``K1``    N·m/rad      linear spring stiffness (link side); > 0
``K2``    N·m/rad³     cubic spring stiffness; any sign (seed Table 1 has softening, K2 < 0)
``C``     N·m·s/rad    transmission damper; ≥ 0
``Jm``    kg·m²        motor (rotor + pulley) inertia, motor side; > 0 for a flexible drive
``Bm``    N·m·s/rad    motor damping, motor side (also the back-EMF damping kt·ke/R of a voltage drive)
``fv``    N·m·s/rad    motor viscous friction, motor side.  **Only Bm + fv is observable**: both
                       multiply dqm in Eqs. (12) and (14).
``fc``    N·m          motor Coulomb friction, motor side
``b``     N·m·s/rad    link-side viscous friction (the seed's bθ, bα; default: the URDF's damping)
``fcl``   N·m          link-side Coulomb friction (default: the URDF's friction)
``kv``    N·m/V        motor torque per volt, used for voltage input only: ``T = kv·u`` (a DC motor
                       with negligible inductance, kv = kt/R; its back-EMF belongs in Bm)
========  ===========  ==========================================================================

Coulomb friction uses ``σ(v) = tanh(v / coulomb_speed)`` (default ``coulomb_speed`` 0.05 rad/s) instead of
the seed's ``sign(v)``, which a fixed-step integrator cannot follow without chattering.  The smoothing is
part of the model: twins and fits use the same.

After the drive parameters come the 10 standard inertial parameters of every body (pinid's names,
``base.Izz``), so that link inertias (the seed's Jθ = ``base.Izz``, Jα = ``barrel.Iyy``) can be
identified too.

Simulation
----------
:meth:`FlexibleModel.simulate` integrates the model under an input sampled every ``dt`` (held constant
over each sample period) with classical Runge-Kutta 4 at a fixed step ``h = dt / substeps``; ``h`` is the
largest step ≤ ``max_step`` (default 2 ms) that divides ``dt`` with ``h·ω ≤ 0.5`` for the spring
oscillation ``ω`` of the parameters that matter (accuracy) and ``h·ω ≤ 2``, ``h·λ ≤ 2`` for the fastest
decay ``λ`` (damper, friction) of every candidate (stability: RK4's limits are 2.83 and 2.78); see
:meth:`FlexibleModel.choose_step`.  It simulates a whole population of parameter sets ``(P, D)`` at
once.  Two backends compute the link dynamics:

* ``"trig"`` (chains of ≤ 3 revolute joints): ``M(q)`` and ``g(q)`` of a fixed-base revolute chain are
  trigonometric polynomials of degree ≤ 2 (``M``, which does not depend on the first joint) and ≤ 1 (``g``)
  in each joint angle, and linear in the inertial parameters.  Their coefficients are computed once,
  exactly, from Pinocchio's joint-torque regressor on a grid of angles; ``c(q, dq)`` follows from
  ``∂M/∂q`` (Christoffel symbols).  Every step then costs a few dozen numpy operations on ``(P, …)``
  arrays, whatever ``P`` is.
* ``"pinocchio"`` (any URDF): ``pinocchio.aba`` per parameter set per RK4 stage (with the rotor inertia of
  rigid drives as Pinocchio armature) — a Python loop over the population.

``docs/flexible.md`` gives the measured cost of both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from collections.abc import Mapping, Sequence

import numpy as np

from pinid.errors import DataError, JointError, SpecError
from pinid.model.robot import INERTIAL_NAMES, RobotModel
from pinid.flexible.link import PinocchioBatch, TrigDynamics

#: Parameters of a flexible drive, in the order of the parameter vector.
FLEX_PARAMS: tuple[str, ...] = ("K1", "K2", "C", "Jm", "Bm", "fv", "fc", "b", "fcl", "kv")
#: Parameters of a rigid drive (no spring, no damper).
RIGID_PARAMS: tuple[str, ...] = ("Jm", "Bm", "fv", "fc", "b", "fcl", "kv")
#: Units of the drive parameters, for reports.
PARAM_UNITS: dict[str, str] = {
    "K1": "N·m/rad",
    "K2": "N·m/rad³",
    "C": "N·m·s/rad",
    "Jm": "kg·m²",
    "Bm": "N·m·s/rad",
    "fv": "N·m·s/rad",
    "fc": "N·m",
    "b": "N·m·s/rad",
    "fcl": "N·m",
    "kv": "N·m/V",
    "m": "kg",
    "mx": "kg·m",
    "my": "kg·m",
    "mz": "kg·m",
    "Ixx": "kg·m²",
    "Ixy": "kg·m²",
    "Iyy": "kg·m²",
    "Ixz": "kg·m²",
    "Iyz": "kg·m²",
    "Izz": "kg·m²",
}
#: Deflection [rad] used to bound the cubic spring's stiffness when choosing the step.
_DEFLECTION_REF = 0.2
#: Step rules of :meth:`FlexibleModel.choose_step`: ``h·ω ≤ STEP_OSCILLATION`` where accuracy matters,
#: ``h·ω ≤ STEP_STABILITY`` and ``h·λ ≤ STEP_STABILITY`` for every candidate.
STEP_OSCILLATION = 0.5
STEP_STABILITY = 2.0
#: Smallest population the ``"auto"`` backend simulates with the trig backend.
AUTO_TRIG_MIN = 4
_INPUT_KINDS = ("torque", "voltage")


@dataclass(frozen=True)
class Drive:
    """How one joint is driven: ``ratio`` r = motor angle / link angle (> 0), flexible or rigid."""

    joint: str
    ratio: float = 1.0
    flexible: bool = True

    def __post_init__(self) -> None:
        r = self.ratio
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not math.isfinite(r) or r <= 0:
            raise SpecError(f"joint '{self.joint}': ratio {r!r}, expected a positive number (motor angle / link angle)")

    @property
    def param_names(self) -> tuple[str, ...]:
        """Names of this drive's parameters (without the joint prefix)."""
        return FLEX_PARAMS if self.flexible else RIGID_PARAMS


def check_parameter(name: str, value: float, *, flexible: bool, where: str = "") -> None:
    """Raise SpecError if a drive parameter value is physically impossible (see the module table)."""
    if not isinstance(name, str):
        raise SpecError(f"name: got {type(name).__name__}, expected a parameter name such as base.K1")
    base = name.rsplit(".", 1)[-1]
    pre = f"{where}{name}"
    if not math.isfinite(value):
        raise SpecError(f"{pre}: {value!r}, expected a finite number")
    if base == "K1" and value <= 0:
        raise SpecError(f"{pre}: stiffness {value:g} N·m/rad, expected > 0 (a spring that holds the link)")
    if base == "Jm" and flexible and value <= 0:
        raise SpecError(f"{pre}: motor inertia {value:g} kg·m², expected > 0 for a flexible joint")
    if base in ("C", "Jm", "Bm", "fv", "fc", "b", "fcl") and value < 0:
        raise SpecError(f"{pre}: {value:g} {PARAM_UNITS[base]}, expected ≥ 0")
    if base == "kv" and value == 0:
        raise SpecError(f"{pre}: 0 N·m/V, expected a non-zero motor constant")


@dataclass
class FlexSimulation:
    """What :meth:`FlexibleModel.simulate` returns, for ``P`` parameter sets and ``N`` samples.

    ``q``, ``dq``: link angles [rad] and speeds [rad/s], ``(P, N, nv)``; ``qm``, ``dqm``: motor angles and
    speeds on the motor side (``r·q`` for rigid drives), same shape; ``torque``: motor torque [N·m] applied
    ``(N, nv)`` (``kv·u`` for voltage input: ``(P, N, nv)``); ``step``: RK4 step [s]; ``substeps`` per sample.
    ``diverged`` (P,): parameter sets whose state became non-finite (their rows are NaN).
    """

    t: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    qm: np.ndarray
    dqm: np.ndarray
    joints: list[str]
    step: float
    substeps: int
    diverged: np.ndarray
    seconds: float = 0.0

    def single(self, i: int = 0) -> "FlexSimulation":
        """The ``i``-th parameter set as a population of one."""
        s = slice(i, i + 1)
        return FlexSimulation(
            self.t,
            self.q[s],
            self.dq[s],
            self.qm[s],
            self.dqm[s],
            self.joints,
            self.step,
            self.substeps,
            self.diverged[s],
            self.seconds,
        )


# ---------------------------------------------------------------------------------------------- the model
class FlexibleModel:
    """A URDF robot whose joints are driven through flexible or rigid transmissions.

    ``robot``: the :class:`~pinid.model.robot.RobotModel`; ``drives``: one :class:`Drive` per driven joint (others
    get a rigid, ratio-1 drive without rotor: a joint torque input); ``values``: parameter values by name
    (``"base.K1"``), the rest take defaults (K2, C, Bm, fv, fc = 0; b, fcl = the URDF's damping, friction;
    kv = 1; inertial = the URDF's); ``K1`` and ``Jm`` of flexible drives have no default.
    ``coulomb_speed`` [rad/s]: smoothing of the Coulomb friction; ``max_step`` [s]: largest RK4 step;
    ``backend``: ``"auto"`` (``"trig"`` when possible and the population has ≥ 4 sets, else ``"pinocchio"``),
    ``"trig"`` or ``"pinocchio"``.
    """

    def __init__(
        self,
        robot: RobotModel,
        drives: Sequence[Drive] | Mapping[str, Drive],
        values: Mapping[str, float] | None = None,
        *,
        coulomb_speed: float = 0.05,
        max_step: float = 2e-3,
        backend: str = "auto",
    ) -> None:
        self.robot = robot
        drives = list(drives.values()) if isinstance(drives, Mapping) else list(drives)
        by_joint: dict[str, Drive] = {}
        for d in drives:
            if d.joint not in robot.joint_names:
                raise JointError(
                    f"joint '{d.joint}' is not an active joint of {robot.name} "
                    f"(active joints: {', '.join(robot.joint_names)})"
                )
            if d.joint in by_joint:
                raise SpecError(f"joint '{d.joint}': two drives, expected one")
            by_joint[d.joint] = d
        self._declared = set(by_joint)
        self.drives: tuple[Drive, ...] = tuple(
            by_joint.get(j, Drive(j, 1.0, flexible=False)) for j in robot.joint_names
        )
        if not (coulomb_speed > 0 and math.isfinite(coulomb_speed)):
            raise SpecError(f"coulomb_speed {coulomb_speed!r}, expected a positive number [rad/s]")
        if not (max_step > 0 and math.isfinite(max_step)):
            raise SpecError(f"max_step {max_step!r}, expected a positive number [s]")
        self.coulomb_speed = float(coulomb_speed)
        self.max_step = float(max_step)
        if backend not in ("auto", "trig", "pinocchio"):
            raise SpecError(f"backend {backend!r}, expected auto, trig or pinocchio")
        trig_ok = robot.nv <= TrigDynamics.MAX_JOINTS and all(j.kind != "prismatic" for j in robot.joints)
        if backend == "trig" and not trig_ok:
            raise SpecError(
                f"backend 'trig' needs ≤ {TrigDynamics.MAX_JOINTS} revolute joints; {robot.name} has "
                f"{robot.nv} ({', '.join(j.kind for j in robot.joints)}); use 'pinocchio'"
            )
        self.backend = backend
        self._trig = TrigDynamics(robot) if (backend == "trig" or (backend == "auto" and trig_ok)) else None
        # parameter vector: drives, then inertial
        names, defaults = [], []
        for j, d in enumerate(self.drives):
            for p in d.param_names:
                names.append(f"{d.joint}.{p}")
                defaults.append(self._default(j, p))
        names += robot.inertial_names
        defaults += list(robot.inertial_parameters())
        self.names: list[str] = names
        self._index = {n: i for i, n in enumerate(names)}
        vec = np.array(defaults, dtype=float)
        for n, v in (values or {}).items():
            vec[self.index(n)] = float(v)
        for i, n in enumerate(names):
            if np.isnan(vec[i]):
                raise SpecError(f"{n}: no value given, and it has no default")
            j = self.robot.joint_index(n.rsplit(".", 1)[0])
            if n.rsplit(".", 1)[-1] in FLEX_PARAMS:
                check_parameter(n, vec[i], flexible=self.drives[j].flexible)
        self.values = vec
        self._nflex = [j for j, d in enumerate(self.drives) if d.flexible]

    def _default(self, j: int, p: str) -> float:
        d = self.drives[j]
        if p in ("K1",) or (p == "Jm" and d.flexible):
            return float("nan")
        if p == "b":
            return float(self.robot.viscous[j])
        if p == "fcl":
            return float(self.robot.coulomb[j])
        if p == "kv":
            return 1.0
        return 0.0

    # ------------------------------------------------------------------ description
    @property
    def joint_names(self) -> list[str]:
        """Names of the joints, in model order."""
        return self.robot.joint_names

    @property
    def nv(self) -> int:
        """Number of joints."""
        return self.robot.nv

    @property
    def flexible_joints(self) -> list[str]:
        """Names of the joints with a flexible drive."""
        return [self.drives[j].joint for j in self._nflex]

    @property
    def ratios(self) -> np.ndarray:
        """Reduction ratios r = motor angle / link angle, 1 for rigid joints."""
        return np.array([d.ratio for d in self.drives])

    def index(self, name: str) -> int:
        """Position of a parameter in the vector; SpecError (naming the joint or parameter) if unknown."""
        try:
            return self._index[name]
        except KeyError:
            pass
        joint, _, par = name.rpartition(".")
        if joint not in self.robot.joint_names:
            raise JointError(
                f"parameter '{name}': joint '{joint}' is not an active joint of {self.robot.name} "
                f"(active joints: {', '.join(self.robot.joint_names)})"
            )
        d = self.drives[self.robot.joint_index(joint)]
        known = list(d.param_names) + list(INERTIAL_NAMES)
        kind = "flexible" if d.flexible else "rigid"
        raise SpecError(
            f"parameter '{name}': '{par}' is not a parameter of the {kind} joint '{joint}' "
            f"(expected one of {', '.join(known)})"
        )

    def value(self, name: str) -> float:
        """A parameter by name ``<joint>.<K1|K2|C|Jm|…>`` [SI]."""
        return float(self.values[self.index(name)])

    def rigid(self) -> "FlexibleModel":
        """The same robot with every drive rigid (motor locked to the link): seed 003's rigid model.

        Drive parameters other than K1, K2, C keep their values."""
        drives = [Drive(d.joint, d.ratio, flexible=False) for d in self.drives if d.joint in self._declared]
        values = {n: v for n, v in zip(self.names, self.values) if n.rsplit(".", 1)[-1] not in ("K1", "K2", "C")}
        return FlexibleModel(
            self.robot, drives, values, coulomb_speed=self.coulomb_speed, max_step=self.max_step, backend=self.backend
        )

    def describe(self) -> dict:
        """Plain-dict description: drives and parameter values."""
        return {
            "robot": self.robot.name,
            "urdf": str(self.robot.urdf_path),
            "backend": self.backends,
            "coulomb_speed": self.coulomb_speed,
            "max_step": self.max_step,
            "drives": [{"joint": d.joint, "ratio": d.ratio, "flexible": d.flexible} for d in self.drives],
            "values": {n: float(v) for n, v in zip(self.names, self.values)},
        }

    def _use_trig(self, P: int) -> bool:
        """The trig backend for explicit ``"trig"``; for ``"auto"``, when it can and ``P ≥ AUTO_TRIG_MIN`` (below,
        Pinocchio's ABA per set is faster: numpy's per-call overhead dominates a population of 1 to 3)."""
        if self._trig is None:
            return False
        return self.backend == "trig" or P >= AUTO_TRIG_MIN

    @property
    def backends(self) -> str:
        """Which backend runs, in words."""
        if self._trig is None:
            return "pinocchio"
        return "trig" if self.backend == "trig" else f"trig for populations of {AUTO_TRIG_MIN} or more, pinocchio below"

    # ------------------------------------------------------------------ batch parameters
    def _unpack(self, params: np.ndarray) -> dict:
        """Arrays per quantity from a population of full parameter vectors ``(P, D)``."""
        P = params.shape[0]
        nv = self.nv
        col = lambda j, p: params[:, self._index[f"{self.drives[j].joint}.{p}"]]  # noqa: E731
        out = {}
        for p in ("Jm", "Bm", "fv", "fc", "b", "fcl", "kv"):
            out[p] = np.stack([col(j, p) for j in range(nv)], axis=1)
        F = self._nflex
        for p in ("K1", "K2", "C"):
            out[p] = np.stack([col(j, p) for j in F], axis=1) if F else np.zeros((P, 0))
        ni = 10 * nv
        out["theta"] = params[:, -ni:]
        return out

    def rates(self, params: np.ndarray, q0: np.ndarray) -> tuple[float, float]:
        """``(ω, λ)`` over a population ``(P, D)``: the fastest oscillation [rad/s] and the fastest decay [1/s].

        Per flexible joint: the spring's coupled frequency ``ω = √(K·(1/J + 1/(r²Jm)))`` with
        ``K = K1 + 3|K2|·0.2²``; the decay rates of the damper ``C·(1/J + 1/(r²Jm))`` and of the motor friction
        ``(Bm + fv + fc/v_s)/Jm``; per joint the link friction ``(b + fcl/v_s + rigid-drive terms)/J``, where ``J`` is
        the joint's apparent inertia ``1/(M⁻¹)_jj`` at ``q0`` (with the rotor inertia of rigid drives) and ``v_s`` the
        Coulomb smoothing speed (the slope of ``fc·tanh(v/v_s)`` at rest is ``fc/v_s``).
        """
        params = np.atleast_2d(params)
        u = self._unpack(params)
        r = self.ratios
        vs = self.coulomb_speed
        rigid = np.array([not d.flexible for d in self.drives])
        arm = np.where(rigid, r**2 * u["Jm"], 0.0)
        J = np.maximum(self._link_inertia(params, q0, arm), 1e-12)  # (P, nv)
        omega = [np.zeros(len(params))]
        lam = [
            ((u["b"] + u["fcl"] / vs + np.where(rigid, r**2 * (u["Bm"] + u["fv"] + u["fc"] / vs), 0.0)) / J).max(axis=1)
        ]
        F = self._nflex
        if F:
            rF = r[F]
            Jm = np.maximum(u["Jm"][:, F], 1e-12)
            inv = 1.0 / J[:, F] + 1.0 / (rF**2 * Jm)
            K = u["K1"] + 3.0 * np.abs(u["K2"]) * _DEFLECTION_REF**2
            omega.append(np.sqrt(np.maximum(K, 0.0) * inv).max(axis=1))
            lam.append((u["C"] * inv).max(axis=1))
            lam.append(((u["Bm"][:, F] + u["fv"][:, F] + u["fc"][:, F] / vs) / Jm).max(axis=1))

        def top(xs):
            with np.errstate(invalid="ignore"):
                a = np.max(np.stack(xs), axis=0)
            a = a[np.isfinite(a)]
            return float(a.max()) if a.size else 0.0

        return top(omega), top(lam)

    def _link_inertia(self, params: np.ndarray, q0: np.ndarray, arm: np.ndarray) -> np.ndarray:
        """Apparent inertia of every joint at ``q0``, ``1/(M⁻¹)_jj`` ``(P, nv)`` (rotor inertia of rigid drives included)."""
        u = self._unpack(params)
        P = len(params)
        if self._trig is not None:
            Mc, Gc = self._trig.coefficients(u["theta"], arm)
            M, _ = self._trig.terms(Mc, Gc, np.broadcast_to(q0, (P, self.nv)).copy(), np.zeros((P, self.nv)))
        else:
            M = PinocchioBatch(self.robot, u["theta"], arm).mass_matrix(q0)
        with np.errstate(all="ignore"):
            return 1.0 / np.diagonal(np.linalg.inv(M), axis1=1, axis2=2)

    def choose_step(
        self, dt: float, params: np.ndarray, q0: np.ndarray, *, accuracy: np.ndarray | None = None
    ) -> tuple[float, int]:
        """``(h, substeps)``: the RK4 step for sample period ``dt`` and a population ``(P, D)``.

        Stability for every parameter set of ``params``: ``h·ω ≤ 2`` and ``h·λ ≤ 2`` (RK4 is stable up to 2.83
        on the imaginary axis and 2.78 on the real one), with ``(ω, λ)`` from :meth:`rates`; accuracy for the
        parameter sets ``accuracy`` (default: ``params``): ``h·ω ≤ 0.5`` (RK4's phase error per step is about
        (hω)⁵/120); ``h ≤ max_step``; ``h`` divides ``dt``."""
        omega, lam = self.rates(params, q0)
        hmax = self.max_step
        if omega > 0:
            hmax = min(hmax, STEP_STABILITY / omega)
        if lam > 0:
            hmax = min(hmax, STEP_STABILITY / lam)
        if accuracy is not None:
            omega_a, _ = self.rates(accuracy, q0)
            if omega_a > 0:
                hmax = min(hmax, STEP_OSCILLATION / omega_a)
        elif omega > 0:
            hmax = min(hmax, STEP_OSCILLATION / omega)
        n = max(1, int(math.ceil(dt / hmax - 1e-9)))
        return dt / n, n

    # ------------------------------------------------------------------ simulation
    def simulate(
        self,
        u: np.ndarray,
        dt: float,
        params: np.ndarray | None = None,
        *,
        q0: np.ndarray | None = None,
        input: str = "torque",
        step: float | None = None,
    ) -> FlexSimulation:
        """Simulate a population under the input ``u`` ``(N, nv)`` sampled every ``dt`` [s] (held constant).

        ``params``: full parameter vectors ``(D,)`` or ``(P, D)`` (default: this model's values).
        ``q0``: initial link angles ``(nv,)`` [rad] (default 0); the run starts at rest with every spring
        deflected to hold its link against gravity (``K1·Δ + K2·Δ³ = g(q0)``), motors at ``r·(q0 + Δ)``.
        ``input``: ``"torque"`` (``u`` in N·m at the motor) or ``"voltage"`` (``u`` in V, ``T = kv·u``).
        ``step``: RK4 step [s] (default: :meth:`choose_step`); it is rounded down to divide ``dt``.
        """
        import time

        start = time.perf_counter()
        nv = self.nv
        if input not in _INPUT_KINDS:
            raise SpecError(f"input {input!r}, expected torque or voltage")
        u = np.asarray(u, dtype=float)
        if u.ndim != 2 or u.shape[1] != nv:
            raise DataError(f"input has shape {u.shape}, expected (N, {nv}) for joints {self.joint_names}")
        if u.shape[0] < 2:
            raise DataError(f"input has {u.shape[0]} sample(s), expected at least 2")
        if not np.all(np.isfinite(u)):
            raise DataError("input contains NaN or infinite values")
        if not (dt > 0 and math.isfinite(dt)):
            raise DataError(f"sample period dt {dt!r}, expected a positive number [s]")
        params = self.values[None, :] if params is None else np.atleast_2d(np.asarray(params, dtype=float))
        if params.shape[1] != len(self.names):
            raise ValueError(f"expected parameter vectors of {len(self.names)} values, got shape {params.shape}")
        P, N = params.shape[0], u.shape[0]
        q0 = np.zeros(nv) if q0 is None else np.asarray(q0, dtype=float).reshape(nv)
        if step is None:
            h, sub = self.choose_step(dt, params, q0)
        else:
            if not step > 0:
                raise SpecError(f"step {step!r}, expected a positive number [s]")
            sub = max(1, int(math.ceil(dt / step - 1e-9)))
            h = dt / sub

        par = self._unpack(params)
        r = self.ratios
        F = np.array(self._nflex, dtype=int)
        nF = len(F)
        rigid = np.array([not d.flexible for d in self.drives])
        R = np.flatnonzero(rigid)
        vs = self.coulomb_speed
        arm = np.where(rigid, r**2 * par["Jm"], 0.0)  # (P, nv)
        if input == "voltage":
            torque = par["kv"][:, None, :] * u[None, :, :]  # (P, N, nv)
        else:
            torque = np.broadcast_to(u[None, :, :], (P, N, nv))

        if self._use_trig(P):
            theta = par["theta"]
            shared = np.all(theta == theta[:1]) and np.all(arm == arm[:1])
            if shared:
                Mc, Gc = self._trig.coefficients(theta[0], arm[0])
            else:
                Mc, Gc = self._trig.coefficients(theta, arm)
            trig = self._trig

            def link_acc(q, dq, tau):
                return trig.forward(Mc, Gc, q, dq, tau)

            g0 = trig.terms(Mc, Gc, np.broadcast_to(q0, (P, nv)).copy(), np.zeros((P, nv)))[1]
        else:
            batch = PinocchioBatch(self.robot, par["theta"], arm)
            link_acc = batch.forward
            g0 = batch.gravity(q0)

        rF = r[F] if nF else np.zeros(0)
        rR = r[R]
        K1, K2, Cd = par["K1"], par["K2"], par["C"]
        JmF = par["Jm"][:, F] if nF else np.zeros((P, 0))
        BF = (par["Bm"] + par["fv"])[:, F] if nF else np.zeros((P, 0))
        fcF = par["fc"][:, F] if nF else np.zeros((P, 0))
        b, fcl = par["b"], par["fcl"]
        BR = (rR**2) * (par["Bm"] + par["fv"])[:, R]
        fcR = rR * par["fc"][:, R]
        all_flex = nF == nv
        no_fcl = not np.any(fcl)

        def rhs(y, T):
            q, dq = y[:, :nv], y[:, nv : 2 * nv]
            tau = -b * dq
            if not no_fcl:
                tau = tau - fcl * np.tanh(dq / vs)
            if nF:
                qm, dqm = y[:, 2 * nv : 2 * nv + nF], y[:, 2 * nv + nF :]
                qF = q if all_flex else q[:, F]
                dqF = dq if all_flex else dq[:, F]
                d = qm / rF - qF
                dd = dqm / rF - dqF
                ts = K1 * d + K2 * d * d * d + Cd * dd
                if all_flex:
                    tau = tau + ts
                else:
                    tau[:, F] += ts
                TF = T if all_flex else T[:, F]
                ddqm = (TF - BF * dqm - fcF * np.tanh(dqm / vs) - ts / rF) / JmF
            if len(R):
                dqR = dq[:, R]
                tau[:, R] += rR * T[:, R] - BR * dqR - fcR * np.tanh(rR * dqR / vs)
            ddq = link_acc(q, dq, tau)
            if nF:
                return np.concatenate([dq, ddq, dqm, ddqm], axis=1)
            return np.concatenate([dq, ddq], axis=1)

        # initial state: at rest, springs holding the links against gravity
        y = np.zeros((P, 2 * nv + 2 * nF))
        y[:, :nv] = q0
        if nF:
            gF = g0[:, F]
            with np.errstate(all="ignore"):
                d0 = gF / K1
                for _ in range(20):  # Newton on K1·Δ + K2·Δ³ = g
                    fp = K1 + 3 * K2 * d0**2
                    step_ = (K1 * d0 + K2 * d0**3 - gF) / np.where(np.abs(fp) > 1e-12, fp, 1e-12)
                    d0 = d0 - step_
            y[:, 2 * nv : 2 * nv + nF] = rF * (q0[F] + d0)

        out = np.empty((N, P, y.shape[1]))
        out[0] = y
        half = 0.5 * h
        with np.errstate(all="ignore"):
            for k in range(N - 1):
                T = torque[:, k, :]
                for _ in range(sub):
                    k1 = rhs(y, T)
                    k2 = rhs(y + half * k1, T)
                    k3 = rhs(y + half * k2, T)
                    k4 = rhs(y + h * k3, T)
                    y = y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
                out[k + 1] = y
        out = np.moveaxis(out, 0, 1)  # (P, N, ns)
        diverged = ~np.all(np.isfinite(out), axis=(1, 2))
        out[diverged] = np.nan
        q, dq = out[:, :, :nv], out[:, :, nv : 2 * nv]
        qm = r * q
        dqm = r * dq
        if nF:
            qm[:, :, F] = out[:, :, 2 * nv : 2 * nv + nF]
            dqm[:, :, F] = out[:, :, 2 * nv + nF :]
        t = np.arange(N) * dt
        return FlexSimulation(t, q, dq, qm, dqm, list(self.joint_names), h, sub, diverged, time.perf_counter() - start)


def flexible_model(
    urdf,
    drives: Mapping[str, Mapping[str, float]] | None = None,
    *,
    values: Mapping[str, float] | None = None,
    **options,
) -> FlexibleModel:
    """Convenience: ``flexible_model("tracker_2dof", {"base": {"ratio": 3, "K1": 91.66, "Jm": 0.0074}, ...})``.

    Each joint's mapping holds ``ratio`` (default 1), ``flexible`` (default True) and parameter values.
    """
    robot = urdf if isinstance(urdf, RobotModel) else RobotModel.from_urdf(urdf)
    ds, vals = [], dict(values or {})
    for joint, d in (drives or {}).items():
        d = dict(d)
        ds.append(Drive(joint, float(d.pop("ratio", 1.0)), bool(d.pop("flexible", True))))
        vals.update({f"{joint}.{k}": v for k, v in d.items()})
    return FlexibleModel(robot, ds, vals, **options)
