"""Small conic programs stated once, solved by Clarabel directly or, for another solver, through cvxpy.

Problem in ``z ∈ ℝⁿ`` (every quantity dimensionless, as the caller scales it)::

    minimise    Σ_k w_k·‖M_k·z − m_k‖
    subject to  A·z = b,   C·z ≥ d,   sym(mat(B_j·z + c_j)) ⪰ 0   (every PSD block j)

``mat`` reshapes a column-major vector of length d² to a d × d matrix and ``sym`` takes its symmetric
part.  With the solver "CLARABEL" (the default of every caller) the problem goes to
``clarabel.DefaultSolver`` as ``min qᵀx  s.t.  A·x + s = b, s ∈ K`` over ``x = [z, t]``: one epigraph
variable ``t_k`` per norm (cost ``Σ w_k·t_k``, second-order cone ``(t_k, M_k·z − m_k)``), the PSD blocks
as Clarabel's triangle cones (svec: the upper triangle column by column, off-diagonal entries × √2).
cvxpy is then never imported (its import costs more than the solve).  Any other solver name goes
through cvxpy, imported on use, with the same problem.  Both report cvxpy's status names.

Why beside cvxpy (measured; docs/benchmarks.md, "Without cvxpy"): importing cvxpy took 0.13 s of
``pinid identify`` (more where scipy.stats is not loaded yet: re-measured 2026-11-24, cvxpy 1.9.3, 2 cores
at load 4, 0.83 s best of 5 after importing pinid's preprocessing and estimators), and its
canonicalisation about 6 ms per problem: a warm ``sdp`` fit on exo_leg went 7.9 → 1.3 ms, of which
Clarabel's own solve is 0.7 ms (re-measured: 30 ms through cvxpy, 1.1 ms here).
tests/model/test_conic.py compares with cvxpy, to tolerances derived from the solvers' stopping rules.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from pinid.errors import SolverError, SpecError
from pinid.checks import count

#: Clarabel's tolerances used by default (its own defaults are 1e-8): the data term is a norm with a
#: kink at the least-squares solution, and 1e-10 brings noise-free base parameters back to ≤ 1e-6.
CLARABEL_OPTIONS = {"tol_gap_abs": 1e-10, "tol_gap_rel": 1e-10, "tol_feas": 1e-10, "tol_ktratio": 1e-8}

#: Clarabel's statuses under cvxpy's names; any other (NumericalError, InsufficientProgress, …) is a failure.
CLARABEL_STATUS = {
    "Solved": "optimal",
    "AlmostSolved": "optimal_inaccurate",
    "PrimalInfeasible": "infeasible",
    "AlmostPrimalInfeasible": "infeasible_inaccurate",
    "DualInfeasible": "unbounded",
    "AlmostDualInfeasible": "unbounded_inaccurate",
    "MaxIterations": "user_limit",
    "MaxTime": "user_limit",
}


def svec_operator(d: int) -> np.ndarray:
    """The (d(d+1)/2, d²) matrix taking a column-major vec(F) to Clarabel's svec of F's symmetric part."""
    d = count(d, "d", low=1)
    out = np.zeros((d * (d + 1) // 2, d * d))
    r = 0
    for j in range(d):
        for i in range(j + 1):
            if i == j:
                out[r, i + j * d] = 1.0
            else:  # √2 · (F_ij + F_ji) / 2
                out[r, i + j * d] = out[r, j + i * d] = np.sqrt(0.5)
            r += 1
    return out


@dataclass
class ConicSolution:
    """A solved problem: the minimiser ``z``, the status (cvxpy's names), the solver's own time [s]
    (None when it does not say) and each norm ``‖M_k·z − m_k‖`` at ``z``, in the order they were added."""

    z: np.ndarray
    status: str
    solve_seconds: float | None
    norms: list[float]


class ConicProblem:
    """A sum of weighted norms of affine maps of ``z`` under linear and PSD constraints (see the module text)."""

    def __init__(self, n: int) -> None:
        self.n = int(n)
        self.norm_terms: list[tuple[np.ndarray, np.ndarray, float]] = []
        self.equalities: list[tuple[np.ndarray, np.ndarray]] = []
        self.inequalities: list[tuple[np.ndarray, np.ndarray]] = []
        self.psd: list[tuple[np.ndarray, np.ndarray, int]] = []

    def _rows(self, A, b) -> tuple[np.ndarray, np.ndarray]:
        A = np.atleast_2d(np.asarray(A, dtype=float))
        b = np.broadcast_to(np.asarray(b, dtype=float), (A.shape[0],)).copy()
        if A.shape[1] != self.n:
            raise ValueError(f"{A.shape[1]} columns, expected {self.n}")
        return A, b

    def add_norm(self, M, m, weight: float = 1.0) -> int:
        """Add ``weight·‖M·z − m‖`` to the cost; returns its index in :attr:`ConicSolution.norms`."""
        if not weight >= 0:
            raise ValueError(f"norm weight {weight}, expected ≥ 0")
        self.norm_terms.append((*self._rows(M, m), float(weight)))
        return len(self.norm_terms) - 1

    def add_equality(self, A, b) -> None:
        """Require ``A·z = b``."""
        self.equalities.append(self._rows(A, b))

    def add_inequality(self, C, d) -> None:
        """Require ``C·z ≥ d`` (row by row)."""
        self.inequalities.append(self._rows(C, d))

    def add_psd(self, B, c=None) -> None:
        """Require ``sym(mat(B·z + c)) ⪰ 0``: ``B`` (d², n), ``c`` (d²,) a column-major vec (0 when None)."""
        B, c = self._rows(B, 0.0 if c is None else c)
        d = int(round(np.sqrt(B.shape[0])))
        if d * d != B.shape[0]:
            raise ValueError(f"PSD block of {B.shape[0]} rows, expected a square number")
        self.psd.append((B, c, d))

    def solve(
        self, solver: str = "CLARABEL", options: dict | None = None, what: str = "conic problem"
    ) -> ConicSolution:
        """Solve (Clarabel with :data:`CLARABEL_OPTIONS` unless ``options`` overrides them; another solver
        through cvxpy); SolverError, its message starting with ``what``, unless the status is optimal or
        optimal_inaccurate."""
        clarabel = solver.upper() == "CLARABEL"
        opts = dict(CLARABEL_OPTIONS) if clarabel else {}
        opts.update(options or {})
        z, status, seconds = (self._clarabel if clarabel else self._cvxpy)(solver, opts, what)
        _check_status(status, solver, what)
        if z is None:
            raise SolverError(f"{what}: solver {solver} returned status '{status}' without a solution")
        z = np.asarray(z, dtype=float).reshape(-1)
        return ConicSolution(z, status, seconds, [float(np.linalg.norm(M @ z - m)) for M, m, _ in self.norm_terms])

    def _clarabel(self, solver: str, opts: dict, what: str) -> tuple[np.ndarray | None, str, float | None]:
        import clarabel
        import scipy.sparse

        n, k = self.n, len(self.norm_terms)
        rows, rhs, cones = [], [], []
        if self.equalities:  # s = b − A·z = 0
            A, b = (np.concatenate(x) for x in zip(*self.equalities))
            rows.append(np.hstack([A, np.zeros((len(b), k))]))
            rhs.append(b)
            cones.append(clarabel.ZeroConeT(len(b)))
        if self.inequalities:  # s = C·z − d ≥ 0
            C, d = (np.concatenate(x) for x in zip(*self.inequalities))
            rows.append(np.hstack([-C, np.zeros((len(d), k))]))
            rhs.append(-d)
            cones.append(clarabel.NonnegativeConeT(len(d)))
        for i, (M, m, _) in enumerate(self.norm_terms):  # s = (t_i, M·z − m) in the second-order cone
            block = np.zeros((1 + len(m), n + k))
            block[0, n + i] = -1.0
            block[1:, :n] = -M
            rows.append(block)
            rhs.append(np.concatenate([[0.0], -m]))
            cones.append(clarabel.SecondOrderConeT(1 + len(m)))
        for B, c, d in self.psd:  # s = svec(B·z + c) in the PSD triangle cone
            V = svec_operator(d)
            rows.append(np.hstack([-V @ B, np.zeros((V.shape[0], k))]))
            rhs.append(V @ c)
            cones.append(clarabel.PSDTriangleConeT(d))
        q = np.concatenate([np.zeros(n), [w for _, _, w in self.norm_terms]])
        A = scipy.sparse.csc_matrix(np.vstack(rows) if rows else np.zeros((0, n + k)))
        P = scipy.sparse.csc_matrix((n + k, n + k))
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        # one thread: Clarabel's default starts a thread pool at the first PSD solve, and a worker process
        # forked after that (pinid.parallel: compare, excitation) waits for ever on the pool's absent threads;
        # these problems are small, so the result is the same (to the bit) and faster
        if hasattr(settings, "max_threads"):  # Clarabel ≥ 0.10; 0.9 has no thread pool
            settings.max_threads = 1
        for key, value in opts.items():
            try:
                setattr(settings, key, value)
            except (AttributeError, TypeError) as exc:
                raise SpecError(f"{what}: Clarabel setting {key}={value!r} refused ({exc})") from None
        try:
            result = clarabel.DefaultSolver(
                P, q, A, np.concatenate(rhs) if rhs else np.zeros(0), cones, settings
            ).solve()
        except (ValueError, RuntimeError) as exc:
            raise SolverError(f"{what}: solver {solver} failed ({str(exc).strip().splitlines()[0]})") from None
        status = CLARABEL_STATUS.get(str(result.status))
        if status is None:
            raise SolverError(f"{what}: solver {solver} failed (Clarabel status '{result.status}')")
        z = np.asarray(result.x, dtype=float)[:n] if result.x is not None and len(result.x) else None
        return z, status, float(result.solve_time)

    def _cvxpy(self, solver: str, opts: dict, what: str) -> tuple[np.ndarray | None, str, float | None]:
        import cvxpy as cp  # heavy optional dependency: imported only for a solver other than Clarabel

        z = cp.Variable(self.n)
        cost = sum((w * cp.norm(M @ z - m) for M, m, w in self.norm_terms), cp.Constant(0.0))
        cons = [A @ z == b for A, b in self.equalities] + [C @ z >= d for C, d in self.inequalities]
        for B, c, d in self.psd:
            F = cp.reshape(B @ z + c, (d, d), order="F")
            cons.append(0.5 * (F + F.T) >> 0)
        prob = cp.Problem(cp.Minimize(cost), cons)
        try:
            with warnings.catch_warnings():  # the status says it; the result is checked by the caller
                warnings.simplefilter("ignore")
                prob.solve(solver=solver, **opts)
        except cp.error.SolverError as exc:
            raise SolverError(f"{what}: solver {solver} failed ({str(exc).strip().splitlines()[0]})") from None
        try:
            seconds = float(prob.solver_stats.solve_time)
        except (AttributeError, TypeError):
            seconds = None
        return z.value, str(prob.status), seconds


def _check_status(status: str, solver: str, what: str) -> None:
    """SolverError unless ``status`` (cvxpy's names) is optimal or optimal_inaccurate."""
    if status in ("infeasible", "infeasible_inaccurate"):
        raise SolverError(
            f"{what}: solver {solver} says the constraints are infeasible (status '{status}'); check the mass bounds"
        )
    if status in ("unbounded", "unbounded_inaccurate"):
        raise SolverError(f"{what}: solver {solver} says the problem is unbounded (status '{status}')")
    if status not in ("optimal", "optimal_inaccurate"):
        raise SolverError(f"{what}: solver {solver} stopped with status '{status}'")
