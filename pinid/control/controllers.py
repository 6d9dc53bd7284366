"""Model-based controllers built on a dynamics model, and a closed-loop simulation to compare them.

A *dynamics model* is anything with ``mass_matrix(q)``, ``coriolis(q, dq)``, ``gravity(q)`` and
``friction(dq)`` — an :class:`~pinid.identification.identified.IdentifiedModel` from ``pinid identify``, or
:func:`nominal_model` of a URDF.  A *controller* maps ``(t, q, dq)`` and the reference
``(q_d, dq_d, ddq_d)`` to a joint torque [N·m].

* :class:`Backstepping` — seed 001, Eqs. (24)–(25):
  δ1 = q − q_d,  α = −K1·δ1 + dq_d,  δ2 = dq − α,
  τ = −δ1 − K2·δ2 + G(q) + C(q, dq)·α + f(dq) + H(q)·α̇,  α̇ = −K1·(dq − dq_d) + ddq_d.
  With an exact model, V = ½δ1ᵀδ1 + ½δ2ᵀHδ2 decreases: V̇ = −δ1ᵀK1δ1 − δ2ᵀK2δ2 (seed 001 Eq. (30);
  the paper's Eq. (26) misprints V1 as ½δ1ᵀδ2).
* :class:`ComputedTorque` — τ = H(q)·(ddq_d + Kd·(dq_d − dq) + Kp·(q_d − q)) + C(q, dq)·dq + G(q) + f(dq).

Friction compensation: ``friction_from="desired"`` (the default) evaluates f at the reference velocity
dq_d; ``"measured"`` at the measured dq, as the equations are printed.  At a velocity reversal the
measured velocity hovers around zero and its sign flips with noise, so compensating Coulomb friction
with it pushes the joint the wrong way for as long as the joint sticks (on exo_leg's knee, 0.9 N·m
against a computed-torque stiffness of about 14 N·m/rad: 0.06 rad of error).  The reference velocity
has a clean sign.  With an exact model and ``"measured"``, the Lyapunov decrease of Eq. (30) holds
exactly; with ``"desired"`` it holds away from reversals.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from collections.abc import Mapping
from typing import Protocol

import numpy as np

from pinid.checks import count, number
from pinid.errors import SpecError
from pinid.model.robot import RobotModel
from pinid.errors import SolverError
from pinid.identification.result import Identification
from pinid.identification.run import identify
from pinid.identification.study import Study
from pinid.identification.identified import IdentifiedModel
from pinid.io import read_json
from pinid.model.base import base_parameters
from pinid.model.regressor import standard_parameters
from pinid.model.terms import TermSelection
from pinid.simulation.plant import Plant
from pinid.simulation.twin import WearerLoad, plant_terms, simulate
from pinid.simulation.cad import perturb
from pinid.model.robot import as_robot
from pinid.result_protocol import ResultProtocol, panel


class DynamicsModel(Protocol):
    """What a model-based controller needs from a model."""

    def mass_matrix(self, q: np.ndarray) -> np.ndarray:
        """Joint-space mass matrix M(q) (nv, nv) [kg·m²]."""

    def coriolis(self, q: np.ndarray, dq: np.ndarray) -> np.ndarray:
        """Coriolis matrix C(q, dq) (nv, nv) with C·dq the velocity torques [N·m]."""

    def gravity(self, q: np.ndarray) -> np.ndarray:
        """Gravity torque g(q) (nv,) [N·m]."""

    def friction(self, dq: np.ndarray) -> np.ndarray:
        """Friction torque f(dq) (nv,) [N·m]."""


def nominal_model(robot: RobotModel, *, friction: bool = True):
    """The URDF's own parameters as a dynamics model; ``friction=False`` ignores its ``<dynamics>``."""
    terms = TermSelection() if friction else TermSelection(coulomb=False, viscous=False)
    return IdentifiedModel(robot, terms, standard_parameters(robot, terms), meta={"method": "nominal"})


def _check_friction_from(value: str) -> None:
    if value not in ("desired", "measured"):
        raise SpecError(f"friction_from {value!r}, expected 'desired' or 'measured'")


