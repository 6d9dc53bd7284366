"""A robot model and its joint terms as a plain dict (saved with every result), and back.

The dict holds the URDF text, so a saved result rebuilds its model without the original file.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from pinid.errors import SpecError
from pinid.model.regressor import TermSelection
from pinid.model.robot import RobotModel
from pinid.model.terms import STRIBECK_TERMS, TERMS, Stribeck
from pinid.model.robot import as_robot


def robot_to_dict(model: RobotModel, terms: TermSelection) -> dict:
    """``{"name", "urdf", "joints", "locked", "terms", "urdf_text", "drives"}`` of a model and its terms, and
    ``"stribeck"`` ``{term: {"velocity", "shape"}}`` when the model sets Stribeck shapes, ``"passive_exponents"``
    ``{anatomical joint: (terms, 4) list}`` when it sets the wearer's passive-moment exponents, ``"base": "floating"``
    for a floating-base robot."""
    model = as_robot(model)
    return {
        "name": model.name,
        "urdf": None if model.urdf_path is None else str(model.urdf_path),
        "joints": model.joint_names,
        "locked": dict(model.locked),
        "terms": terms.names,
        "urdf_text": model.urdf_text,
        "drives": None if model.drives is None else model.drives.to_dict(),
        **(
            {"stribeck": {k: {"velocity": s.velocity, "shape": s.shape} for k, s in model.stribeck.items()}}
            if model.stribeck
            else {}
        ),
        **(
            {"passive_exponents": {k: np.asarray(c).tolist() for k, c in model.passive_exponents.items()}}
            if model.passive_exponents
            else {}
        ),
        **({"base": "floating"} if getattr(model, "base", "fixed") == "floating" else {}),
    }


def robot_from_dict(d: dict) -> tuple[RobotModel, TermSelection]:
    """Inverse of :func:`robot_to_dict` (from the URDF text when present, else the URDF path); SpecError
    naming the field that is missing or of the wrong type."""
    if not isinstance(d, dict):
        raise SpecError(f"saved robot: 'robot' is {type(d).__name__}, expected a JSON object")
    for key, kinds, expected in (
        ("terms", (list,), "a list of term names"),
        ("joints", (list, type(None)), "a list of joint names or null"),
        ("locked", (dict, type(None)), "an object JOINT: value or null"),
        ("urdf_text", (str, type(None)), "the URDF text or null"),
        ("urdf", (str, type(None)), "a URDF path or null"),
        ("drives", (dict, type(None)), "an object or null"),
        ("stribeck", (dict, type(None)), "an object TERM: {velocity, shape} or null"),
        ("passive_exponents", (dict, type(None)), "an object JOINT: exponent rows or null"),
    ):
        if key == "terms" and key not in d:
            raise SpecError("saved robot: no 'terms', expected a list of term names")
        if not isinstance(d.get(key), kinds):
            raise SpecError(f"saved robot: '{key}' is {type(d.get(key)).__name__}, expected {expected}")
    if d.get("base", "fixed") not in ("fixed", "floating"):
        raise SpecError(f"saved robot: 'base' is {d.get('base')!r}, expected 'fixed' or 'floating'")
    base = d.get("base", "fixed")
    terms = TermSelection.from_names(list(d["terms"]))
    text = d.get("urdf_text")
    if text:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "robot.urdf"
            path.write_text(text, encoding="utf-8")
            model = RobotModel.from_urdf(path, joints=d.get("joints"), locked=d.get("locked") or {}, base=base)
        model = model.with_urdf_path(d["urdf"] if d.get("urdf") else None)
    elif d.get("urdf"):
        model = RobotModel.from_urdf(d["urdf"], joints=d.get("joints"), locked=d.get("locked") or {}, base=base)
    else:
        raise SpecError("saved result has no URDF (neither text nor path); cannot rebuild the robot model")
    if d.get("drives") is not None:
        from pinid.model.drives import Drives

        model = model.with_drives(Drives.from_dict(d["drives"], model.joint_names, "saved drives"))
    model = model.with_stribeck(stribeck_from_dict(d.get("stribeck") or {}, "saved robot: 'stribeck'"))
    for term in TERMS.values():  # loads the plug-in terms: a saved setting may be one of theirs
        if term.setting is not None and d.get(term.setting):
            # the model's with_<setting> gives a new model with it (models are built once)
            model = getattr(model, f"with_{term.setting}")(
                term.read_setting(d[term.setting], f"saved robot: '{term.setting}'")
            )
    return model, terms


def stribeck_from_dict(d: dict, origin: str) -> dict[str, Stribeck]:
    """``{term: Stribeck}`` from ``{term: {"velocity": v, "shape": δ}}``; SpecError naming what is wrong."""
    if not isinstance(d, dict):
        raise SpecError(f"d: got {type(d).__name__}, expected a table of Stribeck terms")
    out = {}
    for name, v in d.items():
        if name not in STRIBECK_TERMS or not isinstance(v, dict) or set(v) - {"velocity", "shape"}:
            raise SpecError(
                f"{origin}: {name!r}: {v!r}, expected one of {list(STRIBECK_TERMS)}: "
                "{velocity: number > 0, shape: number > 0}"
            )
        try:
            out[name] = Stribeck(**v)
        except SpecError as exc:
            raise SpecError(f"{origin}: {name}: {exc}") from None
    return out
