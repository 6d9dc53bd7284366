"""Torque offsets per recording (pinid.identification.offsets) against ground truth on noise-free states."""

from __future__ import annotations

import numpy as np
import pytest

from pinid import base_parameters, regressor, standard_parameters
from pinid.data.dataset import Dataset
from pinid.errors import SpecError
from pinid.identification.offsets import calibrate_offsets, identify_recording_offsets
from conftest import load

TERMS = "fc,fv"


def recording(model, theta, offsets, seed, n=200):
    """A noise-free recording: rigid body + friction of ``theta`` plus constant ``offsets`` [N·m] per joint."""
    q, dq, ddq = model.random_states(n, np.random.default_rng(seed))
    tau = (regressor(model, q, dq, ddq, TERMS) @ theta).reshape(n, model.nv) + offsets
    return Dataset(t=np.arange(n) * 0.01, q=q, dq=dq, ddq=ddq, tau=tau, joints=list(model.joint_names))


def test_two_recordings_offsets_and_shared_parameters_recovered_then_third_calibrated():
    model = load("exo_leg")
    rng = np.random.default_rng(3)
    theta = standard_parameters(model, TERMS)
    theta[10 * model.nv :] = rng.uniform(0.2, 1.5, theta.size - 10 * model.nv)  # friction the URDF lacks
    o1, o2, o3 = (rng.uniform(-2, 2, model.nv) for _ in range(3))
    fit = identify_recording_offsets(model, [recording(model, theta, o1, 1), recording(model, theta, o2, 2)], TERMS)
    truth = base_parameters(model, TERMS).P @ theta
    assert np.max(np.abs(fit.values - truth)) <= 1e-6 * np.max(np.abs(truth))
    assert np.allclose(fit.offsets, [o1, o2], rtol=1e-6, atol=1e-9)
    # a third day: only its offsets, from its first 10 %
    assert np.allclose(calibrate_offsets(fit, recording(model, theta, o3, 4), 0.1), o3, rtol=1e-6, atol=1e-9)


def test_shared_offset_term_refused():
    with pytest.raises(SpecError, match="collinear"):
        identify_recording_offsets(load("exo_leg"), [], "fc,fv,offset")