def _gain(value, nv: int, name: str) -> np.ndarray:
    K = np.asarray(value, dtype=float)
    K = np.diag(np.full(nv, float(K))) if K.ndim == 0 else (np.diag(K) if K.ndim == 1 else K)
    if K.shape != (nv, nv):
        raise SpecError(f"gain {name}: shape {K.shape}, expected a number, {nv} numbers or a {nv}×{nv} matrix")
    if not np.allclose(K, K.T) or np.linalg.eigvalsh(K).min() <= 0:
        raise SpecError(f"gain {name} must be symmetric positive definite")
    return K


@dataclass
class Backstepping:
    """Seed 001's backstepping controller on ``model``; K1 [1/s], K2 [N·m·s/rad] positive definite."""

    model: DynamicsModel
    K1: np.ndarray | float = 10.0
    K2: np.ndarray | float = 30.0
    friction_from: str = "desired"
    nv: int = 0

    def __post_init__(self) -> None:
        self.nv = self.nv or len(self.model.gravity(np.zeros(len(self.model.joint_names))))
        _check_friction_from(self.friction_from)
        self.K1 = _gain(self.K1, self.nv, "K1")
        self.K2 = _gain(self.K2, self.nv, "K2")

    def errors(self, q, dq, q_d, dq_d) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(δ1, δ2, α)`` of seed 001 Eq. (24)."""
        d1 = q - q_d
        alpha = -self.K1 @ d1 + dq_d
        return d1, dq - alpha, alpha

    def __call__(
        self, t: float, q: np.ndarray, dq: np.ndarray, q_d: np.ndarray, dq_d: np.ndarray, ddq_d: np.ndarray
    ) -> np.ndarray:
        d1, d2, alpha = self.errors(q, dq, q_d, dq_d)
        alpha_dot = -self.K1 @ (dq - dq_d) + ddq_d
        m = self.model
        f = m.friction(dq_d if self.friction_from == "desired" else dq)
        return -d1 - self.K2 @ d2 + m.gravity(q) + m.coriolis(q, dq) @ alpha + f + m.mass_matrix(q) @ alpha_dot

    def lyapunov(self, q, dq, q_d, dq_d) -> float:
        """V = ½δ1ᵀδ1 + ½δ2ᵀHδ2 (seed 001 Eq. (28)) with this controller's model."""
        d1, d2, _ = self.errors(q, dq, q_d, dq_d)
        return float(0.5 * d1 @ d1 + 0.5 * d2 @ self.model.mass_matrix(q) @ d2)


@dataclass
class ComputedTorque:
    """Inverse dynamics plus PD on ``model``; Kp [1/s²], Kd [1/s] positive definite (default critically
    damped, ωn = 20 rad/s: Kp = 400, Kd = 2√Kp = 40)."""

    model: DynamicsModel
    Kp: np.ndarray | float = 400.0
    Kd: np.ndarray | float = 40.0
    friction_from: str = "desired"
    nv: int = 0

    def __post_init__(self) -> None:
        self.nv = self.nv or len(self.model.gravity(np.zeros(len(self.model.joint_names))))
        _check_friction_from(self.friction_from)
        self.Kp = _gain(self.Kp, self.nv, "Kp")
        self.Kd = _gain(self.Kd, self.nv, "Kd")

    def __call__(self, t, q, dq, q_d, dq_d, ddq_d) -> np.ndarray:
        m = self.model
        v = ddq_d + self.Kd @ (dq_d - dq) + self.Kp @ (q_d - q)
        f = m.friction(dq_d if self.friction_from == "desired" else dq)
        return m.mass_matrix(q) @ v + m.coriolis(q, dq) @ dq + m.gravity(q) + f


#: Controllers by name, for the CLI.
CONTROLLERS = {"backstepping": Backstepping, "computed-torque": ComputedTorque}


