"""The conic-problem builder (Clarabel directly, no cvxpy) against cvxpy and closed forms; the physically
consistent estimator on it, against the cvxpy formulation it replaced."""

from __future__ import annotations

import subprocess
import sys

import warnings

import numpy as np
import pytest

from pinid.errors import SolverError, SpecError
from pinid.estimators import SDP
from pinid.problem.problem import IdentificationProblem
from pinid.model.conic import CLARABEL_OPTIONS, ConicProblem, svec_operator
from pinid.model.lmi import consistent_completion, null_projector
from pinid.model.physical import PSEUDO_INERTIA_BASIS, parameter_scale

from test_identification import relative_errors, true_base, truth_model, twin


def psd_part(A: np.ndarray) -> np.ndarray:
    """The nearest positive semidefinite matrix to symmetric ``A`` in the Frobenius norm."""
    w, V = np.linalg.eigh(A)
    return (V * np.maximum(w, 0.0)) @ V.T


# ---------------------------------------------------------------------------------------------- the PSD convention
def test_svec_operator_is_clarabels_scaled_upper_triangle():
    F = np.arange(9.0).reshape(3, 3, order="F")  # not symmetric: svec takes the symmetric part
    Fs = 0.5 * (F + F.T)
    r2 = np.sqrt(2.0)
    expected = [Fs[0, 0], r2 * Fs[0, 1], Fs[1, 1], r2 * Fs[0, 2], r2 * Fs[1, 2], Fs[2, 2]]
    np.testing.assert_allclose(svec_operator(3) @ F.reshape(-1, order="F"), expected)
    # an isometry on symmetric matrices: ‖svec F‖ = ‖F‖_F
    assert np.linalg.norm(svec_operator(3) @ Fs.reshape(-1, order="F")) == pytest.approx(np.linalg.norm(Fs))


def test_psd_block_optimum_is_the_smallest_eigenvalue():
    """max t s.t. A − t·I ⪰ 0 (written as min |t − 100|) is λ_min(A); a wrong off-diagonal scaling is not."""
    rng = np.random.default_rng(4)
    X = rng.normal(size=(4, 4))
    A = X @ X.T - 1.5 * np.eye(4)  # off-diagonal entries matter, smallest eigenvalue negative
    K = rng.normal(size=(4, 4))
    conic = ConicProblem(1)
    conic.add_norm([[1.0]], [100.0])
    # mat(B·t + c) = A + (K − Kᵀ) − t·I: the antisymmetric part must be ignored
    B, c = -np.eye(4).reshape(-1, 1), (A + K - K.T).reshape(-1, order="F")
    conic.add_psd(B, c)
    sol = conic.solve()
    assert sol.status == "optimal"
    # the cost 100 − t is linear: t is off by the gap, plus what the PSD residual lets t past λ_min
    # (measured: 0.1 of it)
    tol = gap_tolerance(sol.norms[0], *CLARABEL_GAP) + np.sqrt(2) * feasibility_tolerance(B, sol.z, c)
    assert abs(sol.z[0] - np.linalg.eigvalsh(A)[0]) <= tol
    assert abs(sol.norms[0] - (100 - np.linalg.eigvalsh(A)[0])) <= tol
    assert sol.solve_seconds is not None and sol.solve_seconds >= 0


def test_nearest_psd_matrix_in_frobenius_norm():
    rng = np.random.default_rng(5)
    X = rng.normal(size=(3, 3))
    A = X + X.T  # indefinite
    conic = ConicProblem(9)  # z = vec(Z)
    conic.add_norm(np.eye(9), A.reshape(-1, order="F"))
    conic.add_psd(np.eye(9))
    sol = conic.solve()
    Z = sol.z.reshape(3, 3, order="F")
    np.testing.assert_allclose(Z, psd_part(A), atol=1e-7)
    w = np.linalg.eigvalsh(A)
    # the optimum's value to the solver's gap (measured: 0.003 of it); Z above is held to 1e-7, tighter than
    # the √(2·value·gap) ≈ 5e-5 that rule gives it (measured: 2.8e-8)
    tol = gap_tolerance(sol.norms[0], *CLARABEL_GAP) + feasibility_tolerance(np.eye(9), sol.z, np.zeros(9))
    assert abs(sol.norms[0] - np.linalg.norm(w[w < 0])) <= tol


