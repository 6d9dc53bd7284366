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


# ---------------------------------------------------------------------------------------------- issue 44
def test_the_default_terms_take_the_offset_only_when_it_wins():
    """No terms given: fc,fv, and the offset when the held-out blocks say it wins (the truth has one), not when
    the truth has none; an explicit fc,fv stays fc,fv."""
    truth = [0.8, -0.5]
    ident = identify(Study(load("exo_leg"), noisy(offset=truth), validate=noisy(offset=truth, seed=1)), "ols")
    assert ident.robot["terms"] == ["fc", "fv", "offset"]
    assert ident.data["default_terms"]["chosen_by"].startswith("default terms") and "terms_choice" not in ident.data
    from pinid.identification.outputs import identification_text

    assert "terms fc, fv, offset: the default, the offset kept: it wins" in " ".join(identification_text(ident).split())
    plain = identify(Study(load("exo_leg"), noisy(), validate=noisy(seed=1)), "ols")
    assert plain.robot["terms"] == ["fc", "fv"]
    given = identify(Study(load("exo_leg"), noisy(offset=truth), terms="fc,fv"), "ols")
    assert given.robot["terms"] == ["fc", "fv"] and "default_terms" not in given.data


def test_held_out_wins_need_more_than_the_spread_of_the_blocks():
    """crossval.better: a paired t test with the blocks' own degrees of freedom, a 1 % gain, 3 blocks at least,
    nothing against round-off; crossval.unstable: a held-out block above 100 %."""
    from pinid.identification.crossval import better, t_quantile, unstable

    ref = np.array([4.0, 3.0, 5.0, 4.2, 4.4])
    assert better(ref - 0.5, ref)  # steady gain
    assert not better(ref - np.array([2.7, -2.7, 2.4, 1.9, 1.7]) * 0.5, ref)  # mean gain inside the spread
    assert not better(ref - 0.01, ref)  # steady but 0.25 %: below the 1 % gain
    assert not better(ref[:2] - 0.5, ref[:2])  # two blocks decide nothing
    assert not better(np.full(5, 1e-9), np.full(5, 2e-9))  # round-off
    assert t_quantile(5) == pytest.approx(2.132, abs=1e-3) and t_quantile(3) == pytest.approx(2.920, abs=1e-3)
    assert unstable(np.array([4.0, 255.0, np.nan])) and not unstable(np.array([40.0, 60.0, np.nan]))


def test_auto_terms_take_added_terms_and_start_from_the_drives():
    """terms "auto,…" starts from the added terms; on a robot with drives from the motor friction and rotor
    inertia besides (issue 44: auto dropped them)."""
    from pinid.identification.term_choice import parse_auto
    from test_drives import MOTOR_TERMS, coupled, twin as drive_twin

    assert parse_auto("auto") == [] and parse_auto("auto,armature") == ["armature"] and parse_auto("fc,fv") is None
    with pytest.raises(SpecError, match="unknown term"):
        parse_auto("auto,bogus")
    choice = choose_terms(load("exo_leg"), [noisy()], keep=["armature"])
    assert "armature" in choice.terms
    m = coupled("exo_leg")
    ds = drive_twin(m, MOTOR_TERMS, noise=0.02)
    choice = choose_terms(m, [ds])
    assert {"motor_fc", "motor_fv", "motor_armature"} <= set(choice.terms), choice
    ident = identify(Study(m, ds, terms="auto,motor_offset"), "ols")
    assert {"motor_fc", "motor_fv", "motor_armature", "motor_offset"} <= set(ident.robot["terms"])


def test_a_candidate_whose_fit_does_not_converge_is_rejected_not_scored(monkeypatch):
    """A candidate scoring above 100 % on a held-out block is listed as rejected and never adopted."""
    from pinid.identification import term_choice

    real = term_choice.fold_sums

    def blown(rows, edges, spans):  # the Stribeck candidate's held-out errors blown up, as on the coupled wrist
        s = real(rows, edges, spans)
        if rows.W.shape[1] == 12:  # exo_leg's fc,fv has 10 base parameters, fc,fv,fs 12
            s[:, 0] *= 1e6
        return s

    monkeypatch.setattr(term_choice, "fold_sums", blown)
    choice = choose_terms(load("exo_leg"), [noisy()], steps=(("fs", ("fs",)),))
    assert "+fs" in choice.rejected and "did not converge" in choice.rejected["+fs"]
    assert choice.terms == ["fc", "fv"]
    assert "not scored: +fs" in choice.text()
    from pinid.identification.term_choice import TermsChoice

    assert TermsChoice.from_dict(choice.to_dict()).rejected == choice.rejected


def test_the_default_rule_shares_one_regressor_and_scores_as_the_selection_does():
    """choose_default_terms drops the offset columns of one regressor for fc,fv: the same held-out scores as
    building each candidate (choose_terms with the offset as the only step), the same choice."""
    from pinid.identification.term_choice import choose_default_terms

    for ds in (noisy(offset=[0.8, -0.5]), noisy()):
        fast = choose_default_terms(load("exo_leg"), [ds])
        slow = choose_terms(load("exo_leg"), [ds], steps=(("offset", ("offset",)),), kind="default")
        assert fast.terms == slow.terms
        for a, b in zip(fast.steps, slow.steps):
            assert a.keys() == b.keys() and all(a[k] == pytest.approx(b[k], rel=1e-9) for k in a)
