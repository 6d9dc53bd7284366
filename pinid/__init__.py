"""pinid: identify the rigid-body dynamics of robots (exoskeleton legs first) from a URDF and data."""

from .base import BaseParameters, base_parameters
from .estimators import ESTIMATORS
from .errors import DataError, JointError, ModelError, OutputError, PinidError, SolverError, SpecError
from .identification import Identification, IdentificationProblem, IdentificationResult, identify
from .identified import IdentifiedModel
from .model import INERTIAL_NAMES, RobotModel
from .regressor import JointTerms, joint_torque, parameter_names, regressor, standard_parameters

__version__ = "0.1.0"

__all__ = [
    "BaseParameters", "DataError", "ESTIMATORS", "Identification", "IdentificationProblem",
    "IdentificationResult", "IdentifiedModel", "identify", "INERTIAL_NAMES", "JointError", "JointTerms", "ModelError", "OutputError",
    "PinidError", "RobotModel", "SolverError", "SpecError", "base_parameters", "joint_torque",
    "parameter_names", "regressor", "standard_parameters",
]
