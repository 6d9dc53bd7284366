"""The model-class floor (issue 34, item 4): the same model class (rigid bodies and the same joint terms)
fitted by least squares in-sample on the validation recordings themselves, its torque error measured like the
validation error (against the torque as recorded).  No identification of this class fitted on other data can
do much better on those recordings: a validation error near the floor says the model class limits the user
(richer terms help), one far above it says the identification does (more or other excitation, priors)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pinid.data.dataset import Dataset
from pinid.estimators import make_estimator
from pinid.identification.metrics import TorqueMetrics, joint_units, torque_metrics
from pinid.model.base import base_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.problem.problem import REST_FRACTION, IdentificationProblem, check_dataset, predict_torque, recorded_torque


def validation_floor(
    model: RobotModel,
    terms: TermSelection,
    datasets: Sequence[Dataset],
    *,
    rest_velocity="auto",
    rest_fraction: float = REST_FRACTION,
) -> TorqueMetrics:
    """Per-joint torque metrics [N·m or N] of OLS fitted on the (prepared) validation ``datasets`` and
    predicting them, against the torque as recorded; every joint's rows enter the fit (the rows at rest are
    left out as in the identification's)."""
    checked = [check_dataset(ds, model) for ds in datasets]
    base = base_parameters(model, terms)
    problem = IdentificationProblem.from_datasets(
        model, checked, terms=terms, base=base, rest_velocity=rest_velocity, rest_fraction=rest_fraction
    )
    theta = make_estimator("ols").fit(problem).base_
    pred = np.concatenate([predict_torque(model, terms, base, ds, theta) for ds in checked])
    recorded = np.concatenate([recorded_torque(ds) for ds in checked])
    return torque_metrics(recorded, pred, model.joint_names, units=joint_units(model))
