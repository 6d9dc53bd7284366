"""The passive moments' exponents by nonlinear least squares (variable projection), from the published values.

Stage 2's default passive model is linear: a scale factor ``kp`` per joint of Riener & Edrich's
published shape.  A wearer's tissues differ in stiffness *growth* as well as in size; this refinement
also fits the exponents' angle coefficients (``cH``, ``cK``, ``cA`` of each exponential, 1/deg) — those
that are non-zero in the table and whose angle is a joint of the robot (the others have no effect on
the data).  The constants ``c0`` stay published: with ``kp`` they would only trade amplitude.

Variable projection (Golub & Pereyra): for an exponent vector ``p`` the model is linear in the
wearer's inertial parameters ``θ_w`` and the scale factors ``kp``, so those are eliminated by linear
least squares and ``scipy.optimize.least_squares`` (trust region, bounds) sees only ``p``::

    r(p) = P⊥ (y − A(p)·kp(p)),   kp(p) = argmin ‖P⊥ (y − A(p)·kp)‖,   P⊥ = 1 − U·Uᵀ

with ``U`` an orthonormal basis of the inertial columns' range and ``A(p)`` the passive columns.
Nine exponents instead of nine plus the wearer's base parameters plus ``kp``; no starting values
needed for the linear ones, and every step uses their exact optimum.  Bounds: each coefficient
between 0.5× and 2× its published value (its sign kept).  The inner fit is unconstrained; stage 2
then solves its SDP (bounds, LMI, table prior) once at the fitted exponents.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from pinid.linalg import RANK_TOL
from pinid.wearer.passive import ANATOMICAL, anatomy, column, exponents
from pinid.model.robot import as_robot
from pinid.result_protocol import ResultProtocol, panel

#: Bounds of a refined coefficient, as factors of its published value.
BOUNDS: tuple[float, float] = (0.5, 2.0)


@dataclass
class ExponentFit(ResultProtocol):
    """Fitted exponent coefficients ``{anatomical joint: (terms, 4)}``, the published ones, the names of
    the free coefficients (``knee[2].cK``), the unconstrained fit's torque RMS [N·m] at the published and
    the fitted exponents, the solver's evaluations, message and time [s]."""

    fitted: dict[str, np.ndarray]
    published: dict[str, np.ndarray]
    free: list[str]
    rms_published: float
    rms_fitted: float
    evaluations: int
    message: str
    seconds: float

    PLOTS = {"change": True}
    FILE_KIND = "passive exponent fit"

    def to_dict(self) -> dict:
        """Plain-dict form (for JSON)."""
        return {
            "fitted": {k: v.tolist() for k, v in self.fitted.items()},
            "published": {k: v.tolist() for k, v in self.published.items()},
            "free": self.free,
            "rms_published": self.rms_published,
            "rms_fitted": self.rms_fitted,
            "evaluations": self.evaluations,
            "message": self.message,
            "seconds": self.seconds,
        }

    @classmethod
    def from_dict(cls, d: dict) -> "ExponentFit":
        """Inverse of :meth:`to_dict`."""
        arrays = lambda m: {k: np.asarray(v, dtype=float).reshape(-1, 4) for k, v in m.items()}
        return cls(
            arrays(d["fitted"]),
            arrays(d["published"]),
            [str(n) for n in d["free"]],
            float(d["rms_published"]),
            float(d["rms_fitted"]),
            int(d["evaluations"]),
            str(d["message"]),
            float(d["seconds"]),
        )

    def _changes(self) -> list[tuple[str, float, float]]:
        """``(name, published, fitted)`` of every free coefficient [1/deg]."""
        out = []
        for name in self.free:
            kind, rest = name.split("[", 1)
            k, a = int(rest.split("]", 1)[0]), 1 + "HKA".index(name[-1])
            out.append((name, float(self.published[kind][k, a]), float(self.fitted[kind][k, a])))
        return out

    def text(self) -> str:
        """The free coefficients published and fitted [1/deg], then the torque RMS before and after [N·m]."""
        from pinid.report.text import text_table

        rows = [[n, f"{p:.5g}", f"{f:.5g}", f"{100 * (f / p - 1):+.3g}"] for n, p, f in self._changes()]
        return (
            text_table(["coefficient", "published", "fitted", "change %"], rows)
            + f"\ntorque RMS {self.rms_published:.4g} N·m at the published exponents, {self.rms_fitted:.4g} N·m "
            f"fitted ({self.evaluations} evaluations, {self.seconds:.3g} s)"
        )

    def _plot(self, kind: str, ax):
        """``"change"``: every free coefficient's change from its published value [%]."""
        fig, ax = panel(ax)
        changes = self._changes()
        ax.barh(range(len(changes)), [100 * (f / p - 1) for _, p, f in changes], color="tab:blue")
        ax.set_yticks(range(len(changes)), [n for n, _, _ in changes], fontsize=8)
        ax.axvline(0, color="0.3", lw=0.8)
        ax.set_xlabel("fitted − published [% of published]")
        ax.set_title(f"passive exponents: torque RMS {self.rms_published:.3g} → {self.rms_fitted:.3g} N·m")
        fig.tight_layout()
        return fig


