"""Deprecated location: the identification now lives in :mod:`pinid.problem.problem` (the problem
and its statistics), :mod:`pinid.identification.result` (the results) and :mod:`pinid.identification.run`
(:func:`identify`).  These names stay importable from here for one release."""

from __future__ import annotations

from pinid.problem.problem import (
    REST_FRACTION,
    IdentificationProblem,
    base_regressor,
    base_statistics,
    check_dataset,
    least_norm_completion,
    predict_torque,
    prepare_dataset,
    rest_threshold,
    rest_thresholds,
    stack_rows,
)
from pinid.identification.result import Identification, IdentificationResult, make_result
from pinid.identification.run import DEFAULT_METHODS, identify

__all__ = [
    "DEFAULT_METHODS",
    "REST_FRACTION",
    "Identification",
    "IdentificationProblem",
    "IdentificationResult",
    "base_regressor",
    "base_statistics",
    "check_dataset",
    "identify",
    "least_norm_completion",
    "make_result",
    "predict_torque",
    "prepare_dataset",
    "rest_threshold",
    "rest_thresholds",
    "stack_rows",
]
