"""Stage 2: the wearer identified with the exoskeleton fixed, pulled toward the tables."""

from __future__ import annotations

import numpy as np
import pytest

from pinid.identification.identified import IdentifiedModel
from pinid.model.regressor import JointTerms, regressor, standard_parameters
from pinid.model.robot import RobotModel
from pinid.wearer.attach import wearer_urdf
from pinid.wearer.prior import drawn as _perturbed, wearer_prior
from pinid.wearer.stage import identify_wearer


@pytest.fixture(scope="module")
def setup(tmp_path_factory):
    path = tmp_path_factory.mktemp("w") / "exo_with_wearer.urdf"
    wearer_urdf("exo_leg", "hip:thigh,knee:shank,knee:foot", mass=75, height=1.78, sex="male", path=path)
    exo = RobotModel.from_urdf("exo_leg")
    robot = RobotModel.from_urdf(path)
    stage1 = IdentifiedModel(exo, JointTerms(), standard_parameters(exo, JointTerms()))
    rng = np.random.default_rng(3)
    truth = np.zeros(22)
    for b in wearer_prior(path.read_text(), robot):
        truth[10 * b.index: 10 * b.index + 10] = _perturbed(b.theta, rng)
    truth[20:] = [0.8, 1.3]
    n = 400
    q = rng.uniform([-0.05, -1.6], [1.3, -0.1], (n, 2))
    dq, ddq = rng.normal(0, 1, (n, 2)), rng.normal(0, 3, (n, 2))
    full = JointTerms.from_names("fc,fv,passive")
    theta_full = np.concatenate([stage1.theta[:20] + truth[:20], [1.2, 0.8, 0.8, 0.9, 0.6, 1.3]])
    theta_full[[22, 25]] = truth[20:]
    tau = (regressor(robot, q, dq, ddq, full) @ theta_full).reshape(n, 2)
    return stage1, path, robot, truth, (q, dq, ddq, tau)


def test_noise_free_wearer_recovered(setup):
    stage1, path, robot, truth, data = setup
    fit = identify_wearer(stage1, path, *data)
    from pinid.model.base import base_parameters

    want = base_parameters(robot, fit.terms).from_standard(truth)
    rel = np.abs(fit.base - want) / np.maximum(np.abs(want), 1e-3)
    assert rel.max() <= 1e-6, dict(zip(fit.base_names, rel))
    print("max relative error", rel.max(), "solve", fit.seconds)
    assert fit.status == "optimal"
    # the tables decide only what the data cannot: the result differs from the table where data speak
    assert np.abs(fit.base_table - want).max() > 0.05
    # the combined model reproduces the torque
    tau = fit.model().inverse_dynamics(*data[:3])
    np.testing.assert_allclose(tau, data[3], atol=1e-6)
