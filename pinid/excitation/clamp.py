"""An excitation spec clamped to the robot's own limits: the torque bound of ``pinid excite --torque-limits``.

The spec (:class:`pinid.excitation.spec.ExcitationSpec`) holds what a URDF cannot; the URDF's effort
limits clamp its torque bound here, so that the command only says which clamp it wants."""

from __future__ import annotations

import numpy as np

from pinid.errors import SpecError
from pinid.model.robot import RobotModel, as_robot


def within_effort_limits(spec, model: RobotModel):
    """``spec`` with its torque bound ``tau_max`` [N·m] no larger than ``model``'s URDF effort limits (the
    smaller of the two per joint); SpecError when the URDF gives no effort limit for any joint."""
    model = as_robot(model)
    if not callable(getattr(spec, "replace", None)) or getattr(spec, "tau_max", None) is None:
        raise SpecError(f"spec: got {type(spec).__name__}, expected an ExcitationSpec")
    effort = model.effort_limit
    if not np.any(np.isfinite(effort)):
        raise SpecError(f"--torque-limits: the URDF {model.urdf_path} gives no effort limit for any joint")
    return spec.replace(tau_max=np.minimum(spec.tau_max, effort))
