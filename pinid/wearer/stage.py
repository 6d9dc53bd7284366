"""Stage 2 of the wearer workflow: identify only the wearer, the exoskeleton fixed from stage 1.

Stage 1 is ``pinid identify`` on the exoskeleton alone (no wearer).  Stage 2 takes a recording with
the wearer strapped in, subtracts the torque the stage-1 model predicts for the exo (rigid body,
friction, every term it has), and fits what is left with the wearer's own parameters only: the
standard inertial parameters each exo body gains from its segments (``θ_w``, about the joint frame)
and, optionally, the scale factors ``kp`` of the passive joint moments (Riener & Edrich 1999).

Problem (:class:`~pinid.model.conic.ConicProblem`, Clarabel, on the compressed regressor ``R`` from ``QR([W y])``, never the tall one)::

    minimise  ‖R·θ − Qᵀy‖ + 10⁻³·‖V₀ᵀ S⁻¹(θ − θ_table)‖ + λ·σ₁·‖S⁻¹(θ − θ_table)‖
    subject to  pseudo-inertia(θ_w,body) ⪰ 0,  (1 − ρ)·m_table ≤ m ≤ (1 + ρ)·m_table,
                CoM inside the segment (linear in m and m·c),  kp ≥ 0

``V₀`` spans the directions the data cannot see (the null space of ``R S``), so the tables decide
exactly what the data cannot; with ``λ = 0`` the data alone decide the rest (noise-free, the wearer's
base parameters come back exactly).  ``λ > 0`` also pulls the identifiable directions toward the table
(useful for a short, poorly exciting recording).  The default ``λ = "auto"`` chooses it from
:data:`PRIOR_WEIGHTS` by blocked cross-validation on the recording itself (:func:`choose_prior_weight`):
on exact data that is 0.  ``S`` scales the parameters (per body: table mass, mass × segment length,
mass × length²; ``kp``: 1).
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pinid.checks import as_floats, count
from pinid.data.dataset import as_dataset
from pinid.errors import DataError, SpecError
from pinid.io import Artefacts, as_path, json_text, jsonable
from pinid.model.base import base_parameters
from pinid.model.conic import ConicProblem
from pinid.model.physical import PSEUDO_INERTIA_BASIS
from pinid.model.regressor import parameter_names, regressor
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel, as_robot
from pinid.model.serialize import robot_from_dict, robot_to_dict
from pinid.problem.rows import rest_speeds
from pinid.result_protocol import ResultProtocol
from pinid.wearer.options import WearerOptions, as_wearer_options
from pinid.wearer.passive import anatomy
from pinid.wearer.prior import BodyPrior, wearer_prior


@dataclass
class WearerFit(ResultProtocol):
    """Stage-2 result: the wearer's standard parameters ``theta`` (10·nv inertial, then ``kp`` per joint
    when ``passive``), the table's ``table``, their base parameters ``base`` / ``base_table`` named
    ``base_names``, the solver status and time [s].  Follows :mod:`pinid.result_protocol` (``save``,
    ``load``, ``text``, ``plot``): its dict form carries the exo + wearer robot and the stage-1 model, so
    that a saved fit needs no other file."""

    robot: RobotModel
    exo: object  # the stage-1 IdentifiedModel
    priors: list[BodyPrior]
    terms: TermSelection
    theta: np.ndarray
    table: np.ndarray
    base_names: list[str]
    base: np.ndarray
    base_table: np.ndarray
    status: str
    seconds: float
    exponents: object = None  # the pinid.wearer.exponents.ExponentFit when the exponents were refined
    prior_weight: float = 0.0  # λ used (chosen by cross-validation with prior_weight="auto")
    cross_validation: dict | None = None  # choose_prior_weight's table, with prior_weight="auto"
    marks: dict | None = None  # {name: "identified" | "partly" | "not identified"} (BaseParameters.marks)

    PLOTS = {"segments": False, "base": True, "prior_weight": True, "exponents": True, "attachment": False}
    FILE_KIND = "wearer fit"

    @property
    def names(self) -> list[str]:
        """Names of ``theta``'s entries (``knee.m``, ``knee.kp``)."""
        return parameter_names(self.robot, self.terms)

    def model(self, which: str = "identified"):
        """The exo + wearer IdentifiedModel: ``"identified"`` wearer (with the fitted passive exponents, if
        any), ``"table"`` wearer (published exponents, kp = 1), or ``"exo"`` alone."""
        from pinid.identification.identified import IdentifiedModel
        from pinid.model import terms as _terms

        exo = self.exo
        nv = self.robot.nv
        w = {"identified": self.theta, "table": self.table, "exo": np.zeros_like(self.theta)}[which]
        names = [n for n in exo.terms.names if n != "passive"] + (["passive"] if "passive" in self.terms else [])
        terms = TermSelection.from_names(names)
        vals = _terms.values(exo.robot, exo.terms, exo.theta[10 * nv :])
        wv = _terms.values(self.robot, self.terms, w[10 * nv :])
        if "passive" in self.terms:
            vals["passive"] = wv["passive"]
        block = [vals[p.term.name][p.index] for p in _terms.robot_layout(self.robot, terms)]
        theta = np.concatenate([exo.theta[: 10 * nv] + w[: 10 * nv], block])
        robot = self.robot
        if which == "table" and robot.passive_exponents:  # the table wearer: the published exponents
            robot = robot.with_passive_exponents({})
        return IdentifiedModel(robot, terms, theta, meta={"wearer": which})

    def rms(self, datasets) -> dict[str, dict[str, float]]:
        """Torque RMS error [N·m] per joint on ``datasets`` (with q, dq, ddq, tau) of the three models:
        ``{"identified" | "table" | "exo": {joint: rms}}``."""
        q, dq, ddq, tau = stack(datasets)
        return {
            w: dict(
                zip(
                    self.robot.joint_names,
                    np.sqrt(np.mean((tau - self.model(w).inverse_dynamics(q, dq, ddq)) ** 2, axis=0)).tolist(),
                )
            )
            for w in ("identified", "table", "exo")
        }

    def to_dict(self) -> dict:
        """Plain-dict form (for JSON): the parameters by name, the solver's account and, under ``robot`` and
        ``exo_model``, the exo + wearer robot (:func:`~pinid.model.serialize.robot_to_dict`) and the stage-1
        model (:meth:`~pinid.identification.identified.IdentifiedModel.to_dict`)."""
        return {
            "parameters": dict(zip(self.names, self.theta.tolist())),
            **({"marks": dict(self.marks)} if self.marks else {}),
            "table": dict(zip(self.names, self.table.tolist())),
            "base": dict(zip(self.base_names, self.base.tolist())),
            "base_table": dict(zip(self.base_names, self.base_table.tolist())),
            "bodies": {b.joint: b.segments for b in self.priors},
            "status": self.status,
            "seconds": self.seconds,
            **({"passive_exponents": self.exponents.to_dict()} if self.exponents is not None else {}),
            "prior_weight": self.prior_weight,
            **({"prior_weight_cross_validation": self.cross_validation} if self.cross_validation else {}),
            "robot": robot_to_dict(self.robot, self.terms),
            "exo_model": self.exo.to_dict(),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "WearerFit":
        """Inverse of :meth:`to_dict` (the priors read again from the robot's URDF text)."""
        from pinid.identification.identified import IdentifiedModel
        from pinid.wearer.exponents import ExponentFit

        if not isinstance(d, dict) or not isinstance(d.get("robot"), dict) or not isinstance(d.get("exo_model"), dict):
            raise SpecError(
                "expected a stage-2 result with 'robot' and 'exo_model' (WearerFit.to_dict; an identification.json "
                "of an earlier pinid has neither: run stage 2 again)"
            )
        robot, terms = robot_from_dict(d["robot"])
        names = parameter_names(robot, terms)
        values = lambda key, keys: np.array([float(d[key][n]) for n in keys])
        cv = d.get("prior_weight_cross_validation")
        return cls(
            robot,
            IdentifiedModel.from_dict(d["exo_model"]),
            wearer_prior(robot.urdf_text, robot),
            terms,
            values("parameters", names),
            values("table", names),
            list(d["base"]),
            values("base", list(d["base"])),
            values("base_table", list(d["base"])),
            str(d["status"]),
            float(d["seconds"]),
            ExponentFit.from_dict(d["passive_exponents"]) if d.get("passive_exponents") else None,
            float(d["prior_weight"]),
            dict(cv) if cv else None,
            dict(d["marks"]) if d.get("marks") else None,
        )

    def text(self) -> str:
        """Status and time, how λ was chosen and the exponents refined, each base parameter identified and
        from the table (what ``pinid identify --stage wearer`` prints before the torque errors)."""
        width = max(len(n) for n in self.base_names)
        lines = [
            f"stage 2 (wearer) of {self.robot.name}: status {self.status}, {self.seconds:.2f} s",
            f"   {'base parameter':<{width}} {'identified':>13} {'table':>13}",
        ]
        if self.cross_validation is not None:
            cv = self.cross_validation
            lines.insert(
                1,
                f"   prior weight {self.prior_weight:g}: held-out RMS {min(cv['heldout_rms']):.4g} N·m, the least "
                f"of λ = {cv['weights'][0]:g} … {cv['weights'][-1]:g} ({cv['folds']}-fold blocked cross-validation)",
            )
        if self.exponents is not None:
            e = self.exponents
            lines.insert(
                1,
                f"   passive exponents: {len(e.free)} fitted in {e.evaluations} evaluations ({e.seconds:.2f} s); "
                f"torque RMS {e.rms_published:.4g} N·m at the published, {e.rms_fitted:.4g} at the fitted",
            )
        lines += [
            f"   {n:<{width}} {v:13.6g} {t:13.6g}" for n, v, t in zip(self.base_names, self.base, self.base_table)
        ]
        return "\n".join(lines)

    def _plot(self, kind: str, ax):
        """``"segments"``: the wearer's mass and centre of mass per body against the tables
        (:func:`~pinid.report.plot_wearer.segment_masses_figure`); ``"base"``: each base parameter identified
        and from the table; ``"prior_weight"``: the held-out torque RMS per λ of the cross-validation
        (``prior_weight="auto"`` only); ``"exponents"``: the refined passive exponents' change
        (``passive_exponents=True`` only); ``"attachment"``: where the segments attach (zero pose)."""
        from pinid.report import plot_wearer  # loads matplotlib: on use only

        if kind == "segments":
            keys = ("parameters", "table", "bodies", "marks")
            return plot_wearer.segment_masses_figure({k: v for k, v in self.to_dict().items() if k in keys})
        if kind == "base":
            return plot_wearer.base_parameters_figure(self.base_names, self.base, self.base_table, ax=ax)
        if kind == "prior_weight":
            if self.cross_validation is None:
                raise SpecError(f"kind 'prior_weight': λ = {self.prior_weight:g} was given, not cross-validated")
            return plot_wearer.prior_weight_figure(self.cross_validation, self.prior_weight, ax=ax)
        if kind == "exponents":
            if self.exponents is None:
                raise SpecError("kind 'exponents': the passive exponents were not refined (passive_exponents=False)")
            return self.exponents.plot("change", ax=ax)
        from pinid.wearer.attach import wearer_segments

        return plot_wearer.attachment_figure(self.robot.urdf_text, wearer_segments(self.robot.urdf_text))


def _scale(priors: list[BodyPrior], nv: int, nt: int) -> np.ndarray:
    s = np.ones(10 * nv + nt)
    for b in priors:
        M, L = max(b.theta[0], 1e-3), max(b.end - b.start, 0.05)
        s[10 * b.index] = M
        s[10 * b.index + 1 : 10 * b.index + 4] = M * L
        s[10 * b.index + 4 : 10 * b.index + 10] = M * L * L
    return s


def _compress(W: np.ndarray, y: np.ndarray, block: int = 20000) -> tuple[np.ndarray, np.ndarray]:
    """``(R, z)`` with ``‖W·x − y‖² = ‖R·x − z‖² + const``, from QR of ``[W y]`` in row blocks."""
    acc = np.zeros((0, W.shape[1] + 1))
    for k in range(0, W.shape[0], block):
        acc = np.linalg.qr(np.vstack([acc, np.column_stack([W[k : k + block], y[k : k + block]])]), mode="r")
    return acc[:, :-1], acc[:, -1]


#: Largest difference [m, or rad for an axis] between a joint's placement or axis in the stage-1 model
#: and in the exo + wearer URDF for both to describe one exoskeleton (``pinid wearer`` copies them exactly).
KINEMATICS_TOLERANCE = 1e-9


def check_stage1(exo, robot: RobotModel, origin: str = "stage-1 model") -> None:
    """SpecError (one line) unless the stage-1 model ``exo`` is physically consistent and describes the
    exoskeleton of ``robot`` (the exo + wearer URDF): same robot name, joints (names, order, kinds),
    joint placements and axes (within :data:`KINEMATICS_TOLERANCE`).  Stage 2 subtracts the exo's torque
    as given: an inconsistent or foreign exo would be absorbed, silently, into the wearer's parameters."""
    from pinid.identification.identified import IdentifiedModel

    if not isinstance(exo, IdentifiedModel):
        raise SpecError(f"exo: got {type(exo).__name__}, expected the stage-1 IdentifiedModel (model_sdp.json)")
    robot = as_robot(robot)
    if not exo.physically_consistent:
        from pinid.model.physical import check_consistency

        problems = check_consistency(exo.theta, exo.joint_names, exo.terms.names, exo.robot.motor_names).problems
        raise SpecError(
            f"{origin} is not physically consistent ({'; '.join(problems) or 'stored as inconsistent'}); "
            "stage 2 needs a consistent exoskeleton, e.g. stage 1's model_sdp.json"
        )
    if exo.robot.name != robot.name:
        raise SpecError(
            f"{origin} is of robot '{exo.robot.name}', the URDF of robot '{robot.name}'; expected the stage-1 "
            "model of the exoskeleton the wearer URDF was made from (pinid wearer)"
        )
    if robot.joint_names != exo.joint_names:
        raise SpecError(f"{origin}: joints {exo.joint_names} differ from the wearer URDF's {robot.joint_names}")
    a, b = exo.robot.pin_model, robot.pin_model
    axes_a, axes_b = _axes(a), _axes(b)
    for i, name in enumerate(robot.joint_names, start=1):
        pa, pb = a.jointPlacements[i], b.jointPlacements[i]
        same = (
            axes_a[i - 1].shape == axes_b[i - 1].shape
            and np.abs(axes_a[i - 1] - axes_b[i - 1]).max() <= KINEMATICS_TOLERANCE
            and np.abs(pa.translation - pb.translation).max() <= KINEMATICS_TOLERANCE
            and np.abs(pa.rotation - pb.rotation).max() <= KINEMATICS_TOLERANCE
        )
        if not same:
            raise SpecError(
                f"{origin}: joint '{name}' has another placement or axis than in the wearer URDF; expected the "
                "stage-1 model of the exoskeleton the wearer URDF was made from (pinid wearer)"
            )


def _axes(model) -> list[np.ndarray]:
    """Per joint of a Pinocchio model, its motion subspace at the neutral configuration (the axis)."""
    import pinocchio as pin

    q = pin.neutral(model)
    out = []
    for joint in list(model.joints)[1:]:
        data = joint.createData()
        joint.calc(data, q)
        out.append(np.asarray(data.S, dtype=float))
    return out


def identify_wearer(
    exo,
    prior_urdf,
    q: np.ndarray,
    dq: np.ndarray,
    ddq: np.ndarray,
    tau: np.ndarray,
    *,
    options: WearerOptions | None = None,
) -> WearerFit:
    """Stage 2: the wearer's parameters from (N, nv) arrays ``q`` [rad], ``dq``, ``ddq``, ``tau`` [N·m].

    ``exo``: the stage-1 IdentifiedModel (or its JSON path); ``prior_urdf``: the URDF of
    ``pinid wearer`` (the table values, the bounds); ``options``: :class:`~pinid.wearer.options.WearerOptions`
    (default all defaults): ``passive``, ``mass_range`` ρ; ``prior_weight`` λ (see the module text), or
    ``"auto"`` (the default): chosen by blocked cross-validation (:func:`choose_prior_weight`);
    ``passive_exponents``: first fit the passive moments' exponents (:mod:`pinid.wearer.exponents`), then
    solve the SDP with them (the returned model carries them); ``rest_velocity``: leave out each joint's rows
    whose speed is below it [rad/s] — "auto", a number or one per joint (:func:`pinid.problem.rows.rest_speeds`;
    None, the default, keeps every row): there the exoskeleton's Coulomb friction, fixed from stage 1, has
    no defined sign, so those rows measure the static friction, not the wearer.
    """
    from pinid.identification.identified import IdentifiedModel

    o = as_wearer_options(options)
    passive, mass_range, prior_weight = o.passive, o.mass_range, o.prior_weight
    passive_exponents, rest_velocity, solver = o.passive_exponents, o.rest_velocity, o.solver
    origin = "stage-1 model" if isinstance(exo, IdentifiedModel) else f"{exo}: stage-1 model"
    exo = exo if isinstance(exo, IdentifiedModel) else IdentifiedModel.load(exo)
    robot = prior_urdf if isinstance(prior_urdf, RobotModel) else RobotModel.from_urdf(prior_urdf)
    check_stage1(exo, robot, origin)
    if passive_exponents and not passive:
        raise SpecError("passive_exponents needs the passive moments (passive=True): the exponents are theirs")
    if prior_weight != "auto" and (isinstance(prior_weight, str) or not prior_weight >= 0):
        raise SpecError(f"prior_weight {prior_weight!r}, expected a number ≥ 0 or 'auto'")
    if not 0 < mass_range < 1:
        raise SpecError(f"mass_range {mass_range:g}, expected a fraction in (0, 1)")
    priors = wearer_prior(robot.urdf_text or robot.urdf_path.read_text(encoding="utf-8"), robot)
    q, dq, ddq, tau = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, dq, ddq, tau))
    if not (q.shape == dq.shape == ddq.shape == tau.shape) or q.shape[1] != robot.nv:
        raise DataError(
            f"q, dq, ddq, tau: shapes {q.shape}, {dq.shape}, {ddq.shape}, {tau.shape}, expected (N, {robot.nv}) each"
        )
    moving = (np.abs(dq) >= rest_speeds(dq, rest_velocity, robot.joint_names)).reshape(-1)
    t0 = time.perf_counter()
    nv = robot.nv
    terms = TermSelection.from_names("passive" if passive else "none")
    nt = nv if passive else 0
    table = np.zeros(10 * nv + nt)
    for b in priors:
        table[10 * b.index : 10 * b.index + 10] = b.theta
    mapped = [i for i, (kind, _) in enumerate(anatomy(robot)) if kind is not None] if passive else []
    table[[10 * nv + i for i in mapped]] = 1.0
    free = [10 * b.index + k for b in priors for k in range(10)] + [10 * nv + i for i in mapped]
    W = regressor(robot, q, dq, ddq, terms)[:, free] * moving[:, None]  # a row at rest weighs nothing
    y = (tau - exo.inverse_dynamics(q, dq, ddq)).reshape(-1) * moving
    refined = None
    if passive_exponents:
        from pinid.wearer.exponents import fit_exponents

        refined = fit_exponents(robot, W[:, : -len(mapped)] if mapped else W, y, q)
        robot = robot.with_passive_exponents(refined.fitted)  # the caller's model keeps the published exponents
        W = regressor(robot, q, dq, ddq, terms)[:, free] * moving[:, None]
    S = _scale(priors, nv, nt)[free]
    z0 = table[free] / S
    bodies = (priors, free, S, mass_range, [10 * nv + i for i in mapped])
    cv = None
    if prior_weight == "auto":  # too short to cut into folds: the data alone
        auto = len(q) >= 2 * FOLDS
        prior_weight, cv = choose_prior_weight(W * S, y, nv, z0, bodies, solver) if auto else (0.0, None)
    R, z = _compress(W * S, y)
    solution = _fit(R, z, z0, bodies, float(prior_weight), solver)
    status = solution.status
    theta = np.zeros_like(table)
    theta[free] = S * solution.z
    bp = base_parameters(robot, terms)
    return WearerFit(
        robot,
        exo,
        priors,
        terms,
        theta,
        table,
        bp.names,
        bp.from_standard(theta),
        bp.from_standard(table),
        status,
        time.perf_counter() - t0,
        refined,
        float(prior_weight),
        cv,
        bp.marks(),
    )


