"""The joint terms chosen by forward selection (pinid.identification.term_choice), against twins whose true
model class is known: a term the truth has gets in, a term it lacks does not."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import load, shared_data
from pinid.data.dataset import Dataset
from pinid.identification.study import Study
from pinid.errors import SpecError
from pinid.identification import run as runner  # not `setup` by name: pytest 7 runs a module's setup()
from pinid.identification.run import identify
from pinid.identification.term_choice import choose_terms
from test_identification import twin, truth_model


def noisy(offset=None, seed: int = 0) -> Dataset:
    """exo_leg with Coulomb and viscous friction (and a constant torque offset per joint), 0.05 N·m noise."""
    model = truth_model("exo_leg")
    ds = twin(model, seconds=20.0, rate=200.0, seed=seed, noise=0.05)
    if offset is not None:
        ds = Dataset(ds.t, ds.q, ds.joints, dq=ds.dq, ddq=ds.ddq, tau=ds.tau + np.asarray(offset), source=ds.source)
    return ds


def test_an_offset_the_truth_has_is_chosen():
    choice = choose_terms(load("exo_leg"), [noisy(offset=[0.8, -0.5])])
    assert choice.terms == ["fc", "fv", "offset"], choice
    assert "+offset" in choice.steps[1]


def test_no_term_the_truth_lacks_is_chosen():
    choice = choose_terms(load("exo_leg"), [noisy()])
    assert choice.terms == ["fc", "fv"], choice
    assert len(choice.steps) == 2  # the start and one step that found nothing measurably better


def test_identify_with_auto_terms_recovers_the_offset():
    truth = [0.8, -0.5]
    ident = identify(Study(load("exo_leg"), noisy(offset=truth), validate=noisy(offset=truth, seed=1), terms="auto"))
    assert ident.data["terms_choice"]["terms"] == ["fc", "fv", "offset"]
    names = ident.results["sdp"].base_names
    got = [ident.results["sdp"].base[names.index(f"{j}.offset")] for j in ("hip", "knee")]
    np.testing.assert_allclose(got, truth, atol=0.05)  # 0.05 N·m noise; the hip offset shares rows with gravity
    assert ident.robot["terms"] == ["fc", "fv", "offset"]


def test_auto_terms_refuse_what_they_cannot_combine_with():
    with pytest.raises(SpecError, match="terms auto with Stribeck velocity 'auto'"):
        runner.setup(Study(load("exo_leg"), noisy(), terms="auto"), stribeck_auto={"fs": False})


@pytest.mark.slow  # about 5 s of CPU (docs/benchmarks.md, Test suite)
def test_kuka_chooses_the_offset_its_torque_sensors_need():
    folder = shared_data() / "kuka_med7"
    if not folder.is_dir():
        pytest.skip("the shared KUKA recordings are not beside the clone")
    from pinid.data.formats import read_recording
    from pinid.model.robot import RobotModel
    from pinid.problem.recordings import prepare_dataset

    model = RobotModel.from_urdf(str(folder / "robot.urdf"))
    ds = read_recording(str(folder / "mext.csv"), model=model)
    choice = choose_terms(model, [prepare_dataset(ds, {})])
    assert "offset" in choice.terms