def free_coefficients(robot) -> list[tuple[str, int, int]]:
    """The refined coefficients ``(anatomical joint, term, column 1..3)``: non-zero, on a joint the robot has."""
    robot = as_robot(robot)
    have = [kind for kind, _ in anatomy(robot) if kind is not None]
    return [
        (kind, k, 1 + a)
        for kind in have
        for k, c in enumerate(exponents(robot, kind))
        for a in range(3)
        if ANATOMICAL[a] in have and c[1 + a] != 0
    ]


def perturbed(robot, fraction: float = 0.2) -> dict[str, np.ndarray]:
    """Published exponent coefficients with each refined one (:func:`free_coefficients`) × (1 + fraction)
    and × (1 − fraction) in turn — a twin's wearer whose tissues differ from the published ones."""
    robot = as_robot(robot)
    out = {kind: exponents(robot, kind).copy() for kind, _ in anatomy(robot) if kind is not None}
    for n, (kind, k, a) in enumerate(free_coefficients(robot)):
        out[kind][k, a] *= 1 + fraction if n % 2 == 0 else 1 - fraction
    return out


def fit_exponents(robot, inertial: np.ndarray, y: np.ndarray, q: np.ndarray, *, tol: float = 1e-12) -> ExponentFit:
    """Exponents of ``robot``'s passive moments fitted to the torque ``y`` (N·nv,) [N·m] left by the exo,
    with the wearer's inertial columns ``inertial`` (N·nv, k) and joint positions ``q`` (N, nv) [rad]."""
    robot = as_robot(robot)
    from scipy.optimize import least_squares  # scipy.optimize: imported only for this refinement

    t0 = time.perf_counter()
    have = sorted({kind for kind, _ in anatomy(robot) if kind is not None}, key=ANATOMICAL.index)
    start = {kind: exponents(robot, kind) for kind in have}
    free = free_coefficients(robot)
    p0 = np.array([start[kind][k, a] for kind, k, a in free])
    lo, hi = np.minimum(BOUNDS[0] * p0, BOUNDS[1] * p0), np.maximum(BOUNDS[0] * p0, BOUNDS[1] * p0)
    U, s, _ = np.linalg.svd(inertial, full_matrices=False)
    U = U[:, s > RANK_TOL * s[0]] if s.size and s[0] > 0 else U[:, :0]
    n, nv = q.shape
    mapped = [i for i, (kind, _) in enumerate(anatomy(robot)) if kind is not None]

    def perp(x: np.ndarray) -> np.ndarray:
        return x - U @ (U.T @ x)

    def exps(p: np.ndarray) -> dict[str, np.ndarray]:
        out = {kind: c.copy() for kind, c in start.items()}
        for (kind, k, a), v in zip(free, p):
            out[kind][k, a] = v
        return out

    b = perp(y)

    def residual(p: np.ndarray) -> np.ndarray:
        col = column(q, robot, exps(p))
        A = np.zeros((n, nv, len(mapped)))
        for m, i in enumerate(mapped):
            A[:, i, m] = col[:, i]
        A = perp(A.reshape(n * nv, len(mapped)))
        kp, *_ = np.linalg.lstsq(A, b, rcond=None)
        return b - A @ kp

    sol = least_squares(residual, p0, bounds=(lo, hi), x_scale=np.abs(p0), method="trf", xtol=tol, ftol=tol, gtol=tol)
    rms0, rms1 = (float(np.sqrt(np.mean(residual(p) ** 2))) for p in (p0, sol.x))
    return ExponentFit(
        exps(sol.x),
        start,
        [f"{kind}[{k}].c{'HKA'[a - 1]}" for kind, k, a in free],
        rms0,
        rms1,
        int(sol.nfev),
        str(sol.message),
        time.perf_counter() - t0,
    )
