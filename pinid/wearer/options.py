"""The options of stage 2 of the wearer workflow (:func:`pinid.wearer.stage.identify_wearer`), in one group."""

from __future__ import annotations

import numbers
from dataclasses import dataclass
from typing import Any

from pinid.errors import SpecError
from pinid.wearer.prior import MASS_RANGE


@dataclass(frozen=True)
class WearerOptions:
    """How stage 2 fits the wearer (:mod:`pinid.wearer.stage`): ``passive`` (also the scale factors ``kp`` of
    the passive joint moments), ``mass_range`` ρ (each segment's mass within ±ρ of its table's, a fraction in
    (0, 1)), ``prior_weight`` λ (a number ≥ 0, or ``"auto"``: blocked cross-validation), ``passive_exponents``
    (first fit the passive moments' exponents, :mod:`pinid.wearer.exponents`), ``rest_velocity`` (leave out
    each joint's rows slower than it [rad/s]: "auto", a number or one per joint; None keeps every row) and the
    conic ``solver``.  A wrong type: SpecError (one line); the values are checked where they are used."""

    passive: bool = True
    mass_range: float = MASS_RANGE
    prior_weight: float | str = "auto"
    passive_exponents: bool = False
    rest_velocity: Any = None
    solver: str = "CLARABEL"

    def __post_init__(self) -> None:
        for key in ("passive", "passive_exponents"):
            if not isinstance(getattr(self, key), bool):
                raise SpecError(f"WearerOptions {key}: got {type(getattr(self, key)).__name__}, expected True or False")
        if isinstance(self.mass_range, bool) or not isinstance(self.mass_range, numbers.Real):
            raise SpecError(f"WearerOptions mass_range: got {type(self.mass_range).__name__}, expected a number")
        weight = self.prior_weight
        if weight != "auto" and (isinstance(weight, bool) or not isinstance(weight, numbers.Real)):
            raise SpecError(f"WearerOptions prior_weight: got {weight!r}, expected a number ≥ 0 or 'auto'")
        if not isinstance(self.solver, str):
            raise SpecError(f"WearerOptions solver: got {type(self.solver).__name__}, expected a solver's name")


def as_wearer_options(value: WearerOptions | None) -> WearerOptions:
    """``value`` as :class:`WearerOptions` (None: the defaults); SpecError for anything else."""
    if value is None:
        return WearerOptions()
    if not isinstance(value, WearerOptions):
        raise SpecError(f"options: got {type(value).__name__}, expected WearerOptions (pinid.wearer.options)")
    return value


__all__ = ["WearerOptions", "as_wearer_options"]
