"""Excitation design: specs and their errors, limits at every instant, rest start, seed 001 Table 3, the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pinid import TermSelection, RobotModel, regressor
from pinid.model.base import base_parameters
from pinid.errors import SpecError
from pinid.excitation.design import design_excitation
from pinid.excitation.evaluation import condition_number, evaluate_trajectory, limit_violations, trajectory_extremes
from pinid.excitation.problem import DesignProblem
from pinid.excitation.spec import ExcitationSpec, bundled_spec_path, default_spec, load_spec, spec_for
from pinid.excitation.trajectory import FourierTrajectory

from conftest import assert_clean_error, load, run_cli

ROOT = Path(__file__).resolve().parents[2]
TABLE3 = ROOT / "excitation" / "seed001_table3.json"
TABLE2 = (ROOT / "excitation" / "exo_leg_table2.toml").resolve()  # the top-level folder links to pinid/resources
A_DEG = [[1.685, -2.258, 13.828, -15.389], [3.530, -9.949, -15.978, 5.415]]
B_DEG = [[5.689, 2.904, 14.805, 10.822], [5.205, 4.578, 15.914, 11.738]]
# a small, fast configuration of the default optimiser for tests
FAST = {"starts": 2, "screen": 2, "polish": 1, "maxiter": 40, "polish_maxiter": 60}
KEYS = [
    "condition_number",
    "criterion",
    "harmonics",
    "base_frequency",
    "q0",
    "a",
    "b",
    "joints",
    "limits",
    "extremes",
    "feasible",
    "optimizer",
    "seconds",
]


def dense_extremes(tr: FourierTrajectory, n: int = 50_000):
    q, dq, ddq = tr.evaluate(np.linspace(0, tr.period, n))
    return q.min(0), q.max(0), np.abs(dq).max(0), np.abs(ddq).max(0)


def assert_inside(tr: FourierTrajectory, spec: ExcitationSpec, tol: float = 1e-9):
    qmin, qmax, v, a = dense_extremes(tr)
    assert np.all(qmin >= spec.lower - tol), (qmin, spec.lower)
    assert np.all(qmax <= spec.upper + tol), (qmax, spec.upper)
    assert np.all(v <= spec.velocity + tol), (v, spec.velocity)
    assert np.all(a <= spec.acceleration + tol), (a, spec.acceleration)


# ---------------------------------------------------------------------------------------- seed 001 Table 3
def test_table3_read_as_published_stays_inside_table2():
    tr = FourierTrajectory.from_eq19(["hip", "knee"], 0.2 * np.pi, [0.6107, -0.8727], A_DEG, B_DEG)
    qmin, qmax, v, a = dense_extremes(tr, 200_001)
    # the figures of ../shared/README.md, to the digits printed there
    np.testing.assert_allclose(qmin, [-0.087, -1.558], atol=5e-4)
    np.testing.assert_allclose(qmax, [1.222, -0.175], atol=5e-4)
    np.testing.assert_allclose(v, [1.42, 1.41], atol=5e-3)
    np.testing.assert_allclose(a, [3.21, 3.02], atol=6e-3)  # 3.2047 is printed there as "≤ 3.21"
    np.testing.assert_array_less(a, 5.168)
    np.testing.assert_array_less(v, 1.645)
    # read as radians it would be wildly outside Table 2
    wrong = FourierTrajectory.from_eq19(["hip", "knee"], 0.2 * np.pi, [0.6107, -0.8727], A_DEG, B_DEG, unit="rad")
    assert dense_extremes(wrong)[2].max() > 50


def test_shipped_table3_file_is_the_published_trajectory_in_radians():
    shipped = FourierTrajectory.load(TABLE3)
    tr = FourierTrajectory.from_eq19(["hip", "knee"], 0.2 * np.pi, [0.6107, -0.8727], A_DEG, B_DEG)
    assert shipped.joints == ["hip", "knee"] and shipped.harmonics == 4
    assert shipped.base_frequency == pytest.approx(0.2 * np.pi)
    np.testing.assert_allclose(shipped.q0, [0.6107, -0.8727])
    np.testing.assert_allclose(shipped.a, tr.a, rtol=1e-15)
    np.testing.assert_allclose(shipped.b, tr.b, rtol=1e-15)
    assert shipped.meta["published"]["a_deg"] == A_DEG


def test_table3_only_overshoots_table2_by_rounding(exo):
    spec = spec_for(exo)
    ev = evaluate_trajectory(exo, FourierTrajectory.load(TABLE3), spec)
    assert ev["condition_number"] == pytest.approx(43.68, abs=0.01)
    # the printed coefficients reach −0.08742 rad at the hip: 0.4 mrad beyond −0.087
    assert limit_violations(ev["extremes"], spec) == ["hip: q_min -0.0874194 < -0.087 by 0.00042 rad"]
    assert limit_violations(ev["extremes"], spec, tol=1e-3) == []


# ---------------------------------------------------------------------------------------- specs
def test_bundled_spec_is_table2_and_used_by_default(exo):
    assert bundled_spec_path(exo) == TABLE2
    spec = spec_for(exo)
    assert Path(spec.source).resolve() == TABLE2.resolve()
    np.testing.assert_allclose(spec.q_min, [-0.087, -1.658])
    np.testing.assert_allclose(spec.q_max, [1.309, -0.087])
    np.testing.assert_allclose(spec.dq_max, [1.645, 1.645])
    np.testing.assert_allclose(spec.ddq_max, [5.168, 5.168])
    np.testing.assert_allclose(spec.q0, [0.6107, -0.8727])
    assert (spec.harmonics, spec.samples, spec.rest_start, spec.optimize_offsets, spec.margin) == (
        4,
        200,
        True,
        False,
        0.0,
    )
    assert spec.base_frequency == pytest.approx(0.2 * np.pi) and spec.terms == TermSelection()
    assert spec_for(exo, rest_start=False, harmonics=None).rest_start is False


def test_bundled_spec_for_a_copy_only_when_unchanged(tmp_path):
    """An unchanged copy of exo_leg.urdf is the bundled robot (Table 2 spec); an edited copy has its own limits."""
    from pinid.resources import URDF_DIR

    text = (URDF_DIR / "exo_leg.urdf").read_text()
    (tmp_path / "same").mkdir()
    (tmp_path / "same" / "exo_leg.urdf").write_text(text)
    assert bundled_spec_path(RobotModel.from_urdf(tmp_path / "same" / "exo_leg.urdf")) == TABLE2
    (tmp_path / "edited").mkdir()
    (tmp_path / "edited" / "exo_leg.urdf").write_text(text.replace("<robot ", "<!-- edited -->\n<robot ", 1))
    assert bundled_spec_path(RobotModel.from_urdf(tmp_path / "edited" / "exo_leg.urdf")) is None


def test_default_spec_without_urdf_limits():
    model = load("double_pendulum")  # its URDF has no position or velocity limits
    spec = default_spec(model)
    np.testing.assert_allclose(spec.q_min, -np.pi)
    np.testing.assert_allclose(spec.q_max, np.pi)
    np.testing.assert_allclose(spec.dq_max, 2.0)
    np.testing.assert_allclose(spec.ddq_max, 5.0)
    assert bundled_spec_path(model) is None and spec_for(model).source.endswith("pinid defaults)")


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("harmonics = 'four'", "harmonics = 'four', expected a number"),
        ("colour = 3", "unknown setting(s) colour"),
        ("[joints.ankle]\nq_min = 0", "joint 'ankle' is not an active joint"),
        ("[joints.hip]\nspeed = 1", "joints.hip: unknown key(s) speed"),
        ("[joints.hip]\nq_max = 2.0", "joints.hip.q_max = 2 is outside the URDF's limit 1.309"),
        ("[joints.knee]\ndq_max = 3.0", "joints.knee.dq_max = 3 is outside the URDF's limit 1.645"),
        ("harmonics = [", "not valid TOML"),
    ],
)
def test_malformed_spec_files(tmp_path, exo, text, fragment):
    p = tmp_path / "spec.toml"
    p.write_text(text)
    with pytest.raises(SpecError) as info:
        load_spec(p, exo)
    assert fragment in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize(
    "changes, fragment",
    [
        ({"q0": [1.5, -0.8727]}, "joint 'hip': offset q0 = 1.5 is outside its range"),
        (
            {"q_min": [-0.087, -0.5], "q_max": [1.309, -0.5], "q0": [0.6107, -0.5]},
            "joint 'knee': position range [-0.5, -0.5] has no width",
        ),
        ({"ddq_max": [5.168, 1e-6]}, "joint 'knee': ddq_max 1e-06 allows at most 2.53e-06 rad of motion"),
        ({"ddq_max": [5.168, 0.0]}, "joint 'knee': ddq_max 0, expected a finite limit > 0"),
        ({"harmonics": 1}, "rest_start needs at least 2 harmonics"),
        ({"samples": 6}, "samples 6, expected an integer > 2·harmonics = 8"),
        ({"samples": 4, "harmonics": 1, "rest_start": False}, "4 × 2 joints = 8 rows < 10 base parameters"),
        ({"margin": 0.6}, "margin 0.6, expected a fraction in [0, 0.5)"),
        ({"criterion": "trace"}, "criterion 'trace', expected one of cond, logdet"),
    ],
)
def test_infeasible_limits_raise_clear_errors(exo, changes, fragment):
    spec = spec_for(exo).replace(**{k: np.asarray(v) if isinstance(v, list) else v for k, v in changes.items()})
    with pytest.raises(SpecError) as info:
        spec.validate(exo)
    assert fragment in str(info.value), str(info.value)
    assert "\n" not in str(info.value)


# ---------------------------------------------------------------------------------------- the design problem
@pytest.mark.parametrize("rest", [True, False])
def test_parametrisation_and_rest_start_hold_exactly(exo, rest):
    problem = DesignProblem(exo, spec_for(exo, rest_start=rest))
    rng = np.random.default_rng(0)
    lower, upper = problem.box()
    X = lower + rng.random((20, problem.d)) * (upper - lower)
    q, dq, ddq = problem.states(X)
    for x, qi, dqi, ddqi in zip(X, q, dq, ddq):
        tr = problem.trajectory(x)
        t = problem.times
        np.testing.assert_allclose(np.hstack(tr.evaluate(t)), np.hstack([qi, dqi, ddqi]), atol=1e-12)
        np.testing.assert_allclose(problem.variables(tr), x, atol=1e-12)
        assert tr.starts_at_rest(1e-12) == rest
    # limits by scaling: every candidate inside the limits on the check grid
    Xs = problem.scale_into_limits(X)
    q, dq, ddq = problem.states(Xs, problem.check_times)
    spec = problem.spec
    assert np.all(q >= spec.lower - 1e-12) and np.all(q <= spec.upper + 1e-12)
    assert np.all(np.abs(dq) <= spec.velocity + 1e-12) and np.all(np.abs(ddq) <= spec.acceleration + 1e-12)


def test_linear_constraints_are_the_limits_on_the_grid(exo):
    problem = DesignProblem(exo, spec_for(exo, rest_start=False, optimize_offsets=True), check_samples=64)
    A, b = problem.linear_constraints()
    rng = np.random.default_rng(1)
    lower, upper = problem.box()
    for x in lower + rng.random((10, problem.d)) * (upper - lower):
        q, dq, ddq = (v[0] for v in problem.states(x[None], problem.check_times))
        s = problem.spec
        expected = (
            np.all(q <= s.upper)
            & np.all(q >= s.lower)
            & np.all(np.abs(dq) <= s.velocity)
            & np.all(np.abs(ddq) <= s.acceleration)
        )
        assert expected == np.all(A @ x <= b)


def test_batch_criterion_is_the_condition_number_of_the_base_regressor(exo):
    spec = spec_for(exo)
    problem = DesignProblem(exo, spec)
    rng = np.random.default_rng(2)
    lower, upper = problem.box()
    X = problem.scale_into_limits(lower + rng.random((3, problem.d)) * (upper - lower))
    values = problem.evaluate(X)
    base = base_parameters(exo, spec.terms)
    for x, v in zip(X, values):
        tr = problem.trajectory(x)
        t = np.arange(200) * tr.period / 200
        q, dq, ddq = tr.evaluate(t)
        dq[0] = 0.0  # exact rest at t = 0
        W = base.columns(regressor(exo, q, dq, ddq, spec.terms))
        assert v == pytest.approx(np.linalg.cond(W), rel=1e-9)
        assert condition_number(exo, tr) == pytest.approx(v, rel=1e-9)


def test_extremes_are_exact(exo):
    tr = FourierTrajectory.load(TABLE3)
    ext = trajectory_extremes(tr, points=400)  # a coarse grid, refined by Newton steps
    qmin, qmax, v, a = dense_extremes(tr, 400_001)
    for j, name in enumerate(tr.joints):
        e = ext[name]
        assert e["q_min"] == pytest.approx(qmin[j], abs=1e-9) and e["q_max"] == pytest.approx(qmax[j], abs=1e-9)
        assert e["dq_abs_max"] == pytest.approx(v[j], abs=1e-9) and e["ddq_abs_max"] == pytest.approx(a[j], abs=1e-9)


# ---------------------------------------------------------------------------------------- designs
@pytest.mark.parametrize("rest", [True, False])
@pytest.mark.slow
def test_small_design_improves_on_table3_inside_the_limits(exo, rest):
    spec = spec_for(exo, rest_start=rest)
    res = design_excitation(exo, spec, options=FAST, seed=0)
    assert res.feasible
    assert_inside(res.trajectory, spec)
    assert res.trajectory.starts_at_rest(1e-12) == rest
    table3 = condition_number(exo, FourierTrajectory.load(TABLE3))
    assert res.condition_number < 0.85 * table3
    assert res.condition_number == pytest.approx(condition_number(exo, res.trajectory), rel=1e-12)
    again = design_excitation(exo, spec, options=FAST, seed=0)
    np.testing.assert_array_equal(again.trajectory.a, res.trajectory.a)


@pytest.mark.parametrize("name", ["pso", "ewoa"])
def test_metaheuristic_design_is_feasible(exo, name):
    spec = spec_for(exo).replace(samples=60)
    res = design_excitation(exo, spec, optimizer=name, options={"population": 12, "iterations": 6}, seed=3)
    assert res.feasible and res.optimizer == name
    assert_inside(res.trajectory, spec)
    assert res.trajectory.starts_at_rest(1e-12)
    assert len(res.history) == 7 and np.all(np.diff(res.history) <= 0)
    assert res.condition_number == pytest.approx(res.history[-1], rel=1e-2)


def test_offsets_margin_and_logdet(exo):
    spec = spec_for(exo, optimize_offsets=True, margin=0.1, criterion="logdet", samples=60)
    res = design_excitation(exo, spec, options=FAST, seed=1)
    assert res.feasible and res.criterion == "logdet"
    assert_inside(res.trajectory, spec)
    assert not np.allclose(res.trajectory.q0, spec.q0)
    d = res.to_dict()
    assert d["criterion"] == "logdet" and d["margin"] == 0.1 and np.isfinite(d["log_det"])


def test_torque_limits_hold(exo):
    spec = spec_for(exo).replace(samples=60, tau_max=np.array([22.0, np.inf]))
    res = design_excitation(exo, spec, optimizer="pso", options={"population": 16, "iterations": 8}, seed=0)
    assert res.feasible
    assert res.tau_abs_max[0] <= 22.0 * (1 + 1e-6)
    assert res.extremes["hip"]["tau_abs_max"] == pytest.approx(res.tau_abs_max[0])
    assert "tau" in res.usage["hip"] and "tau" not in res.usage["knee"]


def test_csv_export(tmp_path):
    tr = FourierTrajectory.load(TABLE3)
    path = tr.to_csv(tmp_path / "t.csv", rate=100.0)
    lines = path.read_text().splitlines()
    assert lines[0] == "t,q_hip,q_knee,dq_hip,dq_knee,ddq_hip,ddq_knee"
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    assert data.shape == (1000, 7)
    np.testing.assert_allclose(data[:, 1:], np.hstack(tr.evaluate(data[:, 0])), atol=1e-9)
    with pytest.raises(SpecError, match="rate"):
        tr.to_csv(tmp_path / "u.csv", rate=0)


# ---------------------------------------------------------------------------------------- the command
@pytest.mark.slow
def test_cli_writes_json_csv_and_plot(tmp_path):
    out, csv, png = tmp_path / "exo.json", tmp_path / "exo.csv", tmp_path / "exo.png"
    proc = run_cli(
        "excite",
        "--urdf",
        str(ROOT / "urdf" / "exo_leg.urdf"),
        "-o",
        str(out),
        "--csv",
        str(csv),
        "--plot",
        str(png),
        "--rate",
        "50",
        "--starts",
        "2",
        "--option",
        "screen=2",
        "--option",
        "polish=1",
        "--option",
        "polish_maxiter=40",
    )
    assert proc.returncode == 0, proc.stderr
    assert "condition number" in proc.stdout and "hip" in proc.stdout and "|ddq| max" in proc.stdout
    wide = [line for line in proc.stdout.splitlines() if len(line) > 120 and str(ROOT) not in line]
    assert not wide, wide  # fits 120 columns (a line naming a long path aside)
    d = json.loads(out.read_text())
    for key in KEYS:
        assert key in d, key
    assert d["optimizer"] == "slsqp" and d["feasible"] is True and d["criterion"] == "cond"
    assert set(d["extremes"]["hip"]) >= {"q_min", "q_max", "dq_abs_max", "ddq_abs_max"}
    assert d["limits"]["knee"]["ddq_max"] == 5.168
    tr = FourierTrajectory.load(out)
    assert tr.starts_at_rest(1e-12)
    assert len(csv.read_text().splitlines()) == 501 and png.stat().st_size > 10_000
    proc = run_cli("excite", "--urdf", "exo_leg", "--evaluate", str(out))
    assert proc.returncode == 0 and f"condition number {d['condition_number']:.6g}" in proc.stdout


@pytest.mark.parametrize(
    "spec_text, fragment",
    [
        ("[q0]\nhip = 1.5", "offset q0 = 1.5 is outside its range"),
        ("[joints.knee]\nq_min = -0.5\nq_max = -0.5\n", "position range [-0.5, -0.5] has no width"),
        ("[joints.knee]\nddq_max = 0.00001", "ddq_max 1e-05 allows at most"),
    ],
)
def test_cli_infeasible_spec_is_one_line_and_writes_nothing(tmp_path, spec_text, fragment):
    spec = tmp_path / "bad.toml"
    spec.write_text(spec_text)
    out = tmp_path / "out.json"
    proc = run_cli("excite", "--urdf", "exo_leg", "--spec", str(spec), "-o", str(out))
    assert_clean_error(proc, "pinid excite: error:", str(spec), fragment)
    assert not out.exists() and list(tmp_path.iterdir()) == [spec]


def test_cli_bad_options(tmp_path):
    out = tmp_path / "o.json"
    assert_clean_error(run_cli("excite", "--optimizer", "gradient", "-o", str(out)), "--optimizer 'gradient'")
    assert_clean_error(
        run_cli("excite", "--optimizer", "pso", "--option", "swarm=3", "-o", str(out)), "unknown option(s) swarm"
    )
    assert_clean_error(run_cli("excite", "--starts", "3", "--population", "10", "-o", str(out)), "--population")
    assert not out.exists()


@pytest.mark.parametrize("robot, terms", [("exo_leg", "fc,fv"), ("ur5", "fc,fv,armature,offset")])
def test_exact_gradient_and_torque_jacobian_match_central_differences(robot, terms):
    """The cond gradient (RNEA derivatives of a model per singular vector) and the torque Jacobian are exact."""
    model = RobotModel.from_urdf(robot)
    spec = spec_for(model).replace(
        samples=max(20, 30 // model.nv * 2), terms=TermSelection.from_names(terms), tau_max=np.full(model.nv, 1e3)
    )
    problem = DesignProblem(model, spec)
    lower, upper = problem.box()
    x = problem.scale_into_limits(lower + np.random.default_rng(3).random(problem.d) * (upper - lower))[0]
    f, grad, tau, tau_jac = problem.objective_and_gradient(x, torque=True)
    h, fd, jac = 1e-6, np.zeros_like(grad), np.zeros_like(tau_jac)
    for i in range(len(x)):
        e = np.zeros_like(x)
        e[i] = h
        (cp,), tp = problem.evaluate(x + e, torque=True)
        (cm,), tm = problem.evaluate(x - e, torque=True)
        fd[i] = (np.log(cp) - np.log(cm)) / (2 * h)
        jac[:, i] = (tp - tm).reshape(-1) / (2 * h)
    assert f == pytest.approx(np.log(problem.evaluate(x)[0]), rel=1e-12)
    assert np.abs(grad - fd).max() <= 1e-6 * np.abs(fd).max()
    assert np.abs(tau_jac - jac).max() <= 1e-6 * np.abs(jac).max()


def test_progress_labels_search_and_polished_values(monkeypatch):
    """The multistart's progress: phase 1's best is labelled as on the search grid (it is not the design's
    criterion), the polished best is the condition number the result reports (issue 24: "best 36.4448" at
    12/13, then 36.5202 reported, on the UR5)."""
    import pinid.excitation.design as design

    posted = []

    class Recorder:
        def __init__(self, *args, **kwargs):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def update(self, n=1):
            pass

        def set_postfix_str(self, s="", refresh=True):
            posted.append(s)

    monkeypatch.setattr(design, "progress_bar", Recorder)
    leg = RobotModel.from_urdf("exo_leg")
    opts = {"starts": 3, "polish": 1, "maxiter": 15, "polish_maxiter": 30}
    result = design.design_excitation(leg, options=opts, seed=0)
    search, polished = posted[:-1], posted[-1:]  # one search line per batch of starts
    assert search and all(s.startswith("search best ") and "samples/period)" in s for s in search), posted
    assert polished == [f"polished best {result.condition_number:.6g}"], (posted, result.condition_number)


def test_polishing_never_returns_a_worse_design_than_its_start(monkeypatch):
    """Issue 35: "search best 33.3717" then "polished best 33.531".  Whatever the polish returns, the
    design is no worse, on the full problem, than the start it polished (both within the limits)."""
    import pinid.excitation.design as design

    real, starts = design._local_search, []

    def bad_polish(problem, x, maxiter, ftol, stop=None, peaks=False):
        if maxiter != FAST["polish_maxiter"]:  # phase 1: the real search
            return real(problem, x, maxiter, ftol, stop, peaks)
        starts.append(x.copy())
        worse = problem.scale_into_limits((0.05 * x)[None, :])  # 5 % of the motion: far worse conditioned
        return worse[0], float(problem.evaluate(worse)[0]), 1

    monkeypatch.setattr(design, "_local_search", bad_polish)
    leg = RobotModel.from_urdf("exo_leg")
    result = design.design_excitation(leg, options={**FAST, "polish": 2, "workers": 1}, seed=0)
    problem = DesignProblem(leg, result.spec)
    start_values = [problem.evaluate(design._final_repair(problem, x)[0][None, :])[0] for x in starts]
    assert len(starts) == 2 and result.condition_number <= min(start_values) * (1 + 1e-9), (
        result.condition_number,
        start_values,
    )
    assert result.details["polished_values"] == pytest.approx(start_values, rel=1e-9)


@pytest.mark.slow  # 12 s of CPU (docs/benchmarks.md, Test suite)
def test_early_stop_and_workers_keep_the_design_deterministic():
    """Starts stopped early against the best of the batches before them, and the starts shared among worker
    processes: the same seed gives the same design whatever the number of workers."""
    leg = RobotModel.from_urdf("exo_leg")
    opts = {"starts": 16, "screen": 2, "polish": 2, "maxiter": 40, "polish_maxiter": 40}
    one = design_excitation(leg, options={**opts, "workers": 1}, seed=2)
    two = design_excitation(leg, options={**opts, "workers": 2}, seed=2)
    assert one.details["starts_stopped_early"] > 0, one.details
    assert one.condition_number == two.condition_number
    assert np.array_equal(one.trajectory.a, two.trajectory.a) and np.array_equal(one.trajectory.b, two.trajectory.b)
    assert one.nfev == two.nfev and one.details["regressor_samples"] == two.details["regressor_samples"]


def test_gram_singular_values_match_the_svd_and_fall_back_when_ill_conditioned():
    """Issue 35: the criterion from the Gram matrix's eigenvalues is the SVD's to round-off below GRAM_COND;
    above it the SVD itself is used (squaring the condition number would lose the smallest value)."""
    from pinid.excitation.problem import GRAM_COLUMNS, GRAM_COND, _extreme_pairs, _singular_values

    rng = np.random.default_rng(0)
    n = GRAM_COLUMNS + 4
    U, _ = np.linalg.qr(rng.standard_normal((6 * n, n)))
    V, _ = np.linalg.qr(rng.standard_normal((n, n)))
    for cond in (3.0, 40.0, 0.5 * GRAM_COND, 1e8):
        s = np.geomspace(cond, 1.0, n)
        W = (U * s) @ V.T
        sv = _singular_values(W[None])[0]
        exact = np.linalg.svd(W, compute_uv=False)
        assert sv == pytest.approx(exact, rel=1e-13 * cond**2 + 1e-12), cond
        (u_max, v_max, s_max), (u_min, v_min, s_min) = _extreme_pairs(W, sv)
        assert s_max / s_min == pytest.approx(cond, rel=1e-13 * cond**2 + 1e-12)
        for u, v, sigma in ((u_max, v_max, s_max), (u_min, v_min, s_min)):
            assert np.abs(np.outer(u, v) * sigma - np.outer(W @ v, v)).max() <= 1e-12 * cond


def test_a_polish_on_a_coarser_grid_still_meets_the_limits_on_the_full_grid(exo):
    """Issue 35: the polish's constraints on a coarser grid (polish_grid) — the design is still scaled inside
    the limits at every instant (dense grid, exact extremes) and on the default 2·samples grid."""
    result = design_excitation(exo, options={**FAST, "polish_grid": 40, "workers": 1}, seed=0)
    assert result.feasible and result.optimizer_options["polish_grid"] == 40
    assert_inside(result.trajectory, result.spec)
    problem = DesignProblem(exo, result.spec)
    A, b = problem.linear_constraints()
    assert np.all(A @ problem.variables(result.trajectory) <= b + 1e-9)


def test_a_long_design_says_its_expected_time_before_it_runs(monkeypatch, capsys):
    """Issue 35: a design expected to take more than ``LONG`` seconds says so on stderr once, after its first
    search start and before the rest (here LONG is 0, so any design is long)."""
    import pinid.excitation.design as design

    monkeypatch.setattr(design, "LONG", 0.0)
    said_before_polish = []
    real = design._local_search

    def watch(problem, x, maxiter, ftol, stop=None, peaks=False):
        if stop is None:  # a polish: the expected time was said before
            said_before_polish.append("pinid: slsqp: about" in capsys.readouterr().err)
        return real(problem, x, maxiter, ftol, stop, peaks)

    monkeypatch.setattr(design, "_local_search", watch)
    leg = RobotModel.from_urdf("exo_leg")
    design.design_excitation(leg, options={**FAST, "starts": 3, "workers": 1}, seed=0, progress=True)
    assert said_before_polish and said_before_polish[0], said_before_polish


def test_the_design_problems_regressor_is_the_public_one():
    """DesignProblem stacks the regressor without the public function's argument checks: the same numbers."""
    for name, terms in (("exo_leg", TermSelection()), ("exo_leg", TermSelection.from_names("fc,fv,offset"))):
        model = RobotModel.from_urdf(name)
        spec = spec_for(model).replace(terms=terms)
        problem = DesignProblem(model, spec)
        rng = np.random.default_rng(1)
        q, dq, ddq = (rng.standard_normal((7, model.nv)) for _ in range(3))
        assert np.array_equal(problem._stacked(q, dq, ddq), regressor(model, q, dq, ddq, terms))


def test_a_floating_robot_is_evaluated_on_its_joints_with_the_base_held():
    """evaluate_excitation of a floating robot is that of its fixed-base view (``model.fixed_base``): the regressor
    dispatches on the model, the excitation keeps designing on the joints (as pinid excite --base floating)."""
    from pinid.excitation.outputs import evaluate_excitation
    from pinid.excitation.spec import spec_for
    from pinid.excitation.trajectory import FourierTrajectory

    floating = RobotModel.from_urdf("exo_lower_body", base="floating")
    spec = spec_for(floating.fixed_base).replace(samples=60)
    rng = np.random.default_rng(0)
    span = (floating.upper - floating.lower)[:, None]
    a, b = (rng.uniform(-1, 1, (floating.nv, 3)) * 0.05 * span for _ in range(2))
    traj = FourierTrajectory(floating.joint_names, 0.4 * np.pi, 0.5 * (floating.lower + floating.upper), a, b)
    _, ev = evaluate_excitation(floating, traj, spec)
    _, ref = evaluate_excitation(floating.fixed_base, traj, spec)
    assert np.isfinite(ev["condition_number"]) and ev["condition_number"] == ref["condition_number"]
