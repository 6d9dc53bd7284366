"""A robot model and its joint terms as a plain dict (saved with every result), and back.

The dict holds the URDF text, so a saved result rebuilds its model without the original file.
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

from pinid.errors import ModelError, ModelWarning, SpecError
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.model.terms import TERMS, Term
from pinid.model.robot import as_robot


def _setting_terms() -> dict[str, Term]:
    """``{setting name: the first registered term that declares it}`` (:attr:`pinid.model.terms.Term.setting`;
    several terms may share one setting, e.g. fs and motor_fs read "stribeck"), the settings of the plug-in
    terms (:data:`pinid.model.terms.PLUGIN_TERMS`, entry points: :mod:`pinid.plugins`) last: the order of the keys of a saved robot.  Loads the
    plug-in terms."""
    out: dict[str, Term] = {}
    terms = list(TERMS.values())  # loads the plug-in terms: a setting may be one of theirs
    for term in sorted(terms, key=lambda t: TERMS.plugin(t.name)):  # stable: registry order otherwise
        if term.setting is not None:
            out.setdefault(term.setting, term)
    return out


def robot_to_dict(model: RobotModel, terms: TermSelection) -> dict:
    """``{"name", "urdf", "joints", "locked", "terms", "urdf_text", "drives"}`` of a model and its terms, and
    each term setting the model sets, saved by the term that declares it (``Term.write_setting``): e.g.
    ``"stribeck"`` ``{term: {"velocity", "shape"}}``, ``"passive_exponents"`` ``{anatomical joint: (terms, 4)
    list}``; ``"base": "floating"`` for a floating-base robot."""
    model = as_robot(model)
    saved = {}
    for name, term in _setting_terms().items():
        value = model.setting(name)
        if value is not None:
            saved[name] = value if term.write_setting is None else term.write_setting(value)
    return {
        "name": model.name,
        "urdf": None if model.urdf_path is None else str(model.urdf_path),
        "joints": model.joint_names,
        "locked": dict(model.locked),
        "terms": terms.names,
        "urdf_text": model.urdf_text,
        "drives": None if model.drives is None else model.drives.to_dict(),
        **saved,
        **({"base": "floating"} if getattr(model, "base", "fixed") == "floating" else {}),
        **({"repair_inertia": True} if model.repair_inertia else {}),
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
    ):
        if key == "terms" and key not in d:
            raise SpecError("saved robot: no 'terms', expected a list of term names")
        if not isinstance(d.get(key), kinds):
            raise SpecError(f"saved robot: '{key}' is {type(d.get(key)).__name__}, expected {expected}")
    if d.get("base", "fixed") not in ("fixed", "floating"):
        raise SpecError(f"saved robot: 'base' is {d.get('base')!r}, expected 'fixed' or 'floating'")
    if not isinstance(d.get("repair_inertia", False), bool):
        raise SpecError(f"saved robot: 'repair_inertia' is {d.get('repair_inertia')!r}, expected true or false")
    base = d.get("base", "fixed")
    terms = TermSelection.from_names(list(d["terms"]))
    text = d.get("urdf_text")
    options = {"joints": d.get("joints"), "locked": d.get("locked") or {}, "base": base}
    options["repair_inertia"] = d.get("repair_inertia", False)
    with warnings.catch_warnings():  # the repair was reported when the model was identified
        warnings.simplefilter("ignore", ModelWarning)
        if text:
            with tempfile.TemporaryDirectory() as tmp:
                path = Path(tmp) / "robot.urdf"
                path.write_text(text, encoding="utf-8")
                try:
                    model = RobotModel.from_urdf(path, **options)
                except ModelError as exc:
                    raise ModelError(str(exc).replace(str(path), "the saved URDF text")) from None
            model = model.with_urdf_path(d["urdf"] if d.get("urdf") else None)
        elif d.get("urdf"):
            model = RobotModel.from_urdf(d["urdf"], **options)
        else:
            raise SpecError("saved result has no URDF (neither text nor path); cannot rebuild the robot model")
    if d.get("drives") is not None:
        from pinid.model.drives import Drives

        model = model.with_drives(Drives.from_dict(d["drives"], model.joint_names, "saved drives"))
    for name, term in _setting_terms().items():  # each saved setting, read by the term that declares it
        if d.get(name) is not None:
            value = d[name] if term.read_setting is None else term.read_setting(d[name], f"saved robot: '{name}'")
            model = model.with_setting(name, value)  # a new model (models are built once)
    return model, terms