# ---------------------------------------------------------------------------------------------- against cvxpy
def random_problem(seed: int) -> tuple[ConicProblem, dict]:
    """A random feasible SOCP/SDP: two weighted norms, equalities, inequalities, two PSD blocks."""
    rng = np.random.default_rng(seed)
    n = 8
    zf = rng.normal(size=n)  # a strictly feasible point
    data = {
        "norms": [
            (rng.normal(size=(6, n)), rng.normal(size=6), 1.0),
            (rng.normal(size=(n, n)), rng.normal(size=n), 0.3),
        ],
        "eq": (rng.normal(size=(2, n)), None),
        "ge": (rng.normal(size=(3, n)), None),
        "psd": [],
    }
    data["eq"] = (data["eq"][0], data["eq"][0] @ zf)
    data["ge"] = (data["ge"][0], data["ge"][0] @ zf - 0.1)
    for d in (3, 4):
        B = rng.normal(size=(d * d, n))
        c = (0.2 * np.eye(d)).reshape(-1) - B @ zf
        data["psd"].append((B, c))
    conic = ConicProblem(n)
    for M, m, w in data["norms"]:
        conic.add_norm(M, m, w)
    conic.add_equality(*data["eq"])
    conic.add_inequality(*data["ge"])
    for B, c in data["psd"]:
        conic.add_psd(B, c)
    return conic, data


def cvxpy_optimum(data: dict, solver: str = "CLARABEL") -> float:
    """The same problem written directly in cvxpy."""
    import cvxpy as cp

    n = data["eq"][0].shape[1]
    z = cp.Variable(n)
    cost = sum(w * cp.norm(M @ z - m) for M, m, w in data["norms"])
    cons = [data["eq"][0] @ z == data["eq"][1], data["ge"][0] @ z >= data["ge"][1]]
    for B, c in data["psd"]:
        d = int(np.sqrt(B.shape[0]))
        F = cp.reshape(B @ z + c, (d, d), order="F")
        cons.append(0.5 * (F + F.T) >> 0)
    prob = cp.Problem(cp.Minimize(cost), cons)
    with warnings.catch_warnings():  # optimal_inaccurate is accepted below: cvxpy's warning about it is not news
        warnings.filterwarnings("ignore", "Solution may be inaccurate", UserWarning)
        prob.solve(solver=solver, **(CLARABEL_OPTIONS if solver == "CLARABEL" else {}))
    assert prob.status in ("optimal", "optimal_inaccurate")  # 1e-10 is not always reached on a random SDP
    return float(prob.value)


def gap_tolerance(value: float, gap_abs: float, gap_rel: float) -> float:
    """How far a solver's objective may sit from the optimum when it stops on its duality gap
    (|primal − dual| ≤ gap_abs + gap_rel·|objective|; the optimum lies between the two)."""
    return gap_abs + gap_rel * abs(value)


CLARABEL_GAP = (CLARABEL_OPTIONS["tol_gap_abs"], CLARABEL_OPTIONS["tol_gap_rel"])


def feasibility_tolerance(A: np.ndarray, z: np.ndarray, b: np.ndarray) -> float:
    """How far ``A·z`` may miss ``b`` when the solver stops on its feasibility tolerance, relative to the
    sizes involved (Clarabel's primal residual test: ‖A·z + s − b‖∞ ≤ tol_feas·(1 + ‖b‖∞ + ‖A·z‖∞))."""
    return CLARABEL_OPTIONS["tol_feas"] * (1.0 + np.max(np.abs(b)) + np.max(np.abs(A @ z)))


