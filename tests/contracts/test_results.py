"""One result protocol (:mod:`pinid.result_protocol`): every result class, on a small real instance, round-trips
through ``to_dict``/``from_dict`` and ``save``/``load``, prints a ``text()``, and draws ``plot(kind, ax)``:
a Figure for its main figure and each listed kind, into a given Axes for a one-panel kind, a SpecError for an
unknown kind.  A walk over pinid finds every class with ``to_dict`` and ``plot``: none may skip this list."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

import pinid  # noqa: E402
from pinid.identification.study import Study
from pinid.errors import SpecError  # noqa: E402
from pinid.io import json_text  # noqa: E402
from pinid.result_protocol import ResultProtocol  # noqa: E402

from test_identification import true_base, twin  # noqa: E402

#: The classes with ``to_dict`` and ``plot`` that do not follow the protocol (none: the floating base's results
#: are the fixed base's since the pipelines merged).
EXCEPTIONS: set[str] = set()


#: The instances are built on conftest's leg_twins (the exo leg's twins) and leg_identification.
pytestmark = pytest.mark.usefixtures("close_figures")


# ---------------------------------------------------------------------------------------- the instances
def _identification(leg, identification):
    return identification


def _identification_result(leg, identification):
    return identification["ols"]


def _comparison(leg, identification):
    from pinid.identification.compare import compare

    truth, train, valid = leg
    return compare(Study(truth, train, valid), methods=["ols", "pso"], seeds=1, truth=true_base(truth)[1], metaheuristic={"population": 6, "iterations": 3})  # fmt: skip


def _output_error(leg, identification):
    from pinid.flexible.output_error import fit_output_error, make_twin, problem_from_spec
    from pinid.flexible.spec import load_flex_spec

    spec = load_flex_spec(Path(__file__).resolve().parents[2] / "excitation" / "tracker_flex_spec.toml")
    s = replace(spec, input=replace(spec.input, duration=0.2))
    problem = problem_from_spec(s, make_twin(s.model(), s.input, noise=0.0), cost="sq")
    xt = np.array([problem.truth[n] for n in problem.free])
    return fit_output_error(problem, "least_squares", x0=xt * 1.05, max_nfev=2)


def _tracking(leg, identification):
    from pinid.control.controllers import ComputedTorque, Tracking, nominal_model, track
    from pinid.excitation.trajectory import FourierTrajectory

    exo = leg[0]
    ref = FourierTrajectory(["hip", "knee"], 0.5 * np.pi, [0.61, -0.87], [[0.5], [0.5]], [[0.0], [0.0]])
    return track(exo, ComputedTorque(nominal_model(exo)), ref, Tracking(0.3))


def _optimize(leg, identification):
    from pinid.optimizers import get_optimizer

    opt = get_optimizer("pso", population=6, iterations=5)
    return opt.minimize(lambda X: np.sum((X - 0.3) ** 2, axis=1), -np.ones(2), np.ones(2), rng=0)


def _excitation(leg, identification):
    from pinid.excitation.design import design_excitation
    from pinid.excitation.spec import spec_for

    exo = pinid.RobotModel.from_urdf("exo_leg")
    spec = spec_for(exo).replace(samples=40)
    return design_excitation(exo, spec, optimizer="pso", options={"population": 6, "iterations": 2}, seed=0)


def _cutoff(leg, identification):
    from pinid.identification.cutoff import CutoffChoice

    return CutoffChoice(10.0, [5.0, 10.0, 20.0], [4.1, 3.9, float("nan")], 5, {"20": "too few samples"})


def _terms(leg, identification):
    from pinid.identification.term_choice import TermsChoice

    return TermsChoice(["fc", "fv", "offset"], [{"fc,fv": 3.9}, {"+offset": 3.5, "+armature": 3.85}], 5)


def _ripple(leg, identification):
    from pinid.identification.ripple_choice import RippleChoice

    return RippleChoice(8.0, [4.0, 8.0, 16.0], [3.2, 2.9, 3.1], 3.4, True, 5)


def _exponents(leg, identification):
    from pinid.wearer.exponents import ExponentFit

    published = {"knee": np.array([[1.0, 0.0, -0.05, 0.0], [-1.0, 0.0, 0.04, 0.0]])}
    fitted = {"knee": published["knee"] * np.array([1.0, 1.0, 1.2, 1.0])}
    return ExponentFit(fitted, published, ["knee[0].cK", "knee[1].cK"], 2.0, 1.5, 12, "converged", 0.1)


def _wearer_stage(leg, identification):
    """Stage 2 on a short noise-free twin of exo_leg with a wearer: λ cross-validated and the passive
    exponents refined, so that every figure has what it draws."""
    import tempfile

    from pinid.identification.identified import IdentifiedModel
    from pinid.model.regressor import standard_parameters
    from pinid.model.terms import TermSelection
    from pinid.wearer.attach import wearer_urdf
    from pinid.wearer.options import WearerOptions
    from pinid.wearer.stage import identify_wearer_stage

    path = Path(tempfile.mkdtemp()) / "exo_with_wearer.urdf"
    wearer_urdf("exo_leg", "hip:thigh,knee:shank", mass=75, height=1.78, sex="male", path=path)
    exo, robot = pinid.RobotModel.from_urdf("exo_leg"), pinid.RobotModel.from_urdf(path)
    stage1 = IdentifiedModel(exo, TermSelection(), standard_parameters(exo, TermSelection()))
    train, valid = twin(robot, seconds=2, rate=50, seed=1), twin(robot, seconds=1, rate=50, seed=2)
    return identify_wearer_stage(
        stage1, robot, [train], validate=[valid], options=WearerOptions(passive_exponents=True)
    )


def _wearer_fit(leg, identification):
    if "pinid.wearer.stage.WearerStage" not in _built:
        _built["pinid.wearer.stage.WearerStage"] = _wearer_stage(leg, identification)
    return _built["pinid.wearer.stage.WearerStage"].fit


#: ``{qualified class name: builder(leg, identification)}``: every result class of pinid.
CASES = {
    "pinid.identification.result.Identification": _identification,
    "pinid.identification.result.IdentificationResult": _identification_result,
    "pinid.identification.compare.Comparison": _comparison,
    "pinid.flexible.result.OutputErrorResult": _output_error,
    "pinid.control.controllers.TrackingResult": _tracking,
    "pinid.optimizers.base.OptimizeResult": _optimize,
    "pinid.excitation.design.ExcitationResult": _excitation,
    "pinid.identification.cutoff.CutoffChoice": _cutoff,
    "pinid.identification.term_choice.TermsChoice": _terms,
    "pinid.identification.ripple_choice.RippleChoice": _ripple,
    "pinid.wearer.exponents.ExponentFit": _exponents,
    "pinid.wearer.stage.WearerFit": _wearer_fit,
    "pinid.wearer.stage.WearerStage": _wearer_stage,
}

_built: dict = {}


@pytest.fixture(params=sorted(CASES), ids=lambda n: n.rsplit(".", 1)[1])
def result(request, leg_twins, leg_identification):
    """A small real instance of each result class (built once)."""
    name = request.param
    if name not in _built:
        _built[name] = CASES[name](leg_twins, leg_identification)
    r = _built[name]
    assert f"{type(r).__module__}.{type(r).__qualname__}" == name
    return r


def same(a, b) -> bool:
    """Two results' dict forms are equal (as JSON: arrays and lists, NaN and null alike)."""
    return json_text(a.to_dict()) == json_text(b.to_dict())


