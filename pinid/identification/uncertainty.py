"""How well the data determine each base parameter, and the one-line warning when they do not.

The standard deviations (:func:`pinid.problem.statistics.base_statistics`) are the Newey–West sandwich of
least squares (:mod:`pinid.problem.covariance`), which holds for residuals correlated in time as those of
filtered recordings are; ``std_i = √Cov_ii`` and the relative standard deviation ``%σ_i = 100·std_i / |θ_i|``.
OLS uses unit weights, WLS its own final weights; the LMI method is scored at its own estimate, and a value
it holds on a bound (friction ≥ 0, a pseudo-inertia margin) gets no σ (NaN, printed "—"); the
metaheuristics get none at all.  A missing σ never counts as "poorly determined" here.

The warning (:func:`uncertainty_warning`) fires when

* ``cond(W_b) > COND_WARN`` (1e3): a designed excitation reaches 30–40 on the bundled robots (exo_leg 32,
  a UR5 design about the same), so 1e3 is some 30× worse than what `pinid excite` gets; and a
  relative torque error ε can become a relative parameter error up to cond·ε (1 % noise → up to 10×); or
* a parameter's ``%σ > STD_WARN_PERCENT`` (10 %): its 95 % interval is then wider than ±20 % of its value.

Issue 24's case: adding ``motor_fc,motor_fv,motor_armature`` (a plain reduction) to the exo_leg twin
takes cond(W_b) from 32 to 1.0e4 and the knee motor's rotor inertia to a %σ of 15 %.
"""

from __future__ import annotations

import numpy as np

from pinid.errors import SpecError

#: Condition number of the base regressor above which identify warns (see the module text).
COND_WARN = 1e3
#: Relative standard deviation [%] of a base parameter above which identify warns.
STD_WARN_PERCENT = 10.0


def _poorly_determined(std_percent: np.ndarray, names: list[str]) -> list[tuple[str, float]]:
    """``(name, %σ)`` of the parameters above :data:`STD_WARN_PERCENT`, the largest first."""
    sp = np.asarray(std_percent, dtype=float)
    bad = [(n, float(v)) for n, v in zip(names, sp) if v > STD_WARN_PERCENT]  # inf counts; NaN (no σ) does not
    return sorted(bad, key=lambda kv: -kv[1] if np.isfinite(kv[1]) else -np.inf)


def uncertainty_warning(result, terms: list[str] | None = None, urdf: str | None = None) -> str | None:
    """One line when ``result`` (an :class:`~pinid.identification.result.IdentificationResult`) is badly
    conditioned or has poorly determined parameters, naming them and what helps; None when it is fine.
    ``terms`` and ``urdf`` fill in the suggested ``pinid excite`` command."""
    if not all(hasattr(result, a) for a in ("method", "condition_number", "std_percent", "base_names")):
        raise SpecError(f"result: got {type(result).__name__}, expected a pinid IdentificationResult")
    parts = []
    cond = float(result.condition_number)
    if not cond <= COND_WARN:
        parts.append(f"cond(W_b) {cond:.3g} > 1e{int(np.log10(COND_WARN))}")
    bad = _poorly_determined(result.std_percent, result.base_names)
    if bad:
        shown = ", ".join(f"{n} {v:.3g} %" for n, v in bad[:3]) + (f" and {len(bad) - 3} more" if len(bad) > 3 else "")
        parts.append(f"relative std > {STD_WARN_PERCENT:g} %: {shown}")
    if not parts:
        return None
    cmd = f"pinid excite --urdf {urdf or 'URDF'}" + (f" --terms {','.join(terms)}" if terms else "")
    return (
        f"warning: {result.method}: poorly determined parameters ({'; '.join(parts)}); the data hardly tell them "
        f"apart: an excitation designed for these terms ({cmd}) or longer recordings help"
    )
