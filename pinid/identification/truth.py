"""Errors against a known truth: the JSON ``pinid simulate`` writes beside its recording (``run.truth.json``).

:func:`true_base` maps the truth's standard parameters to the base parameters of the model being
identified (its base map ``P``: ``x_true = P·θ_true``), so the truth fits whatever ``--terms`` the
identification uses: a parameter of a term the twin did not simulate (not in the truth's ``terms``,
e.g. motor friction on a twin without drives) is truly 0.  A truth of another robot (other joints, or
a parameter of a simulated term missing) is a SpecError.  :func:`_parameter_errors` gives the errors:
``|x − x_true|`` in the parameter's unit and ``100·|x − x_true| / |x_true|`` [%] where the truth is not 0.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence

import numpy as np

from pinid.checks import as_floats
from pinid.errors import SpecError
from pinid.io import as_path
from pinid.model.base import BaseParameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel, as_robot
from pinid.model.terms import as_terms, robot_layout


def read_truth(truth) -> tuple[dict, str]:
    """``(truth dict, its name for messages)`` from a dict or the path of a truth JSON."""
    if isinstance(truth, Mapping):
        return dict(truth), "truth"
    p = as_path(truth, "truth")
    try:
        d = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise SpecError(f"{p}: cannot read the truth JSON ({exc})") from None
    if not isinstance(d, dict):
        raise SpecError(f"{p}: not a truth JSON (expected an object, as pinid simulate writes)")
    return d, str(p)


def true_base(
    truth: Mapping | str | os.PathLike, model: RobotModel, terms: TermSelection, base: BaseParameters
) -> np.ndarray:
    """The true base parameters (in ``base.names``' order) from a truth of ``pinid simulate``."""
    model, terms = as_robot(model), as_terms(terms)
    if not isinstance(base, BaseParameters):
        raise SpecError(f"base: got {type(base).__name__}, expected pinid BaseParameters (pinid.model.base)")
    d, where = read_truth(truth)
    std = d.get("standard")
    if not (isinstance(std, Mapping) and isinstance(std.get("names"), list) and isinstance(std.get("values"), list)):
        raise SpecError(
            f"{where}: no 'standard' parameters (names and values); expected the truth JSON pinid simulate writes"
        )
    joints = d.get("joints")
    if isinstance(joints, list) and sorted(joints) != sorted(model.joint_names):
        raise SpecError(
            f"{where}: the truth is of robot {d.get('robot')!r} with joints {', '.join(map(str, joints))}; "
            f"the model identified ({model.name}) has joints {', '.join(model.joint_names)}; expected the truth "
            "of the recordings of this robot"
        )
    values = dict(zip(std["names"], std["values"]))
    simulated = set(d.get("terms") or [])
    names = base.standard_names
    n_inertial = len(names) - len(robot_layout(model, terms))
    term_of = [None] * n_inertial + [p.term.name for p in robot_layout(model, terms)]
    theta, missing = np.zeros(len(names)), []
    for i, n in enumerate(names):
        if values.get(n) is not None:
            theta[i] = float(values[n])
        elif term_of[i] is None or term_of[i] in simulated:  # a term the twin did not simulate is truly 0
            missing.append(n)
    if missing:
        raise SpecError(
            f"{where}: no true value for parameter(s) {', '.join(missing[:6])}"
            + (f" and {len(missing) - 6} more" if len(missing) > 6 else "")
            + f"; expected the truth of this robot ({model.name}) and these terms ({', '.join(terms.names) or 'none'})"
        )
    return base.from_standard(theta)


def _parameter_errors(x: np.ndarray, truth: np.ndarray, scale: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(|x − x_true| [the parameter's unit], 100·|x − x_true| / |x_true| [%], NaN where the truth is 0)``;
    the truth counts as 0 when ``|x_true| ≤ 1e-9·scale`` (``scale``: the natural magnitudes)."""
    x, truth, scale = (as_floats(v, k, finite=False) for k, v in (("x", x), ("truth", truth), ("scale", scale)))
    err = np.abs(x - truth)
    nonzero = np.abs(truth) > 1e-9 * scale
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(nonzero, 100.0 * err / np.abs(truth), np.nan)
    return err, rel


def truth_error(x: np.ndarray, truth: np.ndarray, scale: np.ndarray, names: list[str]) -> dict:
    """A result's ``truth_error``: ``{"truth", "error", "error_percent"}``, each ``{name: value}`` (the
    relative error None where the truth is 0; see :func:`_parameter_errors`)."""
    err, rel = _parameter_errors(x, truth, scale)
    if isinstance(names, (str, bytes)) or not isinstance(names, Sequence):
        raise SpecError(f"names: got {type(names).__name__}, expected a list of parameter names")
    return {
        "truth": dict(zip(names, map(float, truth))),
        "error": dict(zip(names, map(float, err))),
        "error_percent": {n: (float(v) if np.isfinite(v) else None) for n, v in zip(names, rel)},
    }