def _fit(R: np.ndarray, z: np.ndarray, z0: np.ndarray, bodies: tuple, prior_weight: float, solver: str):
    """The stage-2 conic problem (see the module text) on the compressed, scaled regressor ``(R, z)``;
    ``z0`` the table in the scaled coordinates; ``bodies`` = ``(priors, free, S, mass_range, kp columns)``."""
    priors, free, S, mass_range, kp = bodies
    _, sv, Vt = np.linalg.svd(R)
    rank = int(np.sum(sv > 1e-9 * sv[0]))
    V0 = Vt[rank:].T
    n = len(free)
    conic = ConicProblem(n)
    conic.add_norm(R, z)  # a norm, not its square: an exact fit, when feasible, is a kink the solver lands on
    if V0.shape[1]:
        conic.add_norm(V0.T, V0.T @ z0, 1e-3)
    if prior_weight:
        conic.add_norm(np.eye(n), z0, prior_weight * sv[0])
    pos = {k: i for i, k in enumerate(free)}
    for b in priors:
        cols = [pos[10 * b.index + k] for k in range(10)]
        th = np.zeros((10, n))  # the body's standard parameters θ = th·x
        th[range(10), cols] = S[cols]
        m0 = b.theta[0]
        conic.add_psd(np.stack([PSEUDO_INERTIA_BASIS[k].reshape(-1, order="F") / m0 for k in range(10)], axis=1) @ th)
        conic.add_inequality(th[0], (1 - mass_range) * m0)
        conic.add_inequality(-th[0], -(1 + mass_range) * m0)
        h = th[1:4]  # m·c [kg·m]
        e1 = np.cross(b.axis, [0.0, 1.0, 0.0]) if abs(b.axis[1]) < 0.9 else np.cross(b.axis, [1.0, 0, 0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(b.axis, e1)
        conic.add_inequality(b.axis @ h - b.start * th[0], 0.0)  # CoM within the segment along the axis
        conic.add_inequality(b.end * th[0] - b.axis @ h, 0.0)
        for e in (e1, e2):  # |e·h| ≤ radius·m
            conic.add_inequality(b.radius * th[0] - e @ h, 0.0)
            conic.add_inequality(b.radius * th[0] + e @ h, 0.0)
    if kp:
        conic.add_inequality(np.eye(n)[[pos[k] for k in kp]], 0.0)  # kp ≥ 0
    return conic.solve(solver, None, "wearer stage 2")


#: Candidate weights λ of ``prior_weight="auto"`` (0: the data alone decide what they can see).
PRIOR_WEIGHTS = (0.0, 1e-4, 1e-3, 1e-2, 1e-1, 1.0)
#: Contiguous blocks of the recording for ``prior_weight="auto"``.
FOLDS = 5


def choose_prior_weight(
    A: np.ndarray, y: np.ndarray, nv: int, z0: np.ndarray, bodies: tuple, solver: str = "CLARABEL"
) -> tuple[float, dict]:
    """λ of :data:`PRIOR_WEIGHTS` with the least held-out torque residual by blocked cross-validation: the
    rows (``nv`` per sample, in time order) cut into :data:`FOLDS` contiguous blocks, each left out in turn
    and predicted by the wearer fitted on the others.  Contiguous blocks, not random rows, because the
    disturbances of a wearer (slow active torque) are correlated in time: random rows would reward fitting
    them.  Returns ``(λ, {"weights": [...], "heldout_rms": [...] [N·m], "folds": FOLDS})``; ties (within
    1e-6 relative, or 1e-9 of the torque RMS) go to the smaller λ."""
    A, y, z0, nv = as_floats(A, "A", finite=False), as_floats(y, "y"), as_floats(z0, "z0"), count(nv, "nv", low=1)
    if not isinstance(bodies, tuple):
        raise SpecError(f"bodies: got {type(bodies).__name__}, expected a tuple of wearer bodies")
    samples = len(y) // nv
    if samples < 2 * FOLDS:
        raise DataError(f"prior_weight='auto': {samples} samples, expected at least {2 * FOLDS} for {FOLDS} folds")
    cuts = np.linspace(0, samples, FOLDS + 1).round().astype(int) * nv
    folds = [_compress(A[a:b], y[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]
    sse = np.zeros(len(PRIOR_WEIGHTS))
    for k, (Rk, zk) in enumerate(folds):
        others = np.vstack([np.column_stack(f) for j, f in enumerate(folds) if j != k])
        train = np.linalg.qr(others, mode="r")
        for i, lam in enumerate(PRIOR_WEIGHTS):
            x = _fit(train[:, :-1], train[:, -1], z0, bodies, lam, solver).z
            sse[i] += float(np.sum((Rk @ x - zk) ** 2))
    rms = np.sqrt(sse / len(y))
    # near-ties (solver precision: with exact data every small λ fits exactly, the cost being a norm) go
    # to the smaller λ, the data's side
    tie = rms.min() * (1 + 1e-6) + 1e-9 * float(np.sqrt(np.mean(y * y)))
    best = int(np.flatnonzero(rms <= tie)[0])
    return PRIOR_WEIGHTS[best], {"weights": list(PRIOR_WEIGHTS), "heldout_rms": rms.tolist(), "folds": FOLDS}


def _as_fit(fit) -> WearerFit:
    """``fit`` if it is a :class:`WearerFit`; SpecError naming what was expected otherwise."""
    if not isinstance(fit, WearerFit):
        raise SpecError(f"fit: got {type(fit).__name__}, expected a WearerFit (pinid.wearer.stage.identify_wearer)")
    return fit


def _as_summary(summary) -> dict:
    """``summary`` if it is a dict; SpecError naming what was expected otherwise."""
    if not isinstance(summary, dict):
        raise SpecError(f"summary: got {type(summary).__name__}, expected the dict of stage_summary")
    return summary


def stack(datasets) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(q, dq, ddq, tau)`` of recordings (Datasets with all four), their samples stacked, (N, nv) each."""
    if isinstance(datasets, (str, bytes)) or not isinstance(datasets, Sequence) or not datasets:
        raise DataError(f"datasets: got {type(datasets).__name__}, expected a list of pinid Datasets")
    datasets = [as_dataset(d, "datasets") for d in datasets]
    return tuple(np.vstack([getattr(d, k) for d in datasets]) for k in ("q", "dq", "ddq", "tau"))


def stage_summary(fit: WearerFit, exo, train, validation=None) -> dict:
    """What ``pinid identify --stage wearer`` writes as ``identification.json`` (:meth:`WearerStage.to_dict`):
    the stage, the stage-1 model's path ``exo`` (None when given as an IdentifiedModel), the URDF,
    :meth:`WearerFit.to_dict` and the torque RMS errors [N·m] of the three models on the ``train`` and
    ``validation`` datasets (None without)."""
    from pinid.identification.identified import IdentifiedModel

    _as_fit(fit)
    path = None if isinstance(exo, IdentifiedModel) else str(as_path(exo, "exo"))
    validation_rms = fit.rms(validation) if validation else None
    if validation_rms:
        warn_if_worse_than_table(validation_rms)
    return jsonable(
        {
            "stage": "wearer",
            "exo": path,
            "urdf": str(fit.robot.urdf_path),
            **fit.to_dict(),
            "train_rms": fit.rms(train),
            "validation_rms": validation_rms,
        }
    )


#: How much worse [ratio of RMS] than the table wearer a joint's held-out torque error may be before it is said.
WORSE_THAN_TABLE = 1.05


def warn_if_worse_than_table(rms: dict[str, dict[str, float]]) -> list[str]:
    """A DataWarning when the identified wearer's held-out torque RMS of a joint is above the table wearer's by
    more than :data:`WORSE_THAN_TABLE` (``rms``: :meth:`WearerFit.rms` on the validation recordings): the fit
    then generalises worse than the anthropometric tables, and the table wearer (model_table.json) is the one to
    use.  Returns the joints named."""
    import warnings

    from pinid.errors import DataWarning

    if not isinstance(rms, dict) or not all(isinstance(v, dict) for v in rms.values()):
        raise SpecError(f"rms: got {type(rms).__name__}, expected {{'identified' | 'table' | 'exo': {{joint: rms}}}}")
    ident, table = rms.get("identified") or {}, rms.get("table") or {}
    worse = [j for j, v in ident.items() if j in table and v > WORSE_THAN_TABLE * table[j]]
    if worse:
        warnings.warn(
            "wearer: the identified wearer predicts the validation torque worse than the anthropometric tables at "
            + ", ".join(f"{j} ({ident[j]:.3g} vs {table[j]:.3g} N·m RMS)" for j in worse)
            + "; the training recordings did not determine it well (too short or too little motion, or a prior "
            "weight too small): prefer the table wearer (model_table.json), or record more and a larger --prior-weight",
            DataWarning,
            stacklevel=2,
        )
    return worse


def stage_text(fit: WearerFit, summary: dict) -> str:
    """A stage-2 fit as text: :meth:`WearerFit.text` (status and time, each base parameter identified and
    from the table), then the RMS errors of :func:`stage_summary`."""
    _as_fit(fit), _as_summary(summary)
    lines = [fit.text()]
    for kind in ("train_rms", "validation_rms"):
        if summary[kind]:
            lines.append(
                f"   {kind.replace('_', ' ')} [N·m]: "
                + "; ".join(f"{w} " + ", ".join(f"{j} {v:.4g}" for j, v in r.items()) for w, r in summary[kind].items())
            )
    return "\n".join(lines)


def torque_curves(fit: WearerFit, kind: str, datasets) -> dict:
    """The measured torque of the first of ``datasets`` and the three models' predictions of it, as the
    report draws them (:func:`pinid.report.wearer.torque_figure`); ``kind``: "training" or "validation"."""
    _as_fit(fit)
    q, dq, ddq, tau = stack(datasets[:1])
    return {
        "t": datasets[0].t,
        "measured": tau,
        "joints": fit.robot.joint_names,
        "kind": str(kind),
        "source": Path(str(datasets[0].source)).name,
        "predicted": {w: fit.model(w).inverse_dynamics(q, dq, ddq) for w in ("identified", "table", "exo")},
    }


def write_stage(
    fit: WearerFit,
    summary: dict,
    folder: str | os.PathLike,
    *,
    shown=None,
    report: bool = True,
    figures: bool = True,
    overwrite: bool | None = None,
) -> list[Path]:
    """Write ``identification.json`` (``summary``), ``model_wearer.json`` and ``model_table.json`` (the exo +
    identified / table wearer as IdentifiedModels) and, with ``report``, report.md, report.html and the
    torque figure on the first of the ``shown`` datasets ((kind, datasets): validation, else training)
    into ``folder``, all or nothing; a ``--force`` re-run leaves no stale report; returns the paths."""
    from pinid.report.wearer import WEARER_REPORT_FILES, wearer_report_files
    from pinid.wearer.attach import wearer_segments

    _as_fit(fit), _as_summary(summary)
    out = as_path(folder, "folder")
    arts = Artefacts(overwrite=overwrite)
    arts.add(out / "identification.json", json_text(summary))
    arts.add(out / "model_wearer.json", json_text(fit.model("identified").to_dict()))
    arts.add(out / "model_table.json", json_text(fit.model("table").to_dict()))
    if report and shown:
        kind, datasets = shown
        curves = torque_curves(fit, kind, datasets)
        text = fit.robot.urdf_text
        attachment = (text, wearer_segments(text)) if figures and text else None
        for name, content in wearer_report_files(summary, curves, figures=figures, attachment=attachment).items():
            arts.add(out / name, content)
    arts.clean(out, WEARER_REPORT_FILES)
    return arts.write()


@dataclass
class WearerStage(ResultProtocol):
    """A stage-2 run on recordings (:func:`identify_wearer_stage`): the ``fit``, its ``summary``
    (:func:`stage_summary`) and the prepared ``train`` and ``validation`` datasets.  Follows
    :mod:`pinid.result_protocol`: its dict form is the ``summary`` (``identification.json``), so
    ``WearerStage.load("identification.json")`` reads a run back, without its recordings (``train`` and
    ``validation`` empty: no ``"torque"`` figure)."""

    fit: WearerFit
    summary: dict
    train: list
    validation: list

    PLOTS = {"rms": True, "torque": False, "segments": False}
    FILE_KIND = "stage-2 identification.json"

    def to_dict(self) -> dict:
        """The ``summary``: what ``pinid identify --stage wearer`` writes as ``identification.json``."""
        return jsonable(self.summary)

    @classmethod
    def from_dict(cls, d: dict) -> "WearerStage":
        """Inverse of :meth:`to_dict` (no recordings: ``train`` and ``validation`` empty)."""
        if not isinstance(d, dict) or d.get("stage") != "wearer":
            got = d.get("stage") if isinstance(d, dict) else type(d).__name__
            raise SpecError(
                f"stage {got!r}, expected a stage-2 result ('stage': 'wearer', pinid identify --stage wearer)"
            )
        return cls(WearerFit.from_dict(d), dict(d), [], [])

    def text(self) -> str:
        """What ``pinid identify --stage wearer`` prints (:func:`stage_text`)."""
        return stage_text(self.fit, self.summary)

    def _plot(self, kind: str, ax):
        """``"rms"``: the torque RMS error [N·m] per joint of exo + identified wearer, exo + table wearer and
        exo alone (validation, else training); ``"torque"``: their predicted torque against the measured on
        the first validation (else training) recording, the report's figure (needs the recordings: not after
        :meth:`load`); ``"segments"``: :meth:`WearerFit.plot`'s."""
        from pinid.report import plot_wearer  # loads matplotlib: on use only

        if kind == "rms":
            kind = "validation" if self.summary.get("validation_rms") else "train"
            return plot_wearer.rms_figure(self.summary[f"{kind}_rms"], kind, ax=ax)
        if kind == "torque":
            from pinid.report.wearer import torque_figure

            if not (self.validation or self.train):
                raise SpecError("kind 'torque' needs the recordings, which a loaded stage has not (identify again)")
            shown = ("validation", self.validation) if self.validation else ("training", self.train)
            return torque_figure(torque_curves(self.fit, *shown))
        return self.fit.plot(kind)

    def write(
        self, folder: str | os.PathLike, *, report: bool = True, figures: bool = True, overwrite: bool | None = None
    ) -> list[Path]:
        """The files of :func:`write_stage` in ``folder``, the report's figure on the validation recordings
        (else the training ones); returns the paths."""
        shown = ("validation", self.validation) if self.validation else ("training", self.train)
        return write_stage(
            self.fit, self.summary, folder, shown=shown, report=report, figures=figures, overwrite=overwrite
        )


def identify_wearer_stage(
    exo,
    robot: RobotModel,
    data,
    *,
    validate=None,
    mapping=None,
    preprocess=None,
    options: WearerOptions | None = None,
) -> WearerStage:
    """``pinid identify --stage wearer`` in one call: the training recordings ``data`` and the ``validate``
    ones (paths or Datasets, each given once: :func:`~pinid.identification.recording_checks.check_distinct`) read with
    ``mapping`` and prepared with ``preprocess`` (:func:`~pinid.problem.recordings.load_datasets`), the
    wearer of ``robot`` (the exo + wearer URDF) identified with the exoskeleton fixed to ``exo`` (the
    stage-1 IdentifiedModel or its JSON path; :func:`identify_wearer` with ``options``, a
    :class:`~pinid.wearer.options.WearerOptions`) and its errors on both sets of recordings summarised."""
    from pinid.problem.recordings import load_datasets  # deferred: stage 2 on arrays does not need them
    from pinid.identification.recording_checks import check_distinct

    robot = as_robot(robot)
    check_distinct(data, validate)
    train = load_datasets(data, robot, mapping, preprocess, "training")
    val = load_datasets(validate, robot, mapping, preprocess, "validation")
    fit = identify_wearer(
        exo,
        robot,
        *stack(train),
        options=options,
    )
    return WearerStage(fit, stage_summary(fit, exo, train, val), train, val)