@pytest.mark.parametrize("seed", range(8))
def test_random_socp_sdp_equals_cvxpy(seed):
    conic, data = random_problem(seed)
    sol = conic.solve()
    assert sol.status in ("optimal", "optimal_inaccurate")
    value = sum(w * v for (_, _, w), v in zip(data["norms"], sol.norms))
    # both are Clarabel at CLARABEL_OPTIONS: each within its gap of the optimum (measured: ≤ 0.33 of the
    # sum, the seeds that stop "optimal_inaccurate" included)
    assert abs(value - cvxpy_optimum(data)) <= 2 * gap_tolerance(value, *CLARABEL_GAP)
    # the solution is feasible to the solver's feasibility tolerance (measured: ≤ 0.05 of it)
    A, b = data["eq"]
    np.testing.assert_allclose(A @ sol.z, b, rtol=0, atol=feasibility_tolerance(A, sol.z, b))
    C, d = data["ge"]
    assert np.all(C @ sol.z >= d - feasibility_tolerance(C, sol.z, d))
    for B, c in data["psd"]:
        n = int(np.sqrt(B.shape[0]))
        F = (B @ sol.z + c).reshape(n, n, order="F")
        # the slack is in the cone exactly; B·z + c misses it by the residual (× √2: the svec scaling)
        assert np.linalg.eigvalsh(0.5 * (F + F.T))[0] >= -np.sqrt(2) * feasibility_tolerance(B, sol.z, c)


def test_other_solvers_go_through_cvxpy():
    conic, data = random_problem(0)
    scs = {"eps_abs": 1e-9, "eps_rel": 1e-9, "max_iters": 200_000}
    sol = conic.solve("SCS", scs)
    assert sol.status in ("optimal", "optimal_inaccurate")
    value = sum(w * v for (_, _, w), v in zip(data["norms"], sol.norms))
    # SCS stops on its gap (eps_abs + eps_rel·|objective|), Clarabel on its own: the sum (measured: 0.07 of it)
    tol = gap_tolerance(value, scs["eps_abs"], scs["eps_rel"]) + gap_tolerance(value, *CLARABEL_GAP)
    assert abs(value - cvxpy_optimum(data)) <= tol


def test_infeasible_unknown_setting_and_iteration_limit():
    conic = ConicProblem(1)
    conic.add_norm([[1.0]], [0.0])
    conic.add_inequality([[1.0]], 2.0)
    conic.add_inequality([[-1.0]], -1.0)  # 2 ≤ z ≤ 1
    with pytest.raises(
        SolverError, match=r"^toy: solver CLARABEL says the constraints are infeasible \(status 'infeasible"
    ):
        conic.solve(what="toy")
    with pytest.raises(SpecError, match="toy: Clarabel setting no_such_setting=1 refused"):
        conic.solve(options={"no_such_setting": 1}, what="toy")
    conic, _ = random_problem(1)
    with pytest.raises(SolverError, match=r"^toy: solver CLARABEL stopped with status 'user_limit'$"):
        conic.solve(options={"max_iter": 1}, what="toy")


