"""The one loader (:func:`pinid.problem.recordings.load_datasets`, issue 32): it dispatches on the model, a
floating model's recordings (paths, Datasets with floating channels, prepared samples) becoming their
FloatingSamples with the same numbers as preparing them directly, a fixed model's prepared as before."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from pinid import RobotModel
from pinid.data.contacts import FloatingSamples
from pinid.data.formats import write_recording
from pinid.data.preprocess import prepare
from pinid.errors import DataError, SpecError
from pinid.problem.recordings import load_datasets
from pinid.simulation.floating_twin import simulate_suspended

from conftest import floating_excitation


@pytest.fixture(scope="module")
def floating():
    model = RobotModel.from_urdf("exo_lower_body", base="floating")
    run = simulate_suspended(model, floating_excitation(model, 0), seconds=1, rate=500, seed=0)
    return model, run.recording


def test_a_floating_model_loads_paths_datasets_and_samples_into_floating_samples(floating, tmp_path):
    model, rec = floating
    direct = prepare(rec, None)
    path = write_recording(tmp_path / "suspended.csv", rec)
    by_hand = replace(rec, floating=replace(rec.floating, model=None))  # built without a model: gets this one
    seen = []
    out = load_datasets([path, by_hand, direct], model, check=seen.append)
    assert all(isinstance(s, FloatingSamples) for s in out) and out[2] is direct  # prepared samples pass through
    assert [r.floating.model for r in seen] == [model, model]  # the raw recordings, before preparing
    np.testing.assert_array_equal(out[1].base_a, direct.base_a)
    np.testing.assert_allclose(out[0].base_a, direct.base_a, rtol=1e-6, atol=1e-6)  # the CSV's printed digits
    with pytest.raises(DataError, match="expected a path, a Dataset with floating channels or FloatingSamples"):
        load_datasets(replace(rec, floating=None), model)
    with pytest.raises(DataError, match="no validation recording given"):
        load_datasets([], model, what="validation")


def test_a_fixed_model_refuses_floating_samples_and_bad_options(floating, exo):
    model, rec = floating
    with pytest.raises(DataError, match="got FloatingSamples, expected a Dataset or a recording's path"):
        load_datasets(prepare(rec, None), exo)
    with pytest.raises(SpecError, match="swing_rows True or False"):
        load_datasets(None, model, swing_rows="yes")
    assert load_datasets(None, model) == []
