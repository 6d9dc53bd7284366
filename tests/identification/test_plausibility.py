"""Recordings that mislead without failing (issue 33): a validation that repeats the training trajectory, a
flipped torque sign, no validation at all."""

from __future__ import annotations

import contextlib
import io
import warnings

import numpy as np
import pytest

from conftest import load
from pinid.data.dataset import Dataset
from pinid.identification.study import Study
from pinid.errors import DataWarning
from pinid.identification.plausibility import aligned_difference, flipped_torque_signs, shared_excitation


def _fourier(t, phase=0.0, w=0.2 * np.pi, a=(0.25, 0.3)):
    return np.column_stack([0.6 + a[0] * np.sin(w * t + phase), -0.9 + a[1] * np.cos(3 * w * t + 3 * phase)])


def _ds(name, t, q):
    return Dataset(t, q, ["hip", "knee"], tau=np.zeros_like(q), source=name)


def test_the_same_excitation_started_later_is_found_another_one_is_not():
    rng = np.random.default_rng(0)
    t = np.arange(0, 20, 0.001)
    train = _ds("train.csv", t, _fourier(t))
    tv = np.arange(0, 8, 0.002)  # another rate, started 1.3 s into the period, with noise
    again = _ds("again.csv", tv, _fourier(tv, phase=0.2 * np.pi * 1.3) + 1e-3 * rng.normal(size=(tv.size, 2)))
    other = _ds("other.csv", tv, _fourier(tv, w=0.31 * np.pi, a=(0.3, 0.2)))
    with pytest.warns(DataWarning) as caught:
        said = shared_excitation([train], [again, other])
    assert len(said) == 1 and len(caught) == 1
    assert said[0].startswith(
        "again.csv: the validation recording repeats the trajectory of training recording train.csv (positions "
    )
    assert said[0].endswith("apart after alignment), so it hides overfitting; validate on another excitation")
    spread = np.std(train.q, axis=0)
    grid = np.arange(0, 20, 0.01)
    assert aligned_difference(_fourier(grid), _fourier(grid[:800] + 1.3), spread) < 1e-9  # exact shift
    assert aligned_difference(_fourier(grid), _fourier(grid[:800], w=0.31 * np.pi), spread) > 0.3


def _motion(seconds: float):
    """``(t, q, dq, ddq)`` of :func:`_fourier` at 100 Hz, derivatives by finite differences."""
    t = np.arange(0, seconds, 0.01)
    q = _fourier(t)
    dq = np.gradient(q, t, axis=0)
    return t, q, dq, np.gradient(dq, t, axis=0)


def test_a_flipped_torque_sign_is_named():
    model = load("exo_leg")
    t, q, dq, ddq = _motion(5)
    nominal = model.rnea(q, dq, ddq)
    rng = np.random.default_rng(1)
    recorded = 1.2 * nominal + 0.05 * rng.normal(size=nominal.shape)  # another payload, noise: not flipped
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert flipped_torque_signs(model.joint_names, recorded, nominal) == []
    recorded[:, 1] *= -1
    with pytest.warns(DataWarning, match=r"^check the sign of tau_knee: it is anti-correlated \(r = -1.00\) with the "):
        assert flipped_torque_signs(model.joint_names, recorded, nominal) == ["knee"]


def test_identify_without_validation_says_so_in_one_line(recording, tmp_path):
    from pinid.cli.identify import UNVALIDATED
    from pinid.cli.main import main

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(["identify", "--data", str(recording), "--methods", "ols", "--no-report", "-o", str(tmp_path)])
    assert code == 0
    assert f"pinid identify: warning: {UNVALIDATED}\n" in err.getvalue(), err.getvalue()


def test_compare_warns_of_a_flipped_torque_sign_as_identify_does():
    from pinid.identification.compare import compare

    model = load("exo_leg")
    t, q, dq, ddq = _motion(8)
    tau = model.rnea(q, dq, ddq)
    tau[:, 0] *= -1
    flipped = Dataset(t, q, ["hip", "knee"], dq, ddq, tau, source="flipped.csv")
    with pytest.warns(DataWarning, match=r"check the sign of tau_hip"):
        compare(Study(model, [flipped], preprocess=False), methods=["ols"], seeds=1)