@dataclass
class TrackingResult(ResultProtocol):
    """A closed-loop run: time [s], reference, measured state, applied torque, per-joint error figures."""

    t: np.ndarray
    q_d: np.ndarray
    q: np.ndarray
    dq: np.ndarray
    tau: np.ndarray
    joints: list[str]
    lyapunov: np.ndarray | None = None
    meta: dict = field(default_factory=dict)

    @property
    def error(self) -> np.ndarray:
        """Tracking error q − q_d [rad], (N, nv)."""
        return self.q - self.q_d

    PLOTS = {"tracking": False, "error": True}
    FILE_KIND = "tracking result"

    def _plot(self, kind: str, ax):
        """``"tracking"``: one column per joint; rows: position against the reference (dashed) [rad], error
        [mrad], torque [N·m] (:func:`pinid.report.plot_control.tracking_figure`); ``"error"``: every joint's
        tracking error [mrad] in one panel."""
        if kind == "tracking":
            from pinid.report.plot_control import tracking_figure  # loads matplotlib: on use only

            return tracking_figure({"tracked": self})
        fig, ax = panel(ax)
        for j, name in enumerate(self.joints):
            ax.plot(self.t, 1e3 * self.error[:, j], lw=0.9, label=name)
        ax.set_xlabel("time [s]")
        ax.set_ylabel("tracking error [mrad]")
        ax.set_title("tracking error q − q_d")
        ax.legend(fontsize=8)
        fig.tight_layout()
        return fig

    def to_dict(self) -> dict:
        """Plain-JSON form: the time series as lists (rows: samples), the joints and ``meta``."""
        return {
            "joints": list(self.joints),
            "t": self.t.tolist(),
            "q_d": self.q_d.tolist(),
            "q": self.q.tolist(),
            "dq": self.dq.tolist(),
            "tau": self.tau.tolist(),
            "lyapunov": None if self.lyapunov is None else self.lyapunov.tolist(),
            "meta": dict(self.meta),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "TrackingResult":
        """Inverse of :meth:`to_dict`."""
        nv = len(d["joints"])
        arr = lambda k: np.asarray(d[k], dtype=float).reshape(-1, nv)
        return cls(
            np.asarray(d["t"], dtype=float),
            arr("q_d"),
            arr("q"),
            arr("dq"),
            arr("tau"),
            [str(j) for j in d["joints"]],
            None if d.get("lyapunov") is None else np.asarray(d["lyapunov"], dtype=float),
            dict(d.get("meta") or {}),
        )

    def text(self) -> str:
        """Per joint: RMS and max |error| [mrad] and the settling time [s] (:meth:`metrics`)."""
        from pinid.report.text import text_table

        rows = [
            [j, f"{1e3 * m['rms']:.4g}", f"{1e3 * m['max_abs']:.4g}", f"{m['settling_time']:.3g}"]
            for j, m in self.metrics().items()
        ]
        return text_table(["joint", "RMS [mrad]", "max |e| [mrad]", "settling [s]"], rows)

    def metrics(self, *, after: float = 0.0, band: float | None = None) -> dict[str, dict[str, float]]:
        """Per joint: RMS and max |error| [rad] after ``after`` s, and settling time [s] — the first time
        after which |error| stays inside ``band`` (default: 2 % of the joint's reference range, at least
        1 mrad); NaN if it never settles."""
        keep = self.t >= after
        out = {}
        for j, name in enumerate(self.joints):
            e = self.error[:, j]
            b = band if band is not None else max(0.02 * np.ptp(self.q_d[:, j]), 1e-3)
            outside = np.flatnonzero(np.abs(e) > b)
            if outside.size == 0:
                settle = 0.0
            elif outside[-1] == len(e) - 1:
                settle = float("nan")
            else:
                settle = float(self.t[outside[-1] + 1] - self.t[0])
            out[name] = {
                "rms": float(np.sqrt(np.mean(e[keep] ** 2))),
                "max_abs": float(np.abs(e[keep]).max()),
                "settling_time": settle,
                "band": float(b),
            }
        return out


@dataclass(frozen=True)
class Tracking:
    """How a closed-loop run is simulated (:func:`track`): ``seconds`` [s] of it; the controller's ``rate``
    [Hz], the plant integrated at ``rate·substeps`` [Hz] with Coulomb friction fc·tanh(dq/``coulomb_velocity``
    [rad/s]); the torque clipped to ``torque_limit`` [N·m] (None: the URDF's effort limits); Gaussian
    measurement noise σ ``position_noise`` [rad] and ``velocity_noise`` [rad/s], seeded by ``seed``."""

    seconds: float
    rate: float = 1000.0
    substeps: int = 4
    coulomb_velocity: float = 0.01
    torque_limit: np.ndarray | float | None = None
    position_noise: float = 0.0
    velocity_noise: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        number(self.seconds, "seconds", low=0, low_open=True)
        number(self.rate, "rate", low=0, low_open=True)
        count(self.substeps, "substeps", low=1)
        number(self.coulomb_velocity, "coulomb_velocity", low=0, low_open=True)
        number(self.position_noise, "position_noise", low=0)
        number(self.velocity_noise, "velocity_noise", low=0)
        count(self.seed, "seed")


def track(
    plant: RobotModel,
    controller,
    reference,
    run: Tracking,
    *,
    q0: np.ndarray | None = None,
    lyapunov: bool = False,
    terms: dict | None = None,
    disturbance=None,
    wearer: Mapping | None = None,
) -> TrackingResult:
    """Simulate ``plant`` (a URDF model with its true friction) under ``controller`` following ``reference``
    as ``run`` (:class:`Tracking`: duration, rates, torque limit, noise, seed) says.

    ``reference`` has ``evaluate(t) -> (q, dq, ddq)`` (a :class:`~pinid.excitation.trajectory.FourierTrajectory`).
    The controller runs at ``run.rate`` [Hz] on noisy measurements; its torque is held for the period
    (zero-order hold) and clipped to ``run.torque_limit``.  The plant is the digital twin's
    (:class:`pinid.simulation.plant.Plant`: ABA-equivalent dynamics, Coulomb friction,
    implicit when stiff) integrated at ``rate·substeps`` [Hz].  Starts at ``q0`` (default the reference at
    t = 0) at rest.  Seeded: the same arguments give the same run.  ``terms``: the plant's extra joint
    terms (:func:`pinid.simulation.twin.plant_terms`; default the wearer's passive moments when ``wearer``, the
    segments strapped to the plant as :func:`pinid.simulation.twin.simulate` takes them, is given);
    ``disturbance(t) -> (nv,)`` [N·m]: a torque acting on the plant besides the controller's (e.g. the
    wearer's, :func:`pinid.simulation.twin.wearer_disturbance`).
    """
    plant = as_robot(plant)
    if not isinstance(run, Tracking):
        raise SpecError(f"run: got {type(run).__name__}, expected a pinid.control.controllers.Tracking(seconds=…)")
    seconds, rate, substeps, seed = run.seconds, run.rate, run.substeps, run.seed
    torque_limit, coulomb_velocity = run.torque_limit, run.coulomb_velocity
    position_noise, velocity_noise = run.position_noise, run.velocity_noise
    rng = np.random.default_rng(seed)
    nv = plant.nv
    limit = plant.effort_limit if torque_limit is None else np.broadcast_to(np.asarray(torque_limit, float), (nv,))
    low = -limit
    dynamics = Plant(plant, plant.coulomb, plant.viscous, coulomb_velocity, plant_terms(plant, terms, wearer))
    n = int(round(seconds * rate))
    t = np.arange(n) / rate
    q_d, dq_d, ddq_d = reference.evaluate(t)
    q = q_d[0].copy() if q0 is None else np.asarray(q0, dtype=float).copy()
    dq = np.zeros(nv)
    h = 1.0 / (rate * substeps)
    Q, DQ, TAU = np.empty((n, nv)), np.empty((n, nv)), np.empty((n, nv))
    V = np.empty(n) if lyapunov else None
    for k in range(n):
        q_meas = q + rng.normal(0.0, position_noise, nv) if position_noise else q
        dq_meas = dq + rng.normal(0.0, velocity_noise, nv) if velocity_noise else dq
        tau = np.asarray(controller(t[k], q_meas, dq_meas, q_d[k], dq_d[k], ddq_d[k]), dtype=float).clip(low, limit)
        Q[k], DQ[k], TAU[k] = q, dq, tau
        if lyapunov:
            V[k] = controller.lyapunov(q, dq, q_d[k], dq_d[k])
        applied = tau if disturbance is None else tau + disturbance(t[k])
        for _ in range(substeps):
            _, q, dq = dynamics.step(q, dq, applied, h)
        if not (np.isfinite(q).all() and np.isfinite(dq).all()):  # array methods: the np.* wrappers cost more
            raise SolverError(f"closed loop diverged at t = {t[k]:.3f} s; lower the gains or raise the rate")
    return TrackingResult(
        t,
        q_d,
        Q,
        DQ,
        TAU,
        plant.joint_names,
        V,
        meta={"rate": rate, "substeps": substeps, "seconds": seconds, "seed": seed},
    )


def load_controller_model(spec: str, plant: RobotModel, *, friction: bool = True, seed: int = 0):
    """A dynamics model from ``spec``: ``nominal`` (the plant's URDF), ``cad:PERCENT`` (the plant's inertial
    parameters about PERCENT % off, :func:`pinid.simulation.twin.perturb` seeded by ``seed``, friction ignored — what
    a CAD model knows), a URDF file, an identified model (``model_<method>.json``) or an identification
    (``identification.json``: its best result)."""
    if not isinstance(spec, str):
        raise SpecError(f"spec: got {type(spec).__name__}, expected nominal, cad:PERCENT, a URDF or a model JSON")
    from pathlib import Path

    if spec == "nominal":
        return nominal_model(plant, friction=friction)
    if spec.startswith("cad:"):
        try:
            percent = float(spec[4:])
        except ValueError:
            raise SpecError(f"{spec}: expected cad:PERCENT with a number, e.g. cad:30") from None
        return nominal_model(perturb(plant, percent, np.random.default_rng(seed)), friction=False)
    p = Path(spec)
    if not p.is_file():
        raise SpecError(f"{spec}: no such file; expected 'nominal', a URDF, model_<method>.json or identification.json")
    if p.suffix.lower() == ".urdf":
        robot = RobotModel.from_urdf(p, joints=plant.joint_names, locked=plant.locked or None)
        _check_same_joints(spec, robot, plant)
        return nominal_model(robot, friction=friction)
    d = read_json(p, "controller model")
    model = Identification.from_dict(d).model if "methods" in d else IdentifiedModel.from_dict(d)
    _check_same_joints(spec, model.robot, plant)
    if not model.physically_consistent:
        raise SpecError(
            f"{spec}: the model is not physically consistent (a body's pseudo-inertia or a friction "
            "value is negative: its mass matrix can be indefinite and the controller diverge); "
            "expected a consistent model, e.g. the sdp result"
        )
    return model


def _check_same_joints(spec: str, robot: RobotModel, plant: RobotModel) -> None:
    """SpecError unless ``robot`` has the plant's joints, in its order, each of the same kind (a prismatic
    joint is not a revolute one; continuous and revolute joints both rotate)."""
    if robot.joint_names != plant.joint_names:
        raise SpecError(f"{spec}: model joints {robot.joint_names}, expected the plant's {plant.joint_names}")
    for a, b in zip(robot.joints, plant.joints):
        if (a.kind == "prismatic") != (b.kind == "prismatic"):
            raise SpecError(
                f"{spec}: joint '{a.name}' is {a.kind} in the model but {b.kind} in the plant; "
                "expected a model of the same robot"
            )


def compare_models(
    plant: RobotModel,
    models: dict,
    reference,
    *,
    controllers: tuple[str, ...] = ("backstepping", "computed-torque"),
    seconds: float = 8.0,
    after: float = 2.0,
    position_noise: float = 2e-5,
    seed: int = 0,
    wearer: Mapping | None = None,
) -> dict:
    """Track ``reference`` on ``plant`` with every controller on every model; same noise seed for all
    (``wearer``: the segments strapped to the plant, as :func:`track` takes them).

    Returns ``{controller: {model_name: {"metrics": per-joint dict, "result": TrackingResult}}}``;
    metrics are taken after ``after`` [s] (the start-up transient excluded)."""
    plant = as_robot(plant)
    for c in controllers:
        if c not in CONTROLLERS:
            raise SpecError(f"controller {c!r}, expected one of {sorted(CONTROLLERS)}")
    jobs = [(c, name, model) for c in controllers for name, model in models.items()]

    def run(job: int) -> TrackingResult:
        c, _, model = jobs[job]
        return track(
            plant,
            CONTROLLERS[c](model),
            reference,
            Tracking(seconds, position_noise=position_noise, seed=seed),
            wearer=wearer,
        )

    out: dict = {c: {} for c in controllers}
    for (c, name, _), r in zip(jobs, _in_parallel(run, len(jobs))):
        out[c][name] = {"metrics": r.metrics(after=after), "result": r}
    return out


def _call(run, i: int):
    return run(i)


def _in_parallel(run, n: int) -> list:
    """``[run(0), …, run(n − 1)]``: independent, deterministic runs (each its own seeded noise), in forked
    worker processes, one per core, on Linux (:func:`pinid.parallel.run_parallel`: the inputs are inherited,
    the results sent back); one after the other elsewhere, on one core, or for one job.  The same results
    either way."""
    import sys
    import warnings

    from pinid.parallel import default_workers, run_parallel

    workers = min(n, default_workers()) if sys.platform.startswith("linux") else 1
    with warnings.catch_warnings():  # Python ≥ 3.12 warns about fork with threads (BLAS)
        warnings.simplefilter("ignore", DeprecationWarning)
        return run_parallel(_call, run, list(range(n)), workers=workers)


def identified_vs_cad(
    plant: RobotModel,
    excitation,
    reference,
    *,
    percent: float = 30.0,
    record_seconds: float = 60.0,
    track_seconds: float = 8.0,
    method: str = "sdp",
    seed: int = 0,
    wearer: Mapping | None = None,
) -> dict:
    """Issue 7's experiment: does identification make the controllers better than a CAD model?

    1. A "CAD" model: ``plant``'s inertial parameters perturbed by about ``percent`` % (physically
       consistent, :func:`pinid.simulation.twin.perturb`) and friction ignored.
    2. Two twin recordings of ``plant`` following ``excitation`` (PD + CAD feed-forward, default noise):
       one to identify with ``method``, one (another seed, another period phase) to validate.
    3. Both controllers track ``reference`` on ``plant`` with the CAD and with the identified model.

    Returns ``{"table": compare_models(...), "identification": Identification, "cad_base_error_percent":
    ..., "identified_base_error_percent": ...}`` (relative errors of the base parameters [%]).  ``wearer``:
    the segments strapped to ``plant``, as :func:`pinid.simulation.twin.simulate` takes them."""
    plant = as_robot(plant)
    rng = np.random.default_rng(seed)
    cad_robot = perturb(plant, percent, rng)
    cad = nominal_model(cad_robot, friction=False)
    carried = None if wearer is None else WearerLoad(dict(wearer) if isinstance(wearer, Mapping) else wearer)
    run = dict(feedforward_model=cad_robot, wearer=carried)
    train, _ = simulate(plant, excitation, seconds=record_seconds, seed=seed + 1, **run)
    valid, _ = simulate(plant, excitation, seconds=record_seconds / 2, seed=seed + 2, **run)
    ident = identify(Study(plant, train, validate=valid), [method])
    terms = TermSelection()
    bp = base_parameters(plant, terms)
    truth = bp.from_standard(standard_parameters(plant, terms))
    cad_base = bp.from_standard(
        standard_parameters(cad_robot, TermSelection()) * np.r_[np.ones(10 * plant.nv), np.zeros(2 * plant.nv)]
    )
    rel = lambda x: (100 * np.abs(x - truth) / np.maximum(np.abs(truth), 1e-9)).tolist()  # noqa: E731
    models = {f"CAD ({percent:g} % off, no friction)": cad, f"identified ({method})": ident[method].model}
    table = compare_models(plant, models, reference, seconds=track_seconds, seed=seed, wearer=wearer)
    return {
        "table": table,
        "identification": ident,
        "base_names": bp.names,
        "cad_base_error_percent": rel(cad_base),
        "identified_base_error_percent": rel(ident[method].base),
    }
