"""Physical consistency of standard parameters: the pseudo-inertia matrix and its checks, conversions.

A body's 10 standard parameters ``π = [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`` (first moments
``h = m·c`` [kg·m] and inertia ``I`` [kg·m²] about the joint frame, Pinocchio's order) are *physically
consistent* when some non-negative mass distribution produces them.  That is exactly (Wensing et al.
2017) the pseudo-inertia matrix being positive semidefinite::

    J(π) = [[Σ, h], [hᵀ, m]] ⪰ 0,   Σ = ½·tr(I)·1 − I   (the second moment ∫ r rᵀ dm)

which implies m ≥ 0, the inertia about the centre of mass positive semidefinite and the triangle
inequalities.  Joint terms are consistent when Coulomb friction ``fc``, viscous friction ``fv`` and
armature are non-negative (the constant ``offset`` may have any sign).

:func:`check_consistency` checks a full standard vector (never assumed, always computed);
:func:`pseudo_inertia` and :data:`PSEUDO_INERTIA_BASIS` are what the LMI estimator uses as constraints.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field
from collections.abc import Sequence

import numpy as np

from pinid.model.terms import layout
from pinid.checks import array_like
from pinid.errors import SpecError

#: Relative tolerance of the checks: an eigenvalue of J ≥ −RTOL·‖J‖ counts as non-negative.
RTOL = 1e-8


def _basis() -> np.ndarray:
    """(10, 4, 4) matrices E_k with J(π) = Σ_k π_k·E_k."""
    E = np.zeros((10, 4, 4))
    E[0, 3, 3] = 1.0  # m
    for k, i in ((1, 0), (2, 1), (3, 2)):  # h = (mx, my, mz)
        E[k, i, 3] = E[k, 3, i] = 1.0
    # Σ = ½ tr(I) 1 − I:  Σxx = ½(−Ixx + Iyy + Izz), Σyy = ½(Ixx − Iyy + Izz), Σzz = ½(Ixx + Iyy − Izz)
    for k, diag in ((4, (-0.5, 0.5, 0.5)), (6, (0.5, -0.5, 0.5)), (9, (0.5, 0.5, -0.5))):
        E[k, :3, :3] = np.diag(diag)
    for k, (i, j) in ((5, (0, 1)), (7, (0, 2)), (8, (1, 2))):  # Σij = −Iij
        E[k, i, j] = E[k, j, i] = -1.0
    return E


#: ``PSEUDO_INERTIA_BASIS[k]`` is ∂J/∂π_k, so that ``J(π) = Σ_k π_k·PSEUDO_INERTIA_BASIS[k]``.
PSEUDO_INERTIA_BASIS: np.ndarray = _basis()


def pseudo_inertia(pi: np.ndarray) -> np.ndarray:
    """The 4×4 pseudo-inertia matrix of one body's 10 standard parameters (about the joint frame)."""
    array_like(pi, "pi")
    pi = np.asarray(pi, dtype=float)
    if pi.shape != (10,):
        raise ValueError(f"expected 10 standard inertial parameters, got shape {pi.shape}")
    return np.tensordot(pi, PSEUDO_INERTIA_BASIS, axes=1)


def from_pseudo_inertia(J: np.ndarray) -> np.ndarray:
    """Inverse of :func:`pseudo_inertia`: the 10 standard parameters of a symmetric 4×4 matrix."""
    array_like(J, "J")
    J = np.asarray(J, dtype=float)
    S = J[:3, :3]
    tr = np.trace(S)
    inertia = tr * np.eye(3) - S  # I = tr(Σ)·1 − Σ
    return np.array(
        [
            J[3, 3],
            J[0, 3],
            J[1, 3],
            J[2, 3],
            inertia[0, 0],
            inertia[0, 1],
            inertia[1, 1],
            inertia[0, 2],
            inertia[1, 2],
            inertia[2, 2],
        ]
    )