# ---------------------------------------------------------------------------------------------- the sdp estimator
def cvxpy_sdp(problem, regularization: float = 1e-3, margin: float = 1e-8) -> tuple[np.ndarray, float]:
    """θ of the cvxpy formulation SDP had before the builder (weighting "none", no mass bounds), and the
    relative change of θ that round-off in building the problem may cause: n·eps·cond([G; λ·N]) (the
    cost's two matrices stacked; both formulations build them from the same data in another order)."""
    import cvxpy as cp

    from pinid.model import terms as _terms

    R, c, rho, colscale = problem.compressed()
    norm_y = float(np.sqrt(c @ c + rho * rho)) or 1.0
    P = problem.base.P
    nv = problem.nv
    S = parameter_scale(problem.nominal, nv, len(problem.terms))
    G = (R * colscale) @ P * S / norm_y
    z = cp.Variable(P.shape[1])
    cost = cp.norm(G @ z - c / norm_y)
    N = null_projector(P * S)
    if regularization > 0 and N is not None:
        cost = cost + regularization * cp.norm(N @ (z - problem.nominal / S))
    cons = []
    for i in range(nv):
        M, L = S[10 * i], np.sqrt(S[10 * i + 4] / S[10 * i])
        T = np.diag([1.0 / (np.sqrt(M) * L)] * 3 + [1.0 / np.sqrt(M)])
        J = sum(z[10 * i + k] * S[10 * i + k] * (T @ PSEUDO_INERTIA_BASIS[k] @ T) for k in range(10))
        cons.append(0.5 * (J + J.T) >> margin * np.eye(4))
    idx = 10 * nv + np.flatnonzero(_terms.nonnegative(problem.model, problem.terms))
    if idx.size:
        cons.append(z[idx] >= 0)
    prob = cp.Problem(cp.Minimize(cost), cons)
    prob.solve(solver="CLARABEL", **CLARABEL_OPTIONS)
    assert prob.status == "optimal"
    stacked = np.vstack([G, regularization * N]) if regularization > 0 and N is not None else G
    return np.asarray(z.value) * S, stacked.shape[1] * np.finfo(float).eps * np.linalg.cond(stacked)


@pytest.mark.parametrize("name", ["exo_leg", "ur5"])
def test_sdp_noise_free_twin_recovers_base_parameters(name):
    model = truth_model(name)
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=10, rate=200, seed=2))
    _, truth = true_base(model)
    est = SDP().fit(problem)
    assert est.status_ == "optimal"
    assert relative_errors(model, est.base_, truth).max() <= 1e-6
    assert est.info_["solve_seconds"] > 0 and est.info_["regularizer"] >= 0


@pytest.mark.parametrize(
    "name, motion",
    [("exo_leg", {}), ("ur5", {"amplitude": 0.05, "around": [0.3, -1.0, 1.0, -0.5, 0.8, 0.2]})],
)
def test_sdp_on_noisy_data_equals_the_cvxpy_formulation(name, motion):
    model = truth_model(name)
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=10, rate=200, seed=3, noise=0.5, **motion))
    theta = SDP().fit(problem).standard_
    reference, tol = cvxpy_sdp(problem)
    # the same problem, the same solver: they differ by how it was built (measured: ≤ 0.003 of tol)
    assert np.linalg.norm(theta - reference) <= tol * np.linalg.norm(reference)


def test_sdp_infeasible_mass_bounds_message():
    model = truth_model("exo_leg")
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=5, rate=100, seed=1))
    with pytest.raises(SolverError) as err:
        SDP(mass_bounds=(2.0, 1.0)).fit(problem)
    assert str(err.value) == (
        "sdp: solver CLARABEL says the constraints are infeasible (status 'infeasible'); check the mass bounds"
    )


def test_consistent_completion_of_true_base_parameters():
    model = truth_model("ur5")
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=5, rate=100, seed=1))
    _, truth = true_base(model)
    theta, status = consistent_completion(problem, truth)
    assert status == "optimal"
    np.testing.assert_allclose(problem.base.P @ theta, truth, rtol=1e-6, atol=1e-9 * np.abs(truth).max())
    # the nominal θ reproduces them and is consistent: the closest consistent θ is the nominal one
    np.testing.assert_allclose(theta, problem.nominal, atol=1e-6 * np.abs(problem.nominal).max())


def test_identify_with_sdp_does_not_import_cvxpy(tmp_path):
    model = truth_model("exo_leg")
    from pinid.data.formats import write_recording

    write_recording(tmp_path / "t.csv", twin(model, seconds=5, rate=200, seed=1))
    code = f"""
import sys
import pinid
result = pinid.identify(pinid.Study("exo_leg", {str(tmp_path / "t.csv")!r}), methods=["ols", "sdp"])
print(result["sdp"].status, result["ols"].standard_source.replace(" ", "_"), "cvxpy" in sys.modules)
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    # OLS's standard parameters come from the consistent completion (also a conic problem)
    assert proc.stdout.split() == ["optimal", "consistent_completion", "False"], proc.stdout
