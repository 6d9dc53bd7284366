"""What a problem computes once from its rows and keeps with it (:class:`ProblemCache`)."""

from __future__ import annotations

from pinid.errors import SpecError


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

    def entries(self) -> dict[str, tuple[object, object]]:
        """Every kept value with its key, ``{name: (key, value)}``: what a worker process sends back to be
        kept by the parent's cache (:meth:`keep`)."""
        return dict(self._values)

    def keep(self, entries: dict[str, tuple[object, object]]) -> None:
        """Keep the ``{name: (key, value)}`` of another cache's :meth:`entries` (replacing what was kept)."""
        if not isinstance(entries, dict):
            raise TypeError(f"entries: got {type(entries).__name__}, expected the dict of ProblemCache.entries")
        self._values.update(entries)

    def forget(self, *names: str) -> None:
        """Drop the values kept under ``names`` (every value when none is named)."""
        for name in names or tuple(self._values):
            self._values.pop(name, None)


def data_key(problem) -> tuple:
    """The key of a value computed from ``problem``'s rows: its ``source_key()`` where it has one (an
    :class:`~pinid.problem.problem.IdentificationProblem`: the same before and after its ``W`` is built, and in a
    forked worker), else the identities of its ``W``, ``tau`` and ``weights``."""
    key = getattr(problem, "source_key", None)
    if callable(key):
        return key()
    if not all(hasattr(problem, a) for a in ("W", "tau", "weights")):
        raise SpecError(f"problem: got {type(problem).__name__}, expected a problem (W, tau, weights)")
    return (id(problem.W), id(problem.tau), id(problem.weights))
