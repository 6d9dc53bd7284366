"""Progress bars for long work (tqdm: well kept, handles terminals, pipes and notebooks).

Shown on stderr when it is a terminal; silent in CI and pipes unless ``PINID_PROGRESS=1``.
"""

from __future__ import annotations

import os
import sys


def progress(total: int, desc: str, *, enabled: bool | None = None):
    """A tqdm bar of ``total`` steps (use ``.update(n)`` and ``.close()``, or as a context manager)."""
    from tqdm.auto import tqdm

    if enabled is None:
        enabled = os.environ.get("PINID_PROGRESS") == "1" or (sys.stderr.isatty() and not os.environ.get("CI"))
    return tqdm(total=total, desc=desc, disable=not enabled, leave=False, dynamic_ncols=True, file=sys.stderr)
