"""The kinematic limits at each signal's peaks: the exact slack of the whole period, its gradient, the slots,
and designs that use them stay inside every limit at every instant."""

from __future__ import annotations

import numpy as np
import pytest

from pinid import RobotModel
from pinid.excitation.design import MultistartOptions, design_excitation
from pinid.excitation.peaks import PeakConstraints
from pinid.excitation.problem import DesignProblem
from pinid.excitation.spec import spec_for

# a small, fast configuration of the default optimiser (as in test_excitation.py)
FAST = {"starts": 2, "screen": 2, "polish": 1, "maxiter": 40, "polish_maxiter": 60}


def assert_inside(tr, spec, tol: float = 1e-9):
    """Every limit at every instant: on 50 000 points of the period."""
    q, dq, ddq = tr.evaluate(np.linspace(0, tr.period, 50_000))
    assert np.all(q.min(0) >= spec.lower - tol) and np.all(q.max(0) <= spec.upper + tol)
    assert np.all(np.abs(dq).max(0) <= spec.velocity + tol)
    assert np.all(np.abs(ddq).max(0) <= spec.acceleration + tol)


def candidates(problem: DesignProblem, count: int, seed: int) -> np.ndarray:
    lower, upper = problem.box()
    rng = np.random.default_rng(seed)
    return problem.scale_into_limits(lower + rng.random((count, problem.d)) * (upper - lower))


@pytest.mark.parametrize("offsets", [False, True])
def test_the_slack_at_the_peaks_is_the_smallest_slack_of_the_whole_period(exo, offsets):
    spec = spec_for(exo).replace(optimize_offsets=offsets)
    problem = DesignProblem(exo, spec)
    A, b = problem.linear_constraints()
    dense = DesignProblem(exo, spec, check_samples=40_000)
    Ad, bd = dense.linear_constraints()
    for x in candidates(problem, 5, 1) * 1.3:  # some beyond their limits: negative slack
        peaks = PeakConstraints(problem, A, b)
        g = peaks.fun(x).reshape(-1, problem.N)  # (6·nv blocks, harmonics)
        at_peaks = np.where(np.isnan(peaks.slots), np.inf, g).min(axis=1)  # empty slots aside
        exact = (bd - Ad @ x).reshape(len(g), -1).min(axis=1)
        np.testing.assert_allclose(at_peaks, exact, atol=1e-6)
        # the grid's slack is never smaller than the peaks' (the peaks lie between grid points)
        assert np.all((b - A @ x).reshape(len(g), -1).min(axis=1) >= at_peaks - 1e-12)


def test_the_jacobian_is_the_derivative_of_the_slack():
    ur5 = RobotModel.from_urdf("ur5")
    problem = DesignProblem(ur5, spec_for(ur5))
    A, b = problem.linear_constraints()
    x = candidates(problem, 1, 2)[0]
    peaks = PeakConstraints(problem, A, b)
    g, J = peaks.fun(x), peaks.jac(x)
    assert J.shape == (6 * ur5.nv * problem.N, problem.d)
    rng = np.random.default_rng(3)
    for _ in range(3):
        e = rng.standard_normal(problem.d) * 1e-6
        moved = PeakConstraints(problem, A, b)
        moved.slots = peaks.slots.copy()  # the same peaks in the same slots
        # at a peak s'(t*) = 0: the row at t* is the gradient, to second order in the step
        np.testing.assert_allclose(moved.fun(x + e) - g, J @ e, rtol=1e-4, atol=1e-9)
        np.testing.assert_allclose(moved.fun(x - e) - g, -J @ e, rtol=1e-4, atol=1e-9)


def test_a_peak_keeps_its_slot_and_a_missing_one_leaves_a_row_of_zeros(exo):
    problem = DesignProblem(exo, spec_for(exo))
    A, b = problem.linear_constraints()
    x = candidates(problem, 1, 4)[0]
    peaks = PeakConstraints(problem, A, b)
    peaks.fun(x)
    before = peaks.slots.copy()
    y = x + 1e-4 * np.random.default_rng(5).standard_normal(problem.d)
    peaks.fun(y)
    found = ~np.isnan(before)
    np.testing.assert_array_equal(np.isnan(peaks.slots), ~found)
    assert np.nanmax(np.abs(peaks.slots - before)) < 0.01 * problem.spec.period
    # a joint at rest has no peak but keeps one row per signal (its offset may be a variable); the other
    # slots are empty: rows of zeros, satisfied whatever x
    Z, q0 = problem.split(x[None])
    Z[0, 1] = 0.0
    rest = problem.join(Z, q0)[0]
    fresh = PeakConstraints(problem, A, b)
    g, J = fresh.fun(rest).reshape(12, -1), fresh.jac(rest).reshape(12, problem.N, -1)
    blocks = np.arange(6, 12)  # the second joint's six signals
    assert np.all(np.isnan(fresh.slots[blocks, 1:])) and not J[blocks, 1:].any()
    np.testing.assert_allclose(g[blocks, 0], b.reshape(12, -1)[blocks, 0])  # its bound: q − q0 = dq = ddq = 0
    np.testing.assert_array_equal(g[blocks, 1:], np.abs(b.reshape(12, -1)[blocks, :1]) + 1 + 0 * g[blocks, 1:])


def test_the_limits_mode_is_checked_and_resolved_by_size():
    assert MultistartOptions().resolved(2).limits == "grid"
    assert MultistartOptions().resolved(6).limits == "peaks"
    assert MultistartOptions(limits="grid").resolved(6).limits == "grid"


def test_an_unknown_limits_mode_is_one_line(exo):
    from pinid.errors import SpecError

    with pytest.raises(SpecError, match="limits 'dense', expected 'grid' or 'peaks'"):
        design_excitation(exo, optimizer="slsqp", options={**FAST, "limits": "dense"})


@pytest.mark.slow
@pytest.mark.parametrize("offsets", [False, True])
def test_a_design_at_the_peaks_meets_every_limit_at_every_instant(exo, offsets):
    spec = spec_for(exo).replace(optimize_offsets=offsets)
    grid = design_excitation(exo, spec, options={**FAST, "limits": "grid"}, seed=1)
    res = design_excitation(exo, spec, options={**FAST, "limits": "peaks"}, seed=1)
    assert res.optimizer_options["limits"] == "peaks" and res.feasible
    assert_inside(res.trajectory, spec)
    # the same problem: within the spread of local minima of the grid's design
    assert res.condition_number < 1.2 * grid.condition_number


@pytest.mark.slow
def test_an_arms_default_design_uses_the_peaks_and_meets_every_limit():
    ur5 = RobotModel.from_urdf("ur5")
    spec = spec_for(ur5)
    res = design_excitation(ur5, spec, options={**FAST, "maxiter": 20, "polish_maxiter": 20}, seed=0)
    assert res.optimizer_options["limits"] == "peaks" and res.feasible
    assert_inside(res.trajectory, spec)
