"""pinid.Study: the one object identify() and compare() take (issue 32) — its type checks, its file form (a
dataset manifest) and an identity of the fit it feeds."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import pinid
from pinid.data.dataset import Dataset
from pinid.data.formats import write_recording
from pinid.errors import SpecError
from pinid.identification import run as runner  # not `setup` by name: pytest 7 runs a module's setup()
from pinid.identification.compare import compare
from pinid.identification.run import identify
from pinid.identification.study import Study
from pinid.model.robot import RobotModel

from test_identification import truth_model, twin


@pytest.fixture(scope="module")
def leg():
    return truth_model("exo_leg")


def test_study_is_exported_beside_identify():
    assert pinid.Study is Study and "Study" in pinid.__all__


def test_the_model_is_resolved_once_to_a_robot_model(leg):
    s = Study("exo_leg", "run.csv")
    assert isinstance(s.model, RobotModel) and s.model.name == "exo_leg"
    assert Study(leg, "run.csv").model is leg
    assert s.terms == "default" and s.rest_velocity == "auto" and s.delay is None  # fc,fv (+ offset if it wins)
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.delay = 0.1


@pytest.mark.parametrize(
    "fields, message",
    [
        ({"model": 3, "data": "run.csv"}, "Study model: got int"),
        ({"model": "exo_leg"}, "Study data: no training recording"),
        ({"model": "exo_leg", "data": 3}, "Study data: got int"),
        ({"model": "exo_leg", "data": ["a.csv", 3]}, "Study data: got list"),
        ({"model": "exo_leg", "data": "a.csv", "validate": {"x": 3}}, "Study validate: got dict"),
        ({"model": "exo_leg", "data": "a.csv", "terms": 3}, "Study terms: got int"),
        ({"model": "exo_leg", "data": "a.csv", "preprocess": [5]}, "Study preprocess: got list"),
        ({"model": "exo_leg", "data": "a.csv", "rest_fraction": "half"}, "Study rest_fraction: got str"),
        ({"model": "exo_leg", "data": "a.csv", "payload": 3}, "Study payload: got int"),
        ({"model": "exo_leg", "data": "a.csv", "fit_joints": [1]}, "Study fit_joints: got list"),
        ({"model": "exo_leg", "data": "a.csv", "delay": [0.1]}, "Study delay: got list"),
        ({"model": "exo_leg", "data": "a.csv", "floating": 1}, "Study floating: got int"),
        ({"model": "exo_leg", "data": "a.csv", "segmental": "knee"}, "Study segmental: got str"),
        ({"model": "exo_leg", "data": "a.csv", "methods": "ols"}, "Study: unknown field(s) methods"),
        ({"model": "exo_leg", "data": "a.csv", "manifset": "x.toml"}, "Study: unknown field(s) manifset"),
    ],
)
def test_a_study_refuses_wrong_types_and_unknown_fields_in_one_line(fields, message):
    with pytest.raises(SpecError) as err:
        Study(**fields)
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def test_identify_and_compare_take_a_study_only(leg):
    for call in (lambda: identify(leg, "run.csv"), lambda: identify("exo_leg"), lambda: compare(leg, "run.csv")):
        with pytest.raises(SpecError, match=r"expected a Study \(pinid.Study\(model, data, …\)\)"):
            call()
    with pytest.raises(SpecError, match="expected a Study"):
        runner.setup("exo_leg")


def test_a_manifest_is_the_file_form_of_a_study(tmp_path, leg):
    ds = twin(leg, seconds=12, rate=200, seed=3, noise=0.05)
    write_recording(tmp_path / "run.csv", Dataset(ds.t, ds.q, ds.joints, tau=ds.tau, source="run"))
    lines = (tmp_path / "run.csv").read_text().splitlines(keepends=True)
    (tmp_path / "train.csv").write_text("".join(lines[: 1 + 1600]))
    (tmp_path / "valid.csv").write_text("".join(lines[:1] + lines[1 + 1600 :]))
    (tmp_path / "study.toml").write_text(
        'fit_joints = ["knee"]\n'
        '[[recording]]\nfile = "run.csv"\nrole = "train"\nrows = [0, 1600]\n'
        '[[recording]]\nfile = "run.csv"\nrole = "validate"\nrows = [1600]\n'
    )
    listed = Study.from_manifest(tmp_path / "study.toml", leg, terms="fc,fv")
    by_hand = Study(leg, tmp_path / "train.csv", validate=tmp_path / "valid.csv", terms="fc,fv", fit_joints=["knee"])
    assert listed.manifest == str(tmp_path / "study.toml") and by_hand.manifest is None
    assert listed.fit_joints == by_hand.fit_joints and listed.terms == by_hand.terms and listed.payload is None
    a, b = runner.setup(listed), runner.setup(by_hand)
    assert np.array_equal(a.problem.W, b.problem.W) and np.array_equal(a.problem.tau, b.problem.tau)
    got, want = identify(listed, "ols"), identify(by_hand, "ols")
    assert np.array_equal(got["ols"].base, want["ols"].base)
    assert got.data["manifest"] == str(tmp_path / "study.toml") and "manifest" not in want.data
    # the recordings are the manifest's: given twice is refused; fit_joints given overrides the manifest's
    with pytest.raises(SpecError, match="the manifest lists the recordings, and data given too"):
        Study.from_manifest(tmp_path / "study.toml", leg, data="train.csv")
    assert Study.from_manifest(tmp_path / "study.toml", leg, fit_joints="hip").fit_joints == "hip"
    with pytest.raises(SpecError, match="Study: unknown field"):
        Study.from_manifest(tmp_path / "study.toml", leg, methods="ols")


def test_ols_of_a_study_is_least_squares_on_its_rows(leg):
    study = Study(leg, twin(leg, seconds=6, rate=200, seed=1, noise=0.05), validate=twin(leg, seconds=3, seed=2))
    s = runner.setup(study)
    x, *_ = np.linalg.lstsq(s.problem.W, s.problem.tau, rcond=None)
    got = identify(study, ["ols"])["ols"].base
    np.testing.assert_allclose(got, x, rtol=1e-10, atol=1e-10 * np.abs(x).max())


def test_a_preprocessing_object_gives_the_numbers_of_its_dict_form(leg):
    """``Study(preprocess=Preprocessing(...))`` is carried as the dict of the options it sets: the prepared rows
    and the fit are those of the dict form, bit for bit (identify and compare alike); a wrong type is one line."""
    from pinid.data.preprocess import Preprocessing

    data = twin(leg, seconds=8, rate=500, seed=4, noise=0.05)
    data = Dataset(data.t, data.q, data.joints, tau=data.tau, source="raw")  # no dq, ddq: prepared
    val = twin(leg, seconds=4, rate=500, seed=5, noise=0.05)
    as_object = Study(leg, data, validate=val, preprocess=Preprocessing(cutoff=6.0, order=2, trim=0.5))
    as_dict = Study(leg, data, validate=val, preprocess={"cutoff": 6.0, "order": 2, "trim": 0.5})
    assert as_object.preprocess == {"cutoff": 6.0, "order": 2, "trim": 0.5} == as_dict.preprocess
    assert Study(leg, data, preprocess=Preprocessing()).preprocess == {}  # the defaults: prepared as with {}
    a, b = runner.setup(as_object), runner.setup(as_dict)
    assert np.array_equal(a.problem.W, b.problem.W) and np.array_equal(a.problem.tau, b.problem.tau)
    default = runner.setup(Study(leg, data, validate=val, preprocess={}))
    assert a.problem.W.shape != default.problem.W.shape  # the options do act (trim 0.5 s, not the default)
    got, want = identify(as_object, "ols"), identify(as_dict, "ols")
    assert np.array_equal(got["ols"].base, want["ols"].base)
    assert got["ols"].validation == want["ols"].validation
    # the truth is recovered through the object form: validation error at the torque noise (0.05 N·m)
    assert got["ols"].validation.all["rms"] < 0.08
    c1, c2 = compare(as_object, ["ols"], seeds=1), compare(as_dict, ["ols"], seeds=1)
    r1, r2 = c1.to_dict()["runs"]["ols"][0], c2.to_dict()["runs"]["ols"][0]
    assert r1["base"] == r2["base"] and r1["validation"] == r2["validation"]
    with pytest.raises(SpecError) as err:
        Study(leg, data, preprocess="cutoff=6")
    assert str(err.value).startswith("Study preprocess: got str, expected a Preprocessing") and "\n" not in str(
        err.value
    )
