"""Finite Fourier-series joint trajectories (seed 001, Eq. (19)).

Per joint ``j``:  q_j(t) = q0_j + Σ_{k=1..N} a_jk·sin(k·ω·t) + b_jk·cos(k·ω·t),
with ω the base frequency [rad/s]; dq and ddq follow analytically.  The coefficients are position
amplitudes [rad or m].  A trajectory is periodic with period 2π/ω.

File format (JSON): ``{"joints": [...], "base_frequency": ω, "harmonics": N, "q0": [...],
"a": [[...] per joint], "b": [[...] per joint], "unit": "rad"}`` — extra keys (the design report of
``pinid excite``) are kept in ``meta`` and written back.  ``"unit": "deg"`` reads q0, a and b as degrees,
so that published tables (seed 001 Table 3) can be loaded as printed.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pinid.errors import SpecError
from pinid.io import read_json, write_json, write_text


@dataclass
class FourierTrajectory:
    """A Fourier trajectory for ``joints``; ``a``, ``b`` are ``(nv, N)`` [rad], ``q0`` is ``(nv,)`` [rad]."""

    joints: list[str]
    base_frequency: float
    q0: np.ndarray
    a: np.ndarray
    b: np.ndarray
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.q0 = np.asarray(self.q0, dtype=float).reshape(-1)
        self.a = np.atleast_2d(np.asarray(self.a, dtype=float))
        self.b = np.atleast_2d(np.asarray(self.b, dtype=float))
        nv = len(self.joints)
        if self.q0.shape != (nv,) or self.a.shape[0] != nv or self.a.shape != self.b.shape:
            raise SpecError(
                f"Fourier trajectory: q0 {self.q0.shape}, a {self.a.shape}, b {self.b.shape} do not match "
                f"{nv} joints; expected q0 ({nv},) and a, b ({nv}, N)"
            )
        if not np.isfinite(self.base_frequency) or self.base_frequency <= 0:
            raise SpecError(f"Fourier trajectory: base_frequency {self.base_frequency}, expected > 0 [rad/s]")
        for name in ("q0", "a", "b"):
            if not np.all(np.isfinite(getattr(self, name))):
                raise SpecError(f"Fourier trajectory: {name} has NaN or infinite values")

    @property
    def harmonics(self) -> int:
        """Number of harmonics N."""
        return self.a.shape[1]

    @property
    def period(self) -> float:
        """Period 2π/ω [s]."""
        return 2 * np.pi / self.base_frequency

    def evaluate(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, dq, ddq)`` at times ``t`` [s], each ``(len(t), nv)`` [rad, rad/s, rad/s²]."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        k = np.arange(1, self.harmonics + 1)
        kw = k * self.base_frequency
        s, c = np.sin(np.outer(t, kw)), np.cos(np.outer(t, kw))  # (n, N)
        q = self.q0 + s @ self.a.T + c @ self.b.T
        dq = (c * kw) @ self.a.T - (s * kw) @ self.b.T
        ddq = -(s * kw**2) @ self.a.T - (c * kw**2) @ self.b.T
        return q, dq, ddq

    def sample(
        self, rate: float, duration: float | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(t, q, dq, ddq)`` sampled at ``rate`` [Hz] over ``duration`` [s] (default one period)."""
        duration = self.period if duration is None else duration
        t = np.arange(int(round(duration * rate))) / rate
        return (t, *self.evaluate(t))

    def derivative(self, t: np.ndarray | float, order: int) -> np.ndarray:
        """The ``order``-th time derivative of q at times ``t`` [s], ``(len(t), nv)`` [rad/sᵒʳᵈᵉʳ].

        ``order`` 0 is q, 1 is dq, 2 is ddq; 3 and 4 (jerk, snap) serve to locate extremes exactly.
        """
        if int(order) != order or order < 0:
            raise ValueError(f"derivative order {order!r}, expected an integer >= 0")
        t = np.atleast_1d(np.asarray(t, dtype=float))
        kw = np.arange(1, self.harmonics + 1) * self.base_frequency
        phase = np.outer(t, kw) + order * np.pi / 2  # d^n/dt^n sin(x) = sin(x + nπ/2), same for cos
        out = (np.sin(phase) * kw**order) @ self.a.T + (np.cos(phase) * kw**order) @ self.b.T
        return out + self.q0 if order == 0 else out

    def for_joints(self, names: list[str], robot: str = "the model") -> "FourierTrajectory":
        """This trajectory with its joints in the order ``names`` (matched by name, never by position);
        SpecError naming both lists unless it has exactly those joints."""
        if sorted(self.joints) != sorted(names) or len(set(self.joints)) != len(self.joints):
            raise SpecError(f"trajectory joints {list(self.joints)} do not match {robot}'s active joints {list(names)}")
        idx = [self.joints.index(j) for j in names]
        return FourierTrajectory(
            list(names), self.base_frequency, self.q0[idx], self.a[idx], self.b[idx], meta=dict(self.meta)
        )

    def starts_at_rest(self, tol: float = 1e-9) -> bool:
        """Whether dq and ddq are zero at t = 0 (and so at the end of every period), to ``tol``."""
        _, dq, ddq = self.evaluate(0.0)
        return bool(np.all(np.abs(dq) <= tol) and np.all(np.abs(ddq) <= tol))

    @classmethod
    def from_eq19(
        cls,
        joints: list[str],
        base_frequency: float,
        q0,
        a,
        b,
        *,
        unit: str = "deg",
        q0_unit: str = "rad",
        meta: dict | None = None,
    ) -> "FourierTrajectory":
        """A trajectory from coefficients printed in the form of seed 001's Eq. (19).

        Seed 001 prints the offsets q0 in radians and the coefficients a_k, b_k of its Table 3 in degrees;
        ``unit`` is the unit of ``a`` and ``b``, ``q0_unit`` that of ``q0`` ("rad" or "deg").  The result is
        stored in radians.
        """
        scales = {"rad": 1.0, "deg": np.pi / 180}
        for name, u in (("unit", unit), ("q0_unit", q0_unit)):
            if u not in scales:
                raise SpecError(f"Fourier trajectory: {name} {u!r}, expected 'rad' or 'deg'")
        return cls(
            list(joints),
            float(base_frequency),
            np.asarray(q0, float) * scales[q0_unit],
            np.asarray(a, float) * scales[unit],
            np.asarray(b, float) * scales[unit],
            meta=dict(meta or {}),
        )

    def to_csv(self, path: str | os.PathLike, rate: float, duration: float | None = None) -> Path:
        """Write samples at ``rate`` [Hz] over ``duration`` [s] (default one period) as CSV, atomically.

        Columns: ``t`` [s], then ``q_<joint>`` [rad], ``dq_<joint>`` [rad/s], ``ddq_<joint>`` [rad/s²] for
        every joint — what a rig's position controller reads.
        """
        if not np.isfinite(rate) or rate <= 0:
            raise SpecError(f"CSV export: rate {rate}, expected > 0 [Hz]")
        if duration is not None and (not np.isfinite(duration) or duration <= 0):
            raise SpecError(f"CSV export: duration {duration}, expected > 0 [s]")
        t, q, dq, ddq = self.sample(rate, duration)
        header = ["t"] + [f"{p}_{j}" for p in ("q", "dq", "ddq") for j in self.joints]
        data = np.column_stack([t, q, dq, ddq])
        lines = [",".join(header)] + [",".join(f"{v:.10g}" for v in row) for row in data]
        return write_text(path, "\n".join(lines) + "\n")

    # ------------------------------------------------------------------ files
    def to_dict(self) -> dict:
        """Plain-dict form (radians); design information in ``meta`` is included."""
        d = dict(self.meta)
        d.update(
            joints=list(self.joints),
            base_frequency=float(self.base_frequency),
            harmonics=self.harmonics,
            q0=self.q0.tolist(),
            a=self.a.tolist(),
            b=self.b.tolist(),
            unit="rad",
        )
        return d

    @classmethod
    def from_dict(cls, d: dict, *, source: str = "<dict>") -> "FourierTrajectory":
        """Read the JSON form; ``unit`` "deg" converts q0, a, b from degrees."""
        try:
            unit = d.get("unit", "rad")
            if unit not in ("rad", "deg"):
                raise SpecError(f"{source}: unit {unit!r}, expected 'rad' or 'deg'")
            scale = np.pi / 180 if unit == "deg" else 1.0
            meta = {
                k: v for k, v in d.items() if k not in ("joints", "base_frequency", "q0", "a", "b", "unit", "harmonics")
            }
            return cls(
                list(d["joints"]),
                float(d["base_frequency"]),
                np.asarray(d["q0"], float) * scale,
                np.asarray(d["a"], float) * scale,
                np.asarray(d["b"], float) * scale,
                meta=meta,
            )
        except KeyError as exc:
            raise SpecError(
                f"{source}: missing key {exc.args[0]!r}; a Fourier trajectory needs joints, base_frequency, q0, a, b"
            ) from None
        except (TypeError, ValueError) as exc:
            if isinstance(exc, SpecError):
                raise
            raise SpecError(f"{source}: malformed Fourier trajectory ({exc})") from None

    def save(self, path: str | os.PathLike) -> Path:
        """Write as JSON (atomically)."""
        return write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | os.PathLike) -> "FourierTrajectory":
        """Read a JSON file written by :meth:`save` or by ``pinid excite``."""
        return cls.from_dict(read_json(path, "trajectory (joints, base_frequency, q0, a, b)"), source=str(path))
