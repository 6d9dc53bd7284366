"""pinid: identify the rigid-body dynamics of robots (exoskeleton legs first) from a URDF and data."""

from .base import BaseParameters, base_parameters
from .errors import DataError, JointError, ModelError, OutputError, PinidError, SolverError, SpecError
from .model import INERTIAL_NAMES, RobotModel
from .regressor import JointTerms, joint_torque, parameter_names, regressor, standard_parameters

__version__ = "0.1.0"

__all__ = [
    "BaseParameters", "DataError", "INERTIAL_NAMES", "JointError", "JointTerms", "ModelError", "OutputError",
    "PinidError", "RobotModel", "SolverError", "SpecError", "base_parameters", "joint_torque",
    "parameter_names", "regressor", "standard_parameters",
]
