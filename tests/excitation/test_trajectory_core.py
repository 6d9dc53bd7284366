"""Fourier trajectories: derivatives match finite differences, files round-trip, degrees convert."""

from __future__ import annotations

import numpy as np
import pytest

from pinid.errors import SpecError
from pinid.excitation.trajectory import FourierTrajectory


def _traj():
    rng = np.random.default_rng(0)
    return FourierTrajectory(
        ["hip", "knee"], 0.2 * np.pi, [0.6, -0.9], rng.normal(0, 0.1, (2, 4)), rng.normal(0, 0.1, (2, 4))
    )


def test_derivatives_match_finite_differences():
    tr = _traj()
    t = np.linspace(0, 10, 2001)
    q, dq, ddq = tr.evaluate(t)
    h = t[1] - t[0]
    np.testing.assert_allclose(np.gradient(q, h, axis=0)[1:-1], dq[1:-1], atol=1e-4)
    np.testing.assert_allclose(np.gradient(dq, h, axis=0)[1:-1], ddq[1:-1], atol=1e-4)


def test_periodic_and_save_load(tmp_path):
    tr = _traj()
    q0, *_ = tr.evaluate(0.0)
    q1, *_ = tr.evaluate(tr.period)
    np.testing.assert_allclose(q0, q1, atol=1e-12)
    tr.meta["condition_number"] = 12.5
    tr.save(tmp_path / "t.json")
    back = FourierTrajectory.load(tmp_path / "t.json")
    np.testing.assert_allclose(back.a, tr.a)
    assert back.meta["condition_number"] == 12.5


def test_degrees_are_converted():
    d = {"joints": ["hip"], "base_frequency": 1.0, "q0": [90.0], "a": [[180.0]], "b": [[0.0]], "unit": "deg"}
    tr = FourierTrajectory.from_dict(d)
    assert tr.q0[0] == pytest.approx(np.pi / 2) and tr.a[0, 0] == pytest.approx(np.pi)


def test_bad_trajectory_files(tmp_path):
    p = tmp_path / "x.json"
    p.write_text("{")
    with pytest.raises(SpecError, match="not valid JSON"):
        FourierTrajectory.load(p)
    p.write_text('{"joints": ["hip"]}')
    with pytest.raises(SpecError, match="missing key"):
        FourierTrajectory.load(p)
    with pytest.raises(SpecError, match="base_frequency"):
        FourierTrajectory(["hip"], 0.0, [0.0], [[0.1]], [[0.1]])
