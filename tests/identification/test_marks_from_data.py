"""Identification marks from the data, not from the model's structure (issue 47 finding 1; reproducer 01 of round 5)."""

from __future__ import annotations

import json
from importlib.resources import files

import numpy as np
import pytest

from pinid.estimators import make_estimator
from pinid.excitation.trajectory import FourierTrajectory
from pinid.identification.result import make_result
from pinid.identification.run import identify
from pinid.identification.study import Study
from pinid.model.robot import RobotModel
from pinid.problem.problem import IdentificationProblem
from pinid.simulation.twin import simulate

from test_identification import truth_model, twin


@pytest.fixture(scope="module")
def knee_still(tmp_path_factory):
    """A 10 s twin recording of exo_leg's designed excitation with the knee's harmonics set to zero."""
    d = json.loads(files("pinid.resources.excitation").joinpath("exo_leg.json").read_text())
    i = d["joints"].index("knee")
    d["a"][i] = [0.0] * len(d["a"][i])
    d["b"][i] = [0.0] * len(d["b"][i])
    path = tmp_path_factory.mktemp("still") / "knee_still.json"
    path.write_text(json.dumps(d))
    model = RobotModel.from_urdf("exo_leg")
    ds, truth = simulate(model, FourierTrajectory.load(path), seconds=10.0, seed=3)
    return model, ds, truth


@pytest.mark.filterwarnings("ignore::pinid.errors.DataWarning")
def test_a_joint_held_still_has_its_friction_not_identified(knee_still, tmp_path):
    model, ds, truth = knee_still
    ident = identify(Study(model, ds), methods="ols,sdp", truth=truth)
    for r in ident:
        assert r.marks["knee.fc"] == r.marks["knee.fv"] == "not identified", r.method
        assert r.marks["hip.fc"] == r.marks["hip.fv"] == "identified", r.method
        assert r.marks["knee.mx"] == "identified", r.method  # its gravity torque is measured all the same
    saved = json.loads(json.dumps(ident.to_dict()))
    assert saved["methods"]["sdp"]["standard_marks"]["knee.fc"] == "not identified"
    sdp = ident["sdp"].model
    for text in (sdp.export_urdf(), sdp.export_mjcf()):
        assert "not identified (no information in these data): fc, fv" in text
    from pinid.report.markdown import report_markdown

    knee = [line for line in report_markdown(ident, {}).splitlines() if line.startswith("| `knee` |")]
    assert knee and "not identified (no information in these data): my, Ixx, Ixy, Ixz, Iyz, Izz, fc, fv" in knee[0]


def test_clean_twin_marks_equal_the_structural_ones():
    model = truth_model("exo_leg")
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=10, seed=1, noise=0.05))
    for method in ("ols", "sdp"):
        r = make_result(problem, make_estimator(method).fit(problem), 0.0, complete=False)
        assert r.marks == problem.base.marks(), method


def test_sdp_friction_held_on_its_bound_is_named():
    """True viscous friction −0.5: sdp holds fv ≥ 0 at 0 — marked "at bound", OLS's (negative) "identified"."""
    model = truth_model("exo_leg", fv=-0.5)
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=5, rate=200, seed=2, noise=0.05))
    sdp = make_result(problem, make_estimator("sdp").fit(problem), 0.0, complete=False)
    ols = make_result(problem, make_estimator("ols").fit(problem), 0.0, complete=False)
    for j in model.joint_names:
        assert sdp.marks[f"{j}.fv"] == "at bound"
        assert ols.marks[f"{j}.fv"] == "identified"
    assert np.all(np.isfinite(ols.std))