def com_inertia(pi: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """``(m [kg], c [m], I_c [kg·m²])``: mass, centre of mass and inertia about the centre of mass.

    For a (numerically) zero mass the centre of mass is undefined; it is returned as the origin and
    ``I_c`` is the inertia about the joint frame.
    """
    array_like(pi, "pi")
    pi = np.asarray(pi, dtype=float)
    m, h = float(pi[0]), pi[1:4]
    I_o = np.array([[pi[4], pi[5], pi[7]], [pi[5], pi[6], pi[8]], [pi[7], pi[8], pi[9]]])
    if abs(m) <= 1e-12 * max(1.0, np.abs(pi).max()):
        return m, np.zeros(3), I_o
    c = h / m
    I_c = I_o - m * (float(c @ c) * np.eye(3) - np.outer(c, c))
    return m, c, I_c


#: Relative size below which a value is written as 0 (round-off of the completion, not a value).
NOISE = 1e-12


def tidy_inertial(m: float, c: np.ndarray, I: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """``(m, c, I)`` of :func:`com_inertia` with round-off set to exactly 0: a centre-of-mass coordinate
    below ``NOISE`` times the body's length scale (``max(|c|, √(λmax(I)/|m|))`` [m]), an inertia entry below
    ``NOISE`` times the largest one [kg·m²].  What is written for a user (report, URDF, MJCF) goes through
    this, so ``c = -6.57e-22`` reads 0."""
    if not isinstance(m, numbers.Real) or isinstance(m, bool):
        raise SpecError(f"m: got {type(m).__name__}, expected a mass [kg]")
    c, I = np.array(array_like(c, "c"), dtype=float), np.array(array_like(I, "I"), dtype=float)
    big = float(np.abs(I).max()) if I.size else 0.0
    length = max(float(np.linalg.norm(c)), float(np.sqrt(big / abs(m))) if m and big > 0 else 0.0)
    c[np.abs(c) < NOISE * length] = 0.0
    I[np.abs(I) < NOISE * big] = 0.0
    return m, c + 0.0, I + 0.0  # + 0.0: no "-0"


def nonnegative_within_tolerance(value: float, scale: float) -> bool:
    """The one tolerance rule of the consistency checks (and of the MJCF export): ``value`` counts as
    non-negative when it is ≥ −RTOL·``scale`` (``scale``: the size of the quantity it belongs to)."""
    if not all(isinstance(x, numbers.Real) and not isinstance(x, bool) for x in (value, scale)):
        raise SpecError(f"value {value!r}, scale {scale!r}: expected two real numbers")
    return value >= -RTOL * scale


@dataclass
class BodyCheck:
    """Consistency of one body: the smallest eigenvalue of its pseudo-inertia, and relative to ‖J‖."""

    joint: str
    mass: float
    min_eigenvalue: float
    relative: float

    @property
    def consistent(self) -> bool:
        """True when every check passed."""
        return nonnegative_within_tolerance(self.relative, 1.0)


@dataclass
class ConsistencyReport:
    """Outcome of :func:`check_consistency`: per-body results and the joint terms that are negative."""

    bodies: list[BodyCheck]
    negative_terms: dict[str, float] = field(default_factory=dict)

    @property
    def consistent(self) -> bool:
        """True when every pseudo-inertia is PSD and fc, fv, armature are non-negative."""
        return all(b.consistent for b in self.bodies) and not self.negative_terms

    @property
    def problems(self) -> list[str]:
        """Readable list of what is inconsistent (empty when consistent)."""
        out = [
            f"{b.joint}: pseudo-inertia has eigenvalue {b.min_eigenvalue:.3g} < 0"
            + (f" (mass {b.mass:.3g} kg)" if b.mass < 0 else "")
            for b in self.bodies
            if not b.consistent
        ]
        out += [f"{n} = {v:.3g} < 0" for n, v in self.negative_terms.items()]
        return out

    def to_dict(self) -> dict:
        """Plain-JSON form."""
        return {
            "consistent": self.consistent,
            "problems": self.problems,
            "bodies": {
                b.joint: {"mass": b.mass, "min_eigenvalue": b.min_eigenvalue, "relative_min_eigenvalue": b.relative}
                for b in self.bodies
            },
            "negative_terms": dict(self.negative_terms),
        }


def check_consistency(
    theta: np.ndarray, joints: list[str], term_names: list[str], motors: Sequence[str] = ()
) -> ConsistencyReport:
    """Check a full standard vector (inertial block for ``joints``, then the terms ``term_names`` laid out
    per joint, then per motor of ``motors``; see :mod:`pinid.model.terms`).

    Body ``i`` is consistent when the smallest eigenvalue of its pseudo-inertia is ≥ −RTOL·‖J‖₂; a term the
    registry marks non-negative (Coulomb, viscous, rotor inertia) when it is ≥ −RTOL·max(1, |largest
    parameter of that term|).
    """
    array_like(theta, "theta")
    theta = np.asarray(theta, dtype=float)
    nv = len(joints)
    params = layout(joints, motors, term_names)
    if theta.shape != (10 * nv + len(params),):
        raise ValueError(f"expected {10 * nv + len(params)} standard parameters, got shape {theta.shape}")
    bodies = []
    for i, j in enumerate(joints):
        J = pseudo_inertia(theta[10 * i : 10 * i + 10])
        ev = np.linalg.eigvalsh(J)
        norm = max(np.abs(ev).max(), 1e-300)
        bodies.append(BodyCheck(j, float(J[3, 3]), float(ev[0]), float(ev[0] / norm)))
    negative = {}
    values = theta[10 * nv :]
    scale = {}  # per term name; the report lists parameters in column order (not a set's hash order)
    for name in dict.fromkeys(p.term.name for p in params if p.term.nonnegative):
        idx = [k for k, p in enumerate(params) if p.term.name == name]
        scale[name] = max(1.0, float(np.abs(values[idx]).max()))
    for k, p in enumerate(params):
        if p.term.nonnegative and not nonnegative_within_tolerance(values[k], scale[p.term.name]):
            negative[p.name] = float(values[k])
    return ConsistencyReport(bodies, negative)


def parameter_scale(theta_nominal: np.ndarray, nv: int, nt: int) -> np.ndarray:
    """A positive scale per standard parameter, from the nominal ones (for regularisation and scaling).

    Per body: a mass scale ``M`` (its nominal mass, at least 1 % of the heaviest body and 1e-3 kg) and a
    length ``L`` (its nominal centre-of-mass distance, at least 0.05 m and 10 % of the largest one);
    ``M`` for the mass, ``M·L`` for first moments, ``M·L²`` for inertias.  Joint terms: 1 (their units).
    """
    array_like(theta_nominal, "theta_nominal")
    theta_nominal = np.asarray(theta_nominal, dtype=float)
    masses = np.array([abs(theta_nominal[10 * i]) for i in range(nv)])
    lengths = []
    for i in range(nv):
        m, c, _ = com_inertia(theta_nominal[10 * i : 10 * i + 10])
        lengths.append(float(np.linalg.norm(c)) if m > 0 else 0.0)
    lengths = np.array(lengths) if nv else np.zeros(0)
    big_m = masses.max() if nv else 1.0
    big_l = lengths.max() if nv else 0.0
    scale = np.ones(theta_nominal.size)  # terms (joint and motor): 1 in their units
    for i in range(nv):
        M = max(masses[i], 0.01 * big_m, 1e-3)
        L = max(lengths[i], 0.05, 0.1 * big_l)
        scale[10 * i] = M
        scale[10 * i + 1 : 10 * i + 4] = M * L
        scale[10 * i + 4 : 10 * i + 10] = M * L * L
    return scale
