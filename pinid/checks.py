"""Checks of the arguments of pinid's public functions.

Every public function that takes arrays or numbers from a user runs them through these, so a wrong
shape, a string, None, NaN or an infinity is one :class:`~pinid.errors.PinidError` naming the argument
and what was expected — never a numpy, Pinocchio or Python error from deep inside.  Arrays are
:class:`~pinid.errors.DataError`, settings (counts, tolerances) :class:`~pinid.errors.SpecError`.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence

import numpy as np

from pinid.errors import DataError, SpecError


def as_floats(x, name: str, *, finite: bool = True) -> np.ndarray:
    """``x`` as a float array (of finite numbers unless ``finite`` is False); DataError naming ``name``
    for anything else."""
    if x is None or isinstance(x, (str, bytes, dict)):
        raise DataError(f"{name}: got {type(x).__name__}, expected an array of numbers")
    try:
        raw = np.asarray(x)
        numeric = raw.dtype.kind in "iuf" or (
            raw.dtype.kind == "O"
            and all(isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_)) for v in raw.reshape(-1))
        )
        a = raw.astype(float, copy=False) if numeric else None
    except (TypeError, ValueError):
        a = None
    if a is None:  # strings, booleans, None inside, ragged nesting, objects
        raise DataError(f"{name}: got {type(x).__name__} that is not an array of numbers, expected an array of numbers")
    if finite and a.size and not np.all(np.isfinite(a)):
        raise DataError(f"{name}: contains NaN or infinite values, expected finite numbers")
    return a


def as_vector(x, name: str, size: int, what: str = "values") -> np.ndarray:
    """``x`` as a finite (size,) float vector; DataError naming ``name`` and the expected size."""
    a = as_floats(x, name)
    if a.shape != (size,):
        raise DataError(f"{name}: shape {a.shape}, expected ({size},) {what}")
    return a


def as_state(x, name: str, joints: Sequence[str]) -> np.ndarray:
    """One sample ``(nv,)`` of joint values (q [rad or m], dq, ddq, tau …) for ``joints``."""
    return as_vector(x, name, len(joints), f"for joints {list(joints)}")


def as_states(x, name: str, joints: Sequence[str]) -> np.ndarray:
    """Samples ``(N, nv)`` of joint values for ``joints``; one sample ``(nv,)`` becomes ``(1, nv)``."""
    a = as_floats(x, name)
    if a.ndim == 1:
        a = a.reshape(1, -1)
    if a.ndim != 2 or a.shape[1] != len(joints) or a.shape[0] == 0:
        raise DataError(
            f"{name}: shape {np.shape(x)}, expected (N, {len(joints)}) or ({len(joints)},) for joints {list(joints)}"
        )
    return a


def same_length(**arrays: np.ndarray) -> None:
    """DataError unless every array has the same number of samples (first axis)."""
    lengths = {k: len(v) for k, v in arrays.items()}
    if len(set(lengths.values())) > 1:
        raise DataError(
            f"{', '.join(lengths)} have {', '.join(map(str, lengths.values()))} samples, expected the same number"
        )


def count(value, name: str, *, low: int = 0) -> int:
    """An integer ≥ ``low`` (bools and non-integral numbers refused); SpecError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not float(value).is_integer() or value < low:
        raise SpecError(f"{name}={value!r}, expected an integer ≥ {low}")
    return int(value)


def number(value, name: str, *, low: float | None = None, low_open: bool = False, high: float | None = None) -> float:
    """A finite number in the given range (``low_open``: strictly above ``low``); SpecError naming ``name``."""
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
    ok = ok and (low is None or (value > low if low_open else value >= low)) and (high is None or value <= high)
    if not ok:
        bounds = []
        if low is not None:
            bounds.append(f"{'>' if low_open else '≥'} {low:g}")
        if high is not None:
            bounds.append(f"≤ {high:g}")
        raise SpecError(f"{name}={value!r}, expected a finite number{' ' + ' and '.join(bounds) if bounds else ''}")
    return float(value)


def of_type(value, kind: type | tuple, name: str, expected: str, *, none: bool = True):
    """``value`` unchanged if it is a ``kind`` (a bool is not a number) or, with ``none``, None; SpecError
    ``"<name>: got <its type>, expected <expected>"`` otherwise (an option group's fields, e.g. ``name``
    "WearerLoad torque")."""
    if (value is None and none) or (isinstance(value, kind) and not isinstance(value, bool)):
        return value
    raise SpecError(f"{name}: got {type(value).__name__}, expected {expected}")


def option_numbers(options, where: str) -> None:
    """Check the numeric fields of the options dataclass ``options`` (annotated ``int`` or ``float``, maybe
    ``| None``): each must hold a finite number (an integer for ``int``); SpecError naming ``where`` and the
    option (``--option w_min=abc`` or ``nan`` fails here, not deep inside the optimiser)."""
    import dataclasses

    for f in dataclasses.fields(options):
        kind = (f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))).replace(" ", "")
        optional = kind.endswith("|None")
        kind = kind.removesuffix("|None")
        if kind not in ("int", "float"):
            continue
        v = getattr(options, f.name)
        if v is None and optional:
            continue
        if (
            isinstance(v, bool)
            or not isinstance(v, numbers.Real)
            or not math.isfinite(v)
            or (kind == "int" and not float(v).is_integer())
        ):
            raise SpecError(
                f"{where}: option {f.name}={v!r}, expected {'an integer' if kind == 'int' else 'a finite number'}"
                + (" or none" if optional else "")
            )


__all__ = [
    "array_like",
    "as_floats",
    "as_state",
    "as_states",
    "as_vector",
    "count",
    "number",
    "of_type",
    "option_numbers",
    "same_length",
]


def array_like(x, name: str):
    """``x`` unchanged if it can be an array of numbers (an ndarray, a list or tuple, a real number, or
    anything with ``__array__``); DataError naming ``name`` otherwise (None, text, bytes, a dict or set,
    a complex number, an object).  Cheap (no copy, no scan): for functions on a hot path."""
    if isinstance(x, (np.ndarray, list, tuple)) or (isinstance(x, numbers.Real) and not isinstance(x, bool)):
        return x
    if hasattr(x, "__array__") and not isinstance(x, (str, bytes, dict, set, numbers.Complex)):
        return x
    raise DataError(f"{name}: got {type(x).__name__}, expected an array of numbers")
