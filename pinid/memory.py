"""How much memory a run needs, and what the machine has: refuse what cannot fit, warn near the limit.

The estimates are linear in the number of samples, with per-sample costs measured on this project
(docs/benchmarks.md, "Memory").  Available memory is the kernel's ``MemAvailable`` (Linux), else the
free physical pages; None when neither is known (then nothing is checked).
"""

from __future__ import annotations

import os
import warnings

from pinid.errors import DataWarning, SpecError

#: A run that needs more than this fraction of the available memory gets a one-line warning.
WARN_FRACTION = 0.5


def available_bytes() -> int | None:
    """Memory available to a new allocation [bytes] (``MemAvailable`` of /proc/meminfo), or None."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def human(n: float) -> str:
    """``n`` bytes as text: ``"3.5 GB"`` (powers of 1000)."""
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"  # pragma: no cover


def check_fits(needed: float, what: str, *, per_item: float | None = None, item: str = "sample") -> None:
    """SpecError (one line naming ``what``) if ``needed`` bytes exceed the available memory; a
    :class:`DataWarning` if they exceed :data:`WARN_FRACTION` of it."""
    available = available_bytes()
    if available is None:
        return
    each = f" ({human(per_item)} per {item})" if per_item else ""
    if needed > available:
        most = f"; expected at most about {int(available // per_item):,} {item}s" if per_item else ""
        raise SpecError(
            f"{what}: needs about {human(needed)} of memory{each}, more than the {human(available)} available{most}"
        )
    warn_if_large(needed, what, per_item=per_item, item=item, available=available)


def warn_if_large(
    needed: float, what: str, *, per_item: float | None = None, item: str = "sample", available: int | None = None
) -> bool:
    """Warn (one line) if ``needed`` bytes exceed :data:`WARN_FRACTION` of the available memory; True if so."""
    available = available_bytes() if available is None else available
    if available is None or needed <= WARN_FRACTION * available:
        return False
    each = f" ({human(per_item)} per {item})" if per_item else ""
    warnings.warn(
        DataWarning(
            f"{what}: needs about {human(needed)} of memory{each}, more than half of the "
            f"{human(available)} available; the run may be slow or killed by the system"
        ),
        stacklevel=3,
    )
    return True
