"""Errors raised by pinid.

Every error pinid raises on purpose derives from :class:`PinidError`; the subclasses also derive from
the builtin exception that fits, so ``except ValueError`` still works.  Messages are one line and name
what was wrong (file, column, joint) and what was expected.  The CLI prints them as one line on stderr
and exits with status 2.
"""

from __future__ import annotations


class PinidError(Exception):
    """Base class of every error pinid raises on purpose."""


class ModelError(PinidError, ValueError):
    """A URDF or robot model that cannot be used (missing, malformed, unsupported joint...)."""


class JointError(PinidError, KeyError):
    """A joint name that is not in the model."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it a plain line
        return str(self.args[0]) if self.args else ""


class DataError(PinidError, ValueError):
    """A recording or array that is missing, malformed or inconsistent."""


class SpecError(PinidError, ValueError):
    """A specification file (limits, mapping, bounds) that is malformed or infeasible."""


class SolverError(PinidError, RuntimeError):
    """An optimiser or solver that failed or returned an unusable result."""


class OutputError(PinidError, OSError):
    """An output path that cannot be written."""


class DataWarning(UserWarning):
    """A finding about a recording that does not stop the work (also kept in ``meta["warnings"]``)."""


class ModelWarning(UserWarning):
    """A finding about a robot model that does not stop the work (e.g. a repaired URDF inertia)."""
