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
