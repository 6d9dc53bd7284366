"""The one protocol every result object follows (after python-control's response objects):

* ``to_dict() -> dict`` (plain JSON types) and the classmethod ``from_dict(d)``, its inverse;
* ``save(path) -> Path`` (JSON, written atomically) and the classmethod ``load(path)``, given here once
  on top of the two;
* ``text() -> str``: the human-readable table the command line prints;
* ``plot(kind=None, ax=None) -> Figure``: ``kind`` one of the class's :attr:`~ResultProtocol.PLOTS`
  (None: the first, the main figure); ``ax``: an existing matplotlib Axes to draw into, for a kind of one
  panel only.  An unknown kind, or ``ax`` for a kind of several panels, is a SpecError.

A class writes ``to_dict``, ``from_dict``, ``text``, ``PLOTS`` and ``_plot(kind, ax)``; the mixin
:class:`ResultProtocol` gives ``save``, ``load`` and the checks of ``plot``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any, ClassVar

from pinid.errors import SpecError
from pinid.io import read_json, write_json


class ResultProtocol:
    """Mixin of a result class: ``save``/``load`` from ``to_dict``/``from_dict``, and ``plot``'s checks.

    ``PLOTS``: ``{kind: True when the figure is one panel (ax accepted)}``, the main kind first.  A kind may
    carry an argument after a colon (``"torque:sdp"``) when the class lists the bare kind in
    ``PLOT_ARGUMENTS``."""

    PLOTS: ClassVar[dict[str, bool]] = {}
    #: Kinds that take an argument after a colon (``"torque:sdp"``: the torque of method sdp).
    PLOT_ARGUMENTS: ClassVar[tuple[str, ...]] = ()
    #: What :meth:`load` names in its errors (default the class name).
    FILE_KIND: ClassVar[str] = ""

    def to_dict(self) -> dict:  # pragma: no cover - every class writes its own
        raise NotImplementedError

    @classmethod
    def from_dict(cls, d: dict):  # pragma: no cover - every class writes its own
        raise NotImplementedError

    def text(self) -> str:  # pragma: no cover - every class writes its own
        raise NotImplementedError

    def save(self, path: str | os.PathLike) -> Path:
        """Write :meth:`to_dict` as JSON (atomically); returns the path."""
        return write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | os.PathLike):
        """Read a JSON file written by :meth:`save`; SpecError naming the file when it is not one."""
        d = read_json(path, cls.FILE_KIND or cls.__name__)
        try:
            return cls.from_dict(d)
        except SpecError as exc:
            raise SpecError(f"{path}: {exc}") from None
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise SpecError(f"{path}: not a {cls.FILE_KIND or cls.__name__} ({type(exc).__name__}: {exc})") from None

    def plot(self, kind: str | None = None, ax: Any = None):
        """The figure ``kind`` (None: the main one; :attr:`PLOTS` lists them), drawn into ``ax`` when given
        (one-panel kinds only).  Returns the matplotlib Figure (never shown; matplotlib loads on use)."""
        kind = plot_kind(type(self), kind, ax)
        return self._plot(kind, ax)

    def _plot(self, kind: str, ax: Any):  # pragma: no cover - every class writes its own
        raise NotImplementedError


def plot_kind(cls: type, kind: str | None, ax: Any) -> str:
    """``kind`` checked against ``cls.PLOTS`` (None: the first); SpecError for an unknown kind or for ``ax``
    with a kind of several panels."""
    if not isinstance(cls, type) or not getattr(cls, "PLOTS", None):
        raise SpecError(f"cls: got {cls!r}, expected a result class with PLOTS")
    kinds = dict(cls.PLOTS)
    if kind is None:
        kind = next(iter(kinds))
    if not isinstance(kind, str):
        raise SpecError(f"kind: got {type(kind).__name__}, expected a string (one of {', '.join(map(repr, kinds))})")
    bare = kind.split(":", 1)[0] if kind.split(":", 1)[0] in cls.PLOT_ARGUMENTS else kind
    if bare not in kinds:
        listed = ", ".join(map(repr, kinds)) + "".join(f", '{k}:…'" for k in cls.PLOT_ARGUMENTS)
        raise SpecError(f"kind: got {kind!r}, expected one of {listed}")
    if ax is not None:
        if not kinds[bare]:
            raise SpecError(f"kind {kind!r} needs its own figure (several panels); plot it without ax")
        if not hasattr(ax, "figure") or not hasattr(ax, "plot"):
            raise SpecError(f"ax: got {type(ax).__name__}, expected a matplotlib Axes")
    return kind


def panel(ax: Any = None, figsize: tuple[float, float] = (6.0, 3.5)):
    """``(figure, axes)``: ``ax`` and its figure, or a new figure of one panel (matplotlib loads here)."""
    if ax is not None:
        if not hasattr(ax, "figure") or not hasattr(ax, "plot"):
            raise SpecError(f"ax: got {type(ax).__name__}, expected a matplotlib Axes")
        return ax.figure, ax
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=figsize)
    return fig, ax
