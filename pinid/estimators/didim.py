"""DIDIM (Gautier, Janot & Vandanjon 2013): output error on the torque of a closed-loop simulation, by Gauss–Newton.

The direct and inverse dynamic identification model minimises the error between the measured torque and
the torque of a *closed-loop simulation* of the model, ``‖τ_m − τ_s(β)‖²``, started from OLS (from the
``sdp`` estimate when the OLS one cannot be simulated, as for :mod:`~pinid.estimators.iv`).  Gautier's
observation makes each Gauss–Newton step a least-squares problem: in closed loop the simulated torque is
``τ_s(β) = W(q_s, dq_s, ddq_s)·β`` (inverse dynamics on the simulated states), and the sensitivity of the
simulated states to ``β`` is small when the loop is stiff, so the Jacobian is ``W(q_s, dq_s, ddq_s)`` and::

    β_{k+1} = argmin_β ‖τ_m − W(q_s(β_k), dq_s(β_k), ddq_s(β_k))·β‖²

— the inverse model's least squares with the *simulated* (noise-free) regressor in place of the measured
one.  The step is halved (up to 3 times) when it raises the simulated output error; the iterations stop
when the base parameters change less than ``tol`` relatively, or when no step lowers the error (status
says so).

The closed loop is the one of :class:`~pinid.estimators.iv.ModelSimulation` (pinid has no controller or
reference trajectory in a problem): the model under the measured torque, kept on the measured positions by
a PD of ``bandwidth`` [Hz], so ``τ_s = τ_m + K_p·(q_m − q_s) + K_d·(dq_m − dq_s)`` and the output error is
the PD's correction — how hard the loop has to pull the model to follow the recording.  ``history_``: the
RMS of that error [N·m] per iteration (its cost).

On noise-free data the truth is a fixed point only up to the simulation's error (the measured torque is
interpolated by cubic splines between samples; a Coulomb jump of the torque falls inside a sample
interval and is smeared): DIDIM is *not* exact there.  Measured on the exo leg at 100 Hz: 1e-4
relatively without Coulomb friction, about 1e-2 with it (tests/estimators/test_real_data_estimators.py).

``physical=True``: each step is LMI-constrained least squares (:class:`~pinid.estimators.sdp.SDP`)
on the simulated regressor, so the result is physically consistent.
"""

from __future__ import annotations

import numpy as np

from pinid.errors import SolverError
from pinid.estimators.iv import ModelSimulation, SimulatingEstimator, physical_fit, simulated_start
from pinid.problem.problem import Problem
from pinid.linalg import weighted_lstsq


class DIDIM(SimulatingEstimator):
    """DIDIM: Gauss–Newton on the torque output error of a closed-loop simulation, from OLS (module text).

    Settings: ``iterations`` (at most, default 10), ``tol`` (relative change of the parameters that
    stops it, default 1e-6), ``bandwidth`` [Hz] of the simulation's PD (default 2), ``substeps``
    (Runge–Kutta steps per integrated interval, default 1), ``sim_rate`` (integrate at most at this rate
    [Hz], default 250; :mod:`~pinid.estimators.iv`), ``physical`` (LMI-constrained steps, default False).
    """

    name = "didim"
    summary = (
        "DIDIM (Gautier, Janot & Vandanjon 2013): Gauss–Newton on the torque output error of a closed-loop "
        "simulation, Jacobian = the simulated regressor, from OLS"
    )
    assumptions = "as `iv`; the truth is a fixed point only up to the simulation's error (not exact on noise-free data)"
    settings_summary = "as `iv`"
    description = "DIDIM: Gauss–Newton on the torque error of a closed-loop simulation, from OLS"
    colour = "#ff00ff"
    exact = False  # noise-free: limited by the simulation between samples (module text)

    def fit(self, problem: Problem) -> "DIDIM":
        """OLS, then Gauss–Newton steps on the simulated regressor; sets ``base_`` and ``history_`` (RMS output error)."""
        sim = ModelSimulation(problem, self.bandwidth, self.substeps, self.sim_rate)
        x, Z, start = simulated_start(problem, sim, "didim")
        tau, w = problem.tau, problem.weights
        standard = None

        def evaluate(b):
            Z = sim.instruments(b)
            err = tau - Z @ b
            return Z, float(np.sqrt(np.sum(w * err * err) / max(np.sum(w), 1e-300)))

        err = tau - Z @ x
        cost = float(np.sqrt(np.sum(w * err * err) / max(np.sum(w), 1e-300)))
        history, status, change = [cost], "ok", float("inf")
        for _ in range(int(self.iterations)):
            if self.physical:
                target, standard_new = physical_fit(problem, Z)
            else:
                target, standard_new = weighted_lstsq(Z, tau, w), None
            step = target - x
            cost_try = float("inf")
            for _half in range(4):
                x_try = x + step
                try:
                    Z_try, cost_try = evaluate(x_try)
                except SolverError:
                    cost_try = float("inf")
                if cost_try <= cost * (1 + 1e-12):
                    break
                step = 0.5 * step
                standard_new = None
            if not cost_try <= cost * (1 + 1e-12):
                status = "stopped: no step lowers the simulated output error"
                break
            change = float(np.linalg.norm(x_try - x) / max(np.linalg.norm(x_try), 1e-300))
            x, Z, cost = x_try, Z_try, cost_try
            standard = standard_new if self.physical else None
            history.append(cost)
            if change < self.tol:
                break
        if self.physical and standard is None:  # a halved step is not the constrained solution: constrain it
            x, standard = physical_fit(problem, Z)
        self.base_ = x
        self.standard_ = standard
        self.weights_ = None
        self.history_ = history
        self.status_ = status if status != "ok" or change < self.tol else f"not settled after {len(history) - 1} steps"
        self.info_ = {"iterations": len(history) - 1, "last_change": change, "output_error_rms": cost, "start": start}
        return self
