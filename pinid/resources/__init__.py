"""Files that ship with pinid: robot descriptions (``urdf/``) and excitation specs and designs
(``excitation/``).  The repository's top-level ``urdf/`` and ``excitation/`` are links to these folders,
so there is one copy, and a wheel carries it as package data."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

#: Folder of the URDFs that ship with pinid.
URDF_DIR = Path(str(resources.files(__name__) / "urdf"))
#: Folder of the bundled excitation specs and designed trajectories.
EXCITATION_DIR = Path(str(resources.files(__name__) / "excitation"))


def bundled_robots() -> list[str]:
    """Names of the robots whose URDF ships with pinid (``exo_leg``, …), sorted."""
    return sorted(f.stem for f in URDF_DIR.glob("*.urdf"))


def bundled_trajectories() -> list[str]:
    """Names of the designed trajectories that ship with pinid (``seed001_table3``, …), sorted."""
    return sorted(f.stem for f in EXCITATION_DIR.glob("*.json"))


def bundled_flex_specs() -> list[str]:
    """Names of the flexible-joint specs that ship with pinid (``tracker_flex_spec``, …), sorted."""
    return sorted(f.stem for f in EXCITATION_DIR.glob("*flex*.toml"))
