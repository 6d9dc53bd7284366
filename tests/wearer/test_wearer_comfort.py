"""Comfort limits: the shipped defaults, the intersection with the URDF's limits, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli
from pinid.errors import SpecError
from pinid.excitation.spec import default_spec
from pinid.wearer import comfort


def test_default_file_has_hip_knee_ankle():
    c = comfort.read_limits()
    assert set(c) == {"hip", "knee", "ankle"}
    assert c["knee"]["min"] >= 0 and c["hip"]["max"] <= 120  # inside the normal range of motion (AAOS)
    assert "Source" in comfort.default_path().read_text() or "Sources" in comfort.default_path().read_text()


def test_design_limits_are_the_intersection(exo):
    spec = default_spec(exo)
    s = comfort.within_comfort(spec, exo)
    c = comfort.read_limits()
    # exo_leg: hip flexion positive (s = +1), knee flexion negative (s = −1)
    assert s.q_min[0] == max(spec.q_min[0], math.radians(c["hip"]["min"]))
    assert s.q_max[0] == min(spec.q_max[0], math.radians(c["hip"]["max"]))
    assert s.q_min[1] == max(spec.q_min[1], -math.radians(c["knee"]["max"]))
    assert s.q_max[1] == min(spec.q_max[1], -math.radians(c["knee"]["min"]))
    np.testing.assert_array_less(s.dq_max, math.radians(60.0) + 1e-12)
    assert np.all((s.q_min < s.q0) & (s.q0 < s.q_max))
    s.validate(exo)


def test_comfort_outside_urdf_limits(exo, tmp_path):
    f = tmp_path / "c.toml"
    f.write_text("[knee]\nmin = 100.0\nmax = 150.0\nspeed = 30.0\nacceleration = 100.0\n")
    with pytest.raises(SpecError, match="knee comfort range"):
        comfort.within_comfort(default_spec(exo), exo, f)
    out = tmp_path / "x.json"
    assert_clean_error(
        run_cli("excite", "--urdf", "exo_leg", "--comfort", str(f), "-o", str(out)),
        "comfort range",
        "outside its limits",
    )
    f.write_text("[knee]\nmin = 10.0\nmax = 5.0\nspeed = 30.0\nacceleration = 100.0\n")
    assert_clean_error(run_cli("excite", "--urdf", "exo_leg", "--comfort", str(f), "-o", str(out)), "min < max")
    assert not out.exists()
