"""One colour per method in every figure (issue 33): every registered method's colour differs from every
other's, from the fallback colours and from the greys and black that draw the measurements."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from pinid.errors import SpecError
from pinid.estimators import ESTIMATORS
from pinid.optimizers import OPTIMIZERS
from pinid.report.colors import FALLBACK, method_color

#: What the figures draw measurements in (raw: light grey; low-passed: dark grey; lines: black).
MEASUREMENT = ("0.75", "0.3", "black", "white")


def _lab(colour: str) -> np.ndarray:
    """CIELAB (D65) of a matplotlib colour."""
    from matplotlib.colors import to_rgb

    rgb = np.array(to_rgb(colour))
    rgb = np.where(rgb > 0.04045, ((rgb + 0.055) / 1.055) ** 2.4, rgb / 12.92)
    m = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
    xyz = m @ rgb / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > 0.008856, np.cbrt(xyz), 7.787 * xyz + 16 / 116)
    return np.array([116 * f[1] - 16, 500 * (f[0] - f[1]), 200 * (f[1] - f[2])])


def _distance(a: str, b: str) -> float:
    return float(np.linalg.norm(_lab(a) - _lab(b)))


NAMES = sorted(set(ESTIMATORS) | set(OPTIMIZERS))


def test_every_registered_method_has_its_own_distinct_colour():
    colours = {n: method_color(n) for n in NAMES}
    assert all(ESTIMATORS[n].colour == colours[n] for n in NAMES if n in ESTIMATORS)  # the class's own
    assert len(set(colours.values())) == len(NAMES), colours
    close = [(a, b, round(_distance(colours[a], colours[b]), 1)) for a, b in itertools.combinations(NAMES, 2)]
    assert min(d for *_, d in close) >= 20, sorted(close, key=lambda x: x[2])[:3]
    for n, c in colours.items():  # never mistaken for a measurement
        assert min(_distance(c, g) for g in MEASUREMENT) >= 20, (n, c)


def test_fallback_is_fixed_by_the_name_and_never_a_registered_colour():
    registered = {method_color(n) for n in NAMES}
    for c in FALLBACK:
        assert min(_distance(c, r) for r in registered) >= 20, c
        assert min(_distance(c, g) for g in MEASUREMENT) >= 20, c
    assert method_color("my-method") == method_color("my-method") in FALLBACK
    assert method_color("OLS") == method_color("ols")  # the registry's spelling is case-blind
    with pytest.raises(SpecError, match="name"):
        method_color(3)
