"""One colour per method in every figure: :func:`method_color`.

A registered estimator declares its colour (:attr:`pinid.estimators.base.Estimator.colour`); every one
differs from the others and from the greys and black that draw measurements (tests/report/test_report_colors.py
checks a CIELAB distance of at least 20 between any two).  A method without a colour of its own (an
unregistered name, an estimator that declares none) gets one of :data:`FALLBACK`, chosen from its name
(CRC-32), so the same name has the same colour in every figure and every run.
"""

from __future__ import annotations

import zlib

from pinid.errors import SpecError

#: Colours for methods without their own, none of them a registered method's colour (tested).
FALLBACK = ("#ff9896", "#c5b0d5", "#637939", "#b5cf6b", "#ad494a", "#6baed6", "#fdae6b", "#1b9e77")


def method_color(name: str) -> str:
    """The colour (a matplotlib colour string) of method ``name`` in every figure: the registered
    estimator's own, else one of :data:`FALLBACK` chosen from the name."""
    if not isinstance(name, str):
        raise SpecError(f"name: got {type(name).__name__}, expected a method name")
    from pinid.estimators import ESTIMATORS

    cls = ESTIMATORS.get(name.strip().lower())
    if cls is not None and cls.colour:
        return cls.colour
    return FALLBACK[zlib.crc32(name.encode("utf-8")) % len(FALLBACK)]
