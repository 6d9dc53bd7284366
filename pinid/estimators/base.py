"""The estimator contract and the least-squares helpers estimators share.

An estimator follows the scikit-learn contract:

* ``__init__`` only stores its settings (keyword arguments, kept as attributes of the same name);
* ``fit(problem)`` takes an :class:`~pinid.identification.core.IdentificationProblem` and returns ``self``;
* fitted values end in ``_``:

  ``base_``       (nb,) base parameters, in the order of ``problem.base.names`` (required)
  ``standard_``   (p,) full standard parameters, or None when the estimator does not produce them
  ``weights_``    (rows,) row weights the fit used (None: ``problem.weights``); the standard deviations
                  and the condition number are computed with them
  ``history_``    list of floats (the cost per iteration), or None
  ``status_``     short text: ``"optimal"``, ``"ok"`` … (what the solver said)
  ``info_``       dict of anything else worth reporting (JSON-serialisable)

Adding an estimator is one file in ``pinid/estimators/`` with a subclass of :class:`Estimator` and one
line in the registry of ``pinid/estimators/__init__.py``.
"""

from __future__ import annotations

import inspect

import numpy as np

from pinid.errors import SolverError


class Estimator:
    """Base class: settings in ``__init__``, ``fit(problem) -> self``, fitted values ending in ``_``."""

    #: Registry name (``"ols"``); set by subclasses.
    name: str = "estimator"
    #: One line for tables and the report.
    description: str = ""
    #: True when ``standard_`` is physically consistent by construction (still checked afterwards).
    consistent_by_construction: bool = False

    base_: np.ndarray
    standard_: np.ndarray | None = None
    weights_: np.ndarray | None = None
    history_: list | None = None
    status_: str = "ok"
    info_: dict

    def fit(self, problem) -> "Estimator":  # pragma: no cover - abstract
        """Estimate the base parameters of ``problem`` (an :class:`~pinid.identification.core.IdentificationProblem`); set the fitted attributes (``base_`` …) and return ``self``."""
        raise NotImplementedError

    def get_params(self) -> dict:
        """The settings given to ``__init__`` (scikit-learn style)."""
        sig = inspect.signature(type(self).__init__)
        return {k: getattr(self, k) for k in sig.parameters if k != "self" and hasattr(self, k)}

    def predict(self, W: np.ndarray) -> np.ndarray:
        """Torque ``W @ base_`` for a stacked base regressor ``W``."""
        return np.asarray(W) @ self.base_

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"


def augmented_r(W: np.ndarray, tau: np.ndarray, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """Compress a weighted least-squares problem: ``(R, c, rho, scale)``.

    With ``A = diag(√w)·W·diag(1/scale)`` (columns scaled to unit norm) and ``y = √w·τ``,
    ``‖A x − y‖² = ‖R x − c‖² + rho²`` for every ``x``: ``R`` is ``(nb, nb)`` upper triangular, ``rho``
    the least-squares residual norm.  One pass over the tall matrix: the Cholesky factor of the
    column-scaled Gram matrix ``AᵀA`` when its condition number is below 1e10 (then the normal
    equations lose at most ~1e-6 relative accuracy, far below any noise), else — and for rank
    deficiency — Householder QR of ``[A | y]``.
    """
    import scipy.linalg

    W = np.asarray(W, dtype=float)
    y = np.asarray(tau, dtype=float)
    nb = W.shape[1]
    if weights is not None and not np.all(weights == 1.0):
        w = np.asarray(weights, dtype=float)
        Ww = W * w[:, None]
        G = Ww.T @ W
        b = Ww.T @ y
        yy = float(np.dot(w * y, y))
        del Ww
    else:
        w = None
        G = W.T @ W
        b = W.T @ y
        yy = float(np.dot(y, y))
    scale = np.sqrt(np.maximum(np.diag(G), 0.0))
    scale[scale == 0] = 1.0
    Gs = G / np.outer(scale, scale)
    ev = np.linalg.eigvalsh(Gs) if nb else np.ones(1)
    if nb and ev[0] > 1e-10 * ev[-1] and np.all(np.isfinite(Gs)):
        try:
            R = scipy.linalg.cholesky(Gs, lower=False)
            c = scipy.linalg.solve_triangular(R, b / scale, trans="T")
            rho = float(np.sqrt(max(yy - float(c @ c), 0.0)))
            return R, c, rho, scale
        except (np.linalg.LinAlgError, ValueError):
            pass
    # ill-conditioned or rank-deficient: Householder QR of the scaled, weighted [A | y]
    aug = np.empty((W.shape[0], nb + 1))
    if w is not None:
        sw = np.sqrt(w)
        np.multiply(W, (sw[:, None] / scale), out=aug[:, :nb])
        aug[:, nb] = y * sw
    else:
        np.divide(W, scale, out=aug[:, :nb])
        aug[:, nb] = y
    R_aug = np.linalg.qr(aug, mode="r")
    k = min(R_aug.shape[0], nb + 1)
    R_full = np.zeros((nb + 1, nb + 1))
    R_full[:k] = R_aug[:k]
    return R_full[:nb, :nb], R_full[:nb, nb], float(abs(R_full[nb, nb])), scale


def solve_r(R: np.ndarray, c: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """The least-squares solution ``x`` of the compressed problem of :func:`augmented_r`."""
    import scipy.linalg

    d = np.abs(np.diag(R))
    if d.size and (not np.all(np.isfinite(R)) or d.min() <= 1e-13 * d.max()):
        raise SolverError("least squares: the (weighted) base regressor is rank deficient")
    return scipy.linalg.solve_triangular(R, c) / scale


def weighted_lstsq(W: np.ndarray, tau: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """``argmin ‖diag(√w)(W x − τ)‖²`` through a column-scaled QR factorisation."""
    R, c, _, scale = augmented_r(W, tau, weights)
    return solve_r(R, c, scale)


def joint_weights(problem, residual: np.ndarray, floor: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """Row weights 1/σ_j² from the residual variance σ_j² of each joint's rows; returns ``(weights, σ)``.

    σ_j² = Σ_{rows of j} r² / (n_j − nb·n_j/rows) (the degrees of freedom shared out by row count).
    A joint with (numerically) no residual gets σ_j floored at ``floor``·RMS(τ_j) so weights stay finite.
    """
    nv, nb, rows = problem.nv, problem.nb, problem.rows
    sigma = np.zeros(nv)
    for j in range(nv):
        sel = problem.joint == j
        n_j = int(sel.sum())
        if n_j == 0:
            sigma[j] = 1.0
            continue
        dof = max(n_j - nb * n_j / rows, 1.0)
        s2 = float(residual[sel] @ residual[sel]) / dof
        tau_rms = float(np.sqrt(np.mean(problem.tau[sel] ** 2))) if n_j else 1.0
        sigma[j] = max(np.sqrt(s2), floor * max(tau_rms, 1e-300))
    return (1.0 / sigma**2)[problem.joint], sigma
