"""pinid: identify the rigid-body dynamics of robots (exoskeleton legs first) from a URDF and data."""

from pinid.model.base import BaseParameters, base_parameters
from pinid.estimators import ESTIMATORS
from pinid.errors import DataError, JointError, ModelError, OutputError, PinidError, SolverError, SpecError
from pinid.identification.problem import IdentificationProblem
from pinid.identification.result import Identification, IdentificationResult
from pinid.identification.run import identify
from pinid.identification.identified import IdentifiedModel
from pinid.model.robot import INERTIAL_NAMES, RobotModel
from pinid.model.floating import FloatingRobotModel
from pinid.model.regressor import JointTerms, joint_torque, parameter_names, regressor, standard_parameters

__version__ = "0.1.0"

__all__ = [
    "BaseParameters",
    "DataError",
    "ESTIMATORS",
    "FloatingRobotModel",
    "Identification",
    "IdentificationProblem",
    "IdentificationResult",
    "IdentifiedModel",
    "identify",
    "INERTIAL_NAMES",
    "JointError",
    "JointTerms",
    "ModelError",
    "OutputError",
    "PinidError",
    "RobotModel",
    "SolverError",
    "SpecError",
    "base_parameters",
    "joint_torque",
    "parameter_names",
    "regressor",
    "standard_parameters",
]
