"""Human segment inertia parameters from body mass, height and sex (de Leva 1996).

The table lives in ``pinid/resources/anthropometry/de_leva_1996.toml``: every value with its source.
Masses scale with body mass; lengths scale with stature (geometric similarity).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from importlib import resources

import numpy as np

from pinid.checks import number
from pinid.errors import SpecError
from pinid.io import toml_loads

#: Sexes the table distinguishes.
SEXES: tuple[str, ...] = ("male", "female")
#: Leg segments with a length (what can be strapped to an exoskeleton).
LEG_SEGMENTS: tuple[str, ...] = ("thigh", "shank", "foot")
#: Segments that can be strapped to an exoskeleton: the pelvis (de Leva's lower trunk) and the leg segments.
STRAPPED_SEGMENTS: tuple[str, ...] = ("pelvis", *LEG_SEGMENTS)


@cache
def table() -> dict:
    """The de Leva 1996 table as read from the shipped TOML file."""
    text = (resources.files("pinid.resources") / "anthropometry" / "de_leva_1996.toml").read_text(encoding="utf-8")
    return toml_loads(text)


@dataclass(frozen=True)
class Segment:
    """One human segment of a given person.

    ``mass`` [kg]; ``length`` [m] from the proximal to the distal endpoint; ``com`` [m] from the
    proximal endpoint along the segment; ``radii`` [m] of gyration about the sagittal, transverse and
    longitudinal axes through the centre of mass; ``source`` the table entry it came from.
    """

    name: str
    mass: float
    length: float
    com: float
    radii: tuple[float, float, float]
    source: str

    @property
    def inertia(self) -> np.ndarray:
        """Principal moments of inertia about the centre of mass [kg·m²]: sagittal, transverse, longitudinal."""
        return self.mass * np.square(self.radii)


def check_person(mass: float, height: float, sex: str) -> None:
    """Raise SpecError unless body mass [kg], height [m] and sex are inside the table's accepted range."""
    lim = table()["limits"]
    mass, height = number(mass, "mass"), number(height, "height")  # numbers, not "75" or True
    if not isinstance(sex, str) or sex not in SEXES:
        raise SpecError(f"sex {sex!r}: expected one of {', '.join(SEXES)}")
    lo, hi = lim["mass"]
    if not (np.isfinite(mass) and lo <= mass <= hi):
        raise SpecError(f"body mass {mass:g} kg: outside the anthropometric table's range [{lo:g}, {hi:g}] kg")
    lo, hi = lim["height"]
    if not (np.isfinite(height) and lo <= height <= hi):
        hint = ""
        if np.isfinite(height) and lo <= height / 100 <= hi:  # the likely slip: a stature in centimetres
            hint = f"; in centimetres? {height:g} cm is {height / 100:g} m (--height {height / 100:g})"
        elif np.isfinite(height) and lo <= height / 1000 <= hi:
            hint = f"; in millimetres? {height:g} mm is {height / 1000:g} m (--height {height / 1000:g})"
        raise SpecError(f"height {height:g} m: outside the anthropometric table's range [{lo:g}, {hi:g}] m{hint}")


def segment(name: str, *, mass: float, height: float, sex: str) -> Segment:
    """The segment ``name`` (pelvis, thigh, shank, foot) of a person of ``mass`` [kg], ``height`` [m], ``sex``."""
    check_person(mass, height, sex)
    rows = table()[sex]
    if not isinstance(name, str) or name not in STRAPPED_SEGMENTS:
        raise SpecError(f"segment {name!r}: expected one of {', '.join(STRAPPED_SEGMENTS)}")
    row = rows[name]
    length = row["length"] * height / table()["reference"][sex]["stature"]
    radii = tuple(float(row[k]) * length for k in ("r_sagittal", "r_transverse", "r_longitudinal"))
    return Segment(name, row["mass_fraction"] * mass, length, row["com"] * length, radii, row["source"])
