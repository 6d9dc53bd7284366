"""pinid: identify the rigid-body dynamics of robots (exoskeleton legs first) from a URDF and data.

The names below are loaded when first used (PEP 562), so ``import pinid`` and the ``pinid`` command
start in milliseconds: the command installs its Ctrl-C handling before numpy, scipy and Pinocchio load
(:func:`pinid.cli.main.main`).
"""

__version__ = "0.1.0"

#: Public name -> the module that defines it.
_EXPORTS = {
    "BaseParameters": "pinid.model.base",
    "base_parameters": "pinid.model.base",
    "ESTIMATORS": "pinid.estimators",
    "DataError": "pinid.errors",
    "JointError": "pinid.errors",
    "ModelError": "pinid.errors",
    "OutputError": "pinid.errors",
    "PinidError": "pinid.errors",
    "SolverError": "pinid.errors",
    "SpecError": "pinid.errors",
    "IdentificationProblem": "pinid.problem.problem",
    "Identification": "pinid.identification.result",
    "IdentificationResult": "pinid.identification.result",
    "identify": "pinid.identification.run",
    "Study": "pinid.identification.study",
    "IdentifiedModel": "pinid.identification.identified",
    "INERTIAL_NAMES": "pinid.model.robot",
    "RobotModel": "pinid.model.robot",
    "FloatingRobotModel": "pinid.model.floating",
    "TermSelection": "pinid.model.terms",
    "JointTerms": "pinid.model.terms",  # TermSelection's old name: a DeprecationWarning, for one release
    "joint_torque": "pinid.model.regressor",
    "parameter_names": "pinid.model.regressor",
    "regressor": "pinid.model.regressor",
    "standard_parameters": "pinid.model.regressor",
}

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
    "TermSelection",
    "ModelError",
    "OutputError",
    "PinidError",
    "RobotModel",
    "SolverError",
    "SpecError",
    "Study",
    "base_parameters",
    "joint_torque",
    "parameter_names",
    "regressor",
    "standard_parameters",
]


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'pinid' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    if name != "JointTerms":  # an old name is not cached: it warns at every use
        globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