# ---------------------------------------------------------------------------------------- the contract
def test_follows_the_protocol(result):
    assert isinstance(result, ResultProtocol)
    params = inspect.signature(type(result).plot).parameters
    assert list(params) == ["self", "kind", "ax"] and params["kind"].default is None and params["ax"].default is None
    assert type(result).PLOTS, "PLOTS lists at least the main figure"


def test_dict_round_trip(result):
    back = type(result).from_dict(result.to_dict())
    assert type(back) is type(result) and same(back, result)


def test_save_load_round_trip(result, tmp_path):
    path = result.save(tmp_path / "result.json")
    assert isinstance(path, Path) and path.is_file()
    back = type(result).load(path)
    assert type(back) is type(result) and same(back, result)


def test_text(result):
    text = result.text()
    assert isinstance(text, str) and text.strip()


def _draw(result, kind: str | None, ax=None) -> Figure | None:
    """``result.plot(kind, ax)``, or None when ``result`` lacks what ``kind`` needs (a loaded identification
    has no torque curves, a fit without truth no errors): a SpecError about the kind, not the kinds list."""
    try:
        return result.plot(kind, ax=ax)
    except SpecError as exc:
        assert "kind" in str(exc) and "expected one of" not in str(exc), exc
        return None


def test_plot_every_kind(result):
    main = result.plot()
    assert isinstance(main, Figure) and main.axes
    plt.close(main)
    for kind in list(type(result).PLOTS)[1:]:  # the first is the main figure, drawn above
        fig = _draw(result, kind)
        assert fig is None or (isinstance(fig, Figure) and fig.axes)
        plt.close(fig or "all")


def test_plot_into_an_axes(result):
    for kind, one_panel in type(result).PLOTS.items():
        fig, ax = plt.subplots()
        if not one_panel:
            with pytest.raises(SpecError, match="its own figure"):
                result.plot(kind, ax=ax)
        else:
            drawn = _draw(result, kind, ax)
            assert drawn is None or (drawn is fig and fig.axes == [ax] and ax.has_data())
        plt.close(fig)


def test_unknown_kind(result):
    with pytest.raises(SpecError, match="expected one of") as exc:
        result.plot("no-such-figure")
    assert all(repr(k) in str(exc.value) for k in type(result).PLOTS)


# ---------------------------------------------------------------------------------------- no class skips it
def test_every_result_class_is_in_the_suite():
    """Every class of pinid with ``to_dict`` and ``plot`` is one of CASES (the floating two excepted)."""
    found = set()
    for info in pkgutil.walk_packages(pinid.__path__, "pinid."):
        if info.name.endswith("__main__"):
            continue
        try:
            module = importlib.import_module(info.name)
        except ImportError:  # an optional dependency missing (mujoco, rosbags): not this test's subject
            continue
        for _, cls in inspect.getmembers(module, inspect.isclass):
            if (
                cls is not ResultProtocol
                and cls.__module__ == info.name
                and callable(getattr(cls, "to_dict", None))
                and hasattr(cls, "plot")
            ):
                found.add(f"{cls.__module__}.{cls.__qualname__}")
    assert found - EXCEPTIONS == set(CASES), (sorted(found - EXCEPTIONS - set(CASES)), sorted(set(CASES) - found))
