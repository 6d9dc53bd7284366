"""What a problem computes once from its rows and keeps with it (:class:`ProblemCache`)."""

from __future__ import annotations


class ProblemCache:
    """What is computed once from a problem's rows and kept with it: its Gram sums (``"gram"``), their
    compression (``"compressed"``), an estimator's own (``"lad"``: the metaheuristics' least-absolute-deviation
    start).  Each value is stored with the key of the data it was computed from (:meth:`put`) and returned
    only while the key is the same (:meth:`get`); :meth:`forget` drops values (e.g. to time a compression)."""

    def __init__(self) -> None:
        self._values: dict[str, tuple[object, object]] = {}

    def get(self, name: str, key: object = None) -> object | None:
        """The value kept under ``name`` for ``key``, else None."""
        kept = self._values.get(name)
        return kept[1] if kept is not None and kept[0] == key else None

    def put(self, name: str, value: object, key: object = None) -> object:
        """Keep ``value`` under ``name`` for ``key`` (replacing what was kept); returns ``value``."""
        self._values[name] = (key, value)
        return value

    def forget(self, *names: str) -> None:
        """Drop the values kept under ``names`` (every value when none is named)."""
        for name in names or tuple(self._values):
            self._values.pop(name, None)
