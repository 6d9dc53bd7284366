"""``--ripple-periods auto``: the ripple periods chosen by blocked cross-validation on the training recordings
(pinid/identification/ripple_choice.py), against twins with a known ripple."""

from __future__ import annotations

import warnings

import pytest

from pinid.errors import SpecError
from pinid.identification.study import Study
from pinid.identification.ripple_choice import choose_ripple_periods, is_auto
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.problem.recordings import load_datasets
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import simulate

TERMS = TermSelection(names=["fc", "fv", "ripple_s1", "ripple_c1"])


def _recording(ripple: dict | None, seed: int = 3):
    """A noisy exo_leg twin (the default noise) with ``ripple`` amplitudes at 12 periods per revolution."""
    m = RobotModel.from_urdf("exo_leg").with_setting("ripple_periods", 12.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zha2019-4 is faster than exo_leg's URDF limits: a DataWarning
        ds, _ = simulate(m, load_trajectory("zha2019-4", m), seconds=12.0, seed=seed, terms=ripple or {})
    return ds


@pytest.mark.slow
def test_the_twins_ripple_periods_are_found_and_said_to_help():
    ds = _recording({"ripple_s1": [0.4, -0.25], "ripple_c1": [-0.2, 0.3]})
    auto = RobotModel.from_urdf("exo_leg").with_setting("ripple_periods", "auto")
    assert is_auto(auto)
    choice = choose_ripple_periods(auto, load_datasets(ds, auto), TERMS)
    assert choice.periods == 12.0
    assert choice.helps
    assert choice.scores[choice.candidates.index(12.0)] < choice.without
    d = choice.to_dict()
    assert (
        d["periods"] == 12.0 and d["measurably_better"] is True and len(d["cv_rel_rms_percent"]) == len(d["candidates"])
    )


@pytest.mark.slow
def test_identify_uses_the_chosen_periods_and_keeps_the_choice(tmp_path):
    from pinid.data.formats import write_recording
    from pinid.identification.run import identify

    train = write_recording(tmp_path / "train.csv", _recording({"ripple_s1": [0.4, -0.25], "ripple_c1": [-0.2, 0.3]}))
    auto = RobotModel.from_urdf("exo_leg").with_setting("ripple_periods", "auto")
    ident = identify(Study(auto, str(train), terms=TERMS), methods=["ols"])
    assert ident.data["ripple_periods"]["periods"] == 12.0
    names = ident["ols"].base_names
    amp = dict(zip(names, ident["ols"].base))
    assert amp["hip.ripple_s1"] == pytest.approx(0.4, abs=0.05) and amp["knee.ripple_c1"] == pytest.approx(
        0.3, abs=0.05
    )


def test_auto_without_a_ripple_term_is_refused():
    auto = RobotModel.from_urdf("exo_leg").with_setting("ripple_periods", "auto")
    with pytest.raises(SpecError, match="without a ripple term"):
        choose_ripple_periods(auto, [], TermSelection(names=["fc", "fv"]))
