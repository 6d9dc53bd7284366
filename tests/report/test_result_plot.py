"""Result objects draw themselves: ``result.plot(...)`` returns a matplotlib Figure drawn by pinid.report
(identification, comparison, output-error fit, tracking), on small ground-truth runs."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from pinid.control.controllers import ComputedTorque, Tracking, nominal_model, track  # noqa: E402
from pinid.identification.study import Study
from pinid.errors import SpecError  # noqa: E402
from pinid.excitation.design import design_excitation  # noqa: E402
from pinid.excitation.spec import spec_for  # noqa: E402
from pinid.excitation.trajectory import FourierTrajectory  # noqa: E402
from pinid.flexible.output_error import fit_output_error, make_twin, problem_from_spec
from pinid.flexible.spec import load_flex_spec
from pinid.identification.compare import compare  # noqa: E402
from pinid import Identification  # noqa: E402
from pinid.identification.result import IdentificationResult  # noqa: E402

from test_identification import true_base  # noqa: E402


def titles(fig: Figure) -> list[str]:
    """The titles of the visible axes, in order."""
    return [ax.get_title() for ax in fig.axes if ax.get_visible()]


def visible(fig: Figure) -> int:
    return sum(ax.get_visible() for ax in fig.axes)


#: The exo leg's twins and their identification are conftest's leg_twins and leg_identification.
pytestmark = pytest.mark.usefixtures("close_figures")


def test_identification_result_plots_its_error_bars(leg_identification):
    r = leg_identification["ols"]
    fig = r.plot()
    assert isinstance(fig, Figure)
    # one panel per joint and one pooling them (a 2-joint leg: hip, knee, all joints)
    assert titles(fig) == ["hip", "knee", "all joints"]
    assert fig.get_suptitle().startswith("ols: absolute torque error (validation)")
    assert r.plot("train").get_suptitle().startswith("ols: absolute torque error (training)")
    with pytest.raises(SpecError, match="kind"):
        r.plot("test")


def test_identification_plots_the_report_figures(leg_identification):
    errors = leg_identification.plot()
    assert titles(errors) == ["hip", "knee", "all joints"]
    assert {t.get_text() for t in errors.axes[0].get_yticklabels()} == {"ols", "sdp"}  # a row per method
    torque = leg_identification.plot("torque:sdp")
    # per joint a torque panel and the error under it
    assert visible(torque) == 4 and torque.get_suptitle().startswith("sdp: measured and predicted torque")
    best = leg_identification.plot("torque")  # the best method's, by default
    assert best.get_suptitle().startswith(f"{leg_identification.best}: measured and predicted torque")
    motion = leg_identification.plot("motion")
    assert titles(motion) == ["hip", "knee", "", ""] and visible(motion) == 4
    params = leg_identification.plot("parameters")  # the best method's and ols's base parameters ± 2σ
    names = [t.get_text() for t in params.axes[0].get_yticklabels()]
    assert names == leg_identification.base["names"] and params.get_suptitle().startswith("base parameters")
    overlay = leg_identification.plot("predictions")  # every method's prediction, its difference to the best's
    assert visible(overlay) == 4 and {t.get_text() for t in overlay.legends[0].get_texts()} >= {"ols", "sdp"}
    with pytest.raises(SpecError, match="method"):
        leg_identification.plot("torque:pso")
    with pytest.raises(SpecError, match="kind"):
        leg_identification.plot("bars")


def test_a_loaded_identification_plots_without_curves(leg_identification, tmp_path):
    back = Identification.load(leg_identification.save(tmp_path / "identification.json"))
    assert titles(back.plot()) == ["hip", "knee", "all joints"]
    assert titles(IdentificationResult.from_dict(back["ols"].to_dict()).plot()) == ["hip", "knee", "all joints"]
    with pytest.raises(SpecError, match="torque curves"):
        back.plot("torque")
    assert [t.get_text() for t in back.plot("parameters").axes[0].get_yticklabels()] == back.base["names"]


def test_comparison_plots_its_three_figures(leg_twins):
    truth, train, valid = leg_twins
    _, xt = true_base(truth)
    comparison = compare(
        Study(truth, train, valid),
        methods=["ols", "pso"],
        seeds=2,
        truth=xt,
        metaheuristic={"population": 10, "iterations": 5},
    )
    errors = comparison.plot()
    assert isinstance(errors, Figure) and titles(errors) == ["hip", "knee", "all joints"]
    conv = comparison.plot("convergence")
    assert titles(conv) == ["convergence"] and conv.axes[0].get_yscale() == "log"
    params = comparison.plot("parameters")
    assert titles(params) == ["error against the true parameters"]
    assert [t.get_text() for t in params.axes[0].get_xticklabels()]  # one bar group per base parameter
    with pytest.raises(SpecError, match="validation set"):
        comparison.plot("errors:nope")
    with pytest.raises(SpecError, match="convergence:first"):
        comparison.plot("convergence:second")


def test_output_error_result_plots_cost_and_parameter_errors():
    spec = load_flex_spec(Path(__file__).resolve().parents[2] / "excitation" / "tracker_flex_spec.toml")
    s = replace(spec, input=replace(spec.input, duration=0.3))
    problem = problem_from_spec(s, make_twin(s.model(), s.input, noise=0.0), cost="sq")
    xt = np.array([problem.truth[n] for n in problem.free])
    res = fit_output_error(problem, "least_squares", x0=xt * 1.05, max_nfev=3)
    cost = res.plot()
    assert titles(cost) == [f"output-error fit (least_squares, {res.model_kind} model, {res.cost_kind} cost)"]
    assert cost.axes[0].get_xscale() == "log" and len(cost.axes[0].get_lines()) == 1
    errors = res.plot("errors")
    assert [t.get_text() for t in errors.axes[0].get_xticklabels()] == list(res.rel_error)
    with pytest.raises(SpecError, match="kind"):
        res.plot("angles")


def test_tracking_result_plots_position_error_torque(exo):
    ref = FourierTrajectory(["hip", "knee"], 0.5 * np.pi, [0.61, -0.87], [[0.5], [0.5]], [[0.0], [0.0]])
    r = track(exo, ComputedTorque(nominal_model(exo)), ref, Tracking(0.5))
    fig = r.plot()
    assert isinstance(fig, Figure) and visible(fig) == 3 * exo.nv  # rows q, error, torque; a column per joint
    assert titles(fig)[: exo.nv] == ["hip", "knee"]
    assert [t.get_text() for t in fig.axes[0].get_legend().get_texts()] == ["reference", "tracked"]


def test_excitation_result_plots_q_dq_ddq_within_the_limits(exo):
    spec = spec_for(exo)
    res = design_excitation(exo, spec, optimizer="pso", options={"population": 8, "iterations": 2}, seed=0)
    fig = res.plot()
    assert isinstance(fig, Figure)
    assert visible(fig) == 3 * exo.nv  # rows q, dq, ddq; a column per joint
    assert titles(fig)[: exo.nv] == exo.joint_names
    assert fig.get_suptitle() == f"2-joint excitation, condition number {res.condition_number:.4g}"
