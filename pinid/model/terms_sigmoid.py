"""Smooth sigmoid friction of Gaz et al. 2019 (Franka Emika Panda), per joint:

    τ_fsig,j = φ1_j / (1 + exp(−φ2_j·(dq_j + φ3_j))) − φ1_j / (1 + exp(−φ2_j·φ3_j))      [N·m]

The amplitude ``φ1`` is the linear parameter ``<joint>.fsig`` [N·m] (``--terms fc,fv,fsig``); the shape — the
steepness ``φ2`` [s/rad] > 0 and the velocity offset ``φ3`` [rad/s] — is the model setting ``"sigmoid"``
(like the Stribeck velocity of ``fs``), saved with the model: ``{"steepness": φ2, "offset": φ3}`` for every
joint, or ``{joint: {"steepness", "offset"}}``; default :data:`STEEPNESS`, :data:`OFFSET` (with φ3 = 0 the
column is ``tanh(φ2·dq/2)/2``, a smooth Coulomb step).  The value ``"auto"`` asks the training recordings to
fit the shape (:mod:`pinid.identification.sigmoid`, ``--sigmoid-shape auto``); until then the default is used.
The column is 0 at rest and smooth, so the twin's plant applies value × column.

Registered in :data:`pinid.model.terms.TERMS` when ``fsig`` is first asked for
(an entry point of the group ``pinid.terms``, pyproject.toml; :data:`pinid.model.terms.PLUGIN_TERMS`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pinid.errors import ModelError, SpecError
from pinid.model.terms import Motion, Term, register

#: The model setting that holds the sigmoid shape.
SETTING = "sigmoid"
#: Default steepness φ2 [s/rad] and velocity offset φ3 [rad/s].
STEEPNESS, OFFSET = 40.0, 0.0


def _shape(value, origin: str) -> dict[str, float]:
    """``{"steepness": φ2 > 0, "offset": φ3}`` of a saved shape; SpecError naming ``origin`` otherwise."""
    ok = isinstance(value, Mapping) and set(value) == {"steepness", "offset"}
    nums = [value[k] for k in ("steepness", "offset")] if ok else []
    ok = ok and all(not isinstance(v, bool) and isinstance(v, (int, float, np.number)) for v in nums)
    ok = ok and all(np.isfinite(v) for v in nums) and nums[0] > 0
    if not ok:
        raise SpecError(f"{origin}: {value!r}, expected {{'steepness': φ2 > 0 [s/rad], 'offset': φ3 [rad/s]}}")
    return {"steepness": float(nums[0]), "offset": float(nums[1])}


def read_shape(saved, origin: str) -> dict:
    """The sigmoid shape as given or saved: ``{"steepness", "offset"}`` for every joint, ``{joint: {…}}``, or
    ``"auto"`` (fitted by the training recordings); SpecError otherwise."""
    if not isinstance(origin, str):
        raise SpecError(f"origin: got {type(origin).__name__}, expected the name of the setting's place")
    if isinstance(saved, str) and saved.strip().lower() == "auto":
        return "auto"
    if isinstance(saved, Mapping) and saved and all(isinstance(v, Mapping) for v in saved.values()):
        return {str(k): _shape(v, f"{origin}: {k}") for k, v in saved.items()}
    return _shape(saved, origin)


def _write_shape(value):
    return read_shape(value, "sigmoid")


def shape_from_text(text: str, origin: str = "--sigmoid-shape") -> dict | str:
    """``"40,0"`` (φ2 [s/rad], φ3 [rad/s] for every joint), ``"A1=40:0.01,A2=60:0"`` or ``"auto"`` as
    :func:`read_shape` returns it; SpecError otherwise."""
    if not isinstance(text, str) or not isinstance(origin, str):
        raise SpecError(f"text: got {type(text).__name__}, expected a sigmoid shape 'PHI2,PHI3' or 'auto'")
    if text.strip().lower() == "auto":
        return "auto"

    def steep(a: float, where: str = "") -> float:
        if not a > 0:  # the likely slip: a sign on the wrong number ("-1,0" for "1,-0" or "40,-0.01")
            raise SpecError(
                f"{origin} {text!r}: steepness φ2{where} = {a:g} [s/rad], expected > 0 "
                "(the offset φ3, the second number, may be negative: 40,-0.01)"
            )
        return a

    try:
        if "=" not in text:
            a, b = (float(x) for x in text.split(","))
            return read_shape({"steepness": steep(a), "offset": b}, origin)
        out = {}
        for part in (p.strip() for p in text.split(",") if p.strip()):
            joint, _, pair = part.partition("=")
            a, b = (float(x) for x in pair.split(":"))
            out[joint.strip()] = {"steepness": steep(a, f" of {joint.strip()}"), "offset": b}
        return read_shape(out, origin)
    except SpecError:
        raise
    except ValueError:
        raise SpecError(
            f"{origin} {text!r}: expected PHI2,PHI3 (steepness > 0 [s/rad], offset [rad/s]; every joint), "
            "JOINT=PHI2:PHI3,… or auto"
        ) from None


def shapes(robot) -> np.ndarray:
    """``(nv, 2)`` steepness φ2 [s/rad] and offset φ3 [rad/s] of each joint: the model's ``"sigmoid"`` setting,
    the default (:data:`STEEPNESS`, :data:`OFFSET`) for a joint it does not name or while it is ``"auto"``."""
    if not (hasattr(robot, "joint_names") and hasattr(robot, "setting")):
        raise ModelError(f"robot: got {type(robot).__name__}, expected a pinid RobotModel")
    given = robot.setting(SETTING)
    names = list(robot.joint_names)
    out = np.tile([STEEPNESS, OFFSET], (len(names), 1))
    if given is None or (isinstance(given, str) and given.strip().lower() == "auto"):
        return out
    given = read_shape(given, "sigmoid")
    if set(given) == {"steepness", "offset"} and not isinstance(given["steepness"], Mapping):
        out[:] = [given["steepness"], given["offset"]]
        return out
    unknown = sorted(set(given) - set(names))
    if unknown:
        raise ModelError(f"sigmoid shape for {unknown}: not joints of {robot.name}, expected some of {names}")
    for j, name in enumerate(names):
        if name in given:
            out[j] = [given[name]["steepness"], given[name]["offset"]]
    return out


def sigmoid_column(dq: np.ndarray, steepness: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """``1/(1 + exp(−φ2·(dq + φ3))) − 1/(1 + exp(−φ2·φ3))`` (dq [rad/s], φ2 [s/rad], φ3 [rad/s]; broadcast):
    0 at rest, written with tanh (no overflow)."""
    for key, x in (("dq", dq), ("steepness", steepness), ("offset", offset)):
        if isinstance(x, bool) or not isinstance(x, (int, float, np.number, np.ndarray, list, tuple)):
            raise SpecError(f"{key}: got {type(x).__name__}, expected a number or an array")
    dq, a, b = (np.asarray(x, dtype=float) for x in (dq, steepness, offset))
    return 0.5 * (np.tanh(0.5 * a * (dq + b)) - np.tanh(0.5 * a * b))


def _column(m: Motion) -> np.ndarray:
    s = shapes(m.robot)
    return sigmoid_column(m.dq, s[:, 0], s[:, 1])


register(
    Term(
        "fsig",
        "fsig",
        "sigmoid friction (Gaz 2019)",
        "N·m",
        _column,
        nonnegative=True,
        setting=SETTING,
        read_setting=read_shape,
        write_setting=_write_shape,
    )
)
