"""Registries that other modules and other packages extend: entry points, loaded when a name is asked for.

Each registry of pinid (terms, estimators, optimisers, readers) is a :class:`Registry`: a mapping from a name
to an entry.  An entry registers itself when its module is imported (a module of a lower layer never names
one of a higher layer).  An entry that nothing imports — a term of a module above the model (the wearer's
``passive``), a module loaded only when used (``ripple_s1``, ``fl``) or anything of another package — is an
*entry point* of the registry's group, declared in its package's ``pyproject.toml``::

    [project.entry-points."pinid.estimators"]
    mymethod = "mypkg.estimator:MyEstimator"   # an object: registered under the entry point's name
    [project.entry-points."pinid.terms"]
    backlash = "mypkg.terms"                    # a module: registers its terms itself when imported

Listing a registry's names imports nothing (an entry point's name is the name it registers); asking for a
declared name that is not registered yet loads its entry point, once.  pinid's own entry points are read
from the installed metadata and, when pinid runs from a source tree whose installed metadata is older
(an editable install before ``pip install -e .`` ran again), from the ``pyproject.toml`` beside the package:
the one fallback, so that a saved robot naming ``passive`` loads from a fresh checkout too.
"""

from __future__ import annotations

import functools
import importlib.metadata
import types
import warnings
from collections.abc import Callable, Iterator, Mapping, MutableMapping
from pathlib import Path

from pinid.errors import SpecError


class PluginWarning(UserWarning):
    """An entry point of another package failed to load; its name is left out of the registry's listing."""


#: The entry-point groups of pinid's registries.
GROUPS: tuple[str, ...] = ("pinid.terms", "pinid.estimators", "pinid.optimizers", "pinid.readers")

_SOURCE_TREE = Path(__file__).resolve().parents[1] / "pyproject.toml"


@functools.cache
def _source_tree_project() -> dict:
    """The ``[project]`` table of the ``pyproject.toml`` beside the package when it is pinid's (a source tree),
    else ``{}`` (an installed wheel: no such file, or another project's); read once."""
    from pinid.io import toml_loads

    try:
        project = toml_loads(_SOURCE_TREE.read_text(encoding="utf-8")).get("project", {})
    except (OSError, ValueError):
        return {}
    return project if project.get("name") == "pinid" else {}


def _source_tree_entry_points(group: str) -> list[importlib.metadata.EntryPoint]:
    """pinid's entry points of ``group`` in the ``pyproject.toml`` of the source tree pinid runs from."""
    table = _source_tree_project().get("entry-points", {}).get(group, {})
    return [importlib.metadata.EntryPoint(name, value, group) for name, value in table.items()]


def declared(group: str) -> dict[str, importlib.metadata.EntryPoint]:
    """``{name: entry point}`` of ``group`` (one of :data:`GROUPS`) in the installed packages' metadata,
    then pinid's source tree (a name declared twice: the first)."""
    if not isinstance(group, str) or group not in GROUPS:
        raise SpecError(f"group: got {group!r}, expected one of {list(GROUPS)}")
    out: dict[str, importlib.metadata.EntryPoint] = {}
    for ep in [*importlib.metadata.entry_points(group=group), *_source_tree_entry_points(group)]:
        out.setdefault(ep.name, ep)
    return out


def _origin(ep: importlib.metadata.EntryPoint) -> str:
    dist = getattr(ep, "dist", None)
    return f"entry point {ep.name} = {ep.value!r} of group {ep.group}" + (f" ({dist.name})" if dist else "")


class Registry(MutableMapping):
    """Entries by name, in registration order, extended by the entry points of ``group`` (see the module
    text).  ``adopt(name, obj)`` registers the object an entry point names (a module registers its own
    entries); it defaults to ``registry[name] = obj``.  ``reserve(name)`` keeps a place in the order for an
    entry registered later (the column order of the terms).  ``entries``: the package's own, in order."""

    def __init__(
        self,
        group: str,
        what: str,
        adopt: Callable[[str, object], None] | None = None,
        entries: Mapping[str, object] | None = None,
    ) -> None:
        if group not in GROUPS:
            raise SpecError(f"group: got {group!r}, expected one of {list(GROUPS)}")
        self.group, self.what = group, what
        self._adopt = adopt
        self._entries: dict[str, object | None] = {}  # None: a reserved place, not registered yet
        self._declared: dict[str, importlib.metadata.EntryPoint] | None = None
        self._tried: set[str] = set()
        self._reserved: set[str] = set()
        self._entries.update(entries or {})

    # -------------------------------------------------------------------------- entry points
    def entry_points(self) -> dict[str, importlib.metadata.EntryPoint]:
        """The entry points of this registry's group, read once (:meth:`refresh` reads them again); their
        names get a place at the end of the order."""
        if self._declared is None:
            self._declared = declared(self.group)
            for name in self._declared:
                self._entries.setdefault(name, None)
        return self._declared

    def refresh(self) -> None:
        """Forget the entry points read (a package installed since, or a test's fake ones): read again
        when next needed.  Reserved places whose entry is not registered are dropped, unless reserved
        by :meth:`reserve`."""
        self._declared = None
        self._tried.clear()
        for name in [n for n, e in self._entries.items() if e is None and n not in self._reserved]:
            del self._entries[name]

    def reserve(self, name: str) -> None:
        """Keep a place in the order for ``name``, registered later (by its entry point)."""
        if not isinstance(name, str):
            raise SpecError(f"name: got {type(name).__name__}, expected a {self.what} name")
        self._reserved.add(name)
        self._entries.setdefault(name, None)

    def plugin(self, name: str) -> bool:
        """True if ``name`` is an entry point's or a reserved place's (not registered with the package)."""
        return name in self._reserved or name in self.entry_points()

    def registered(self, name: str) -> bool:
        """True once ``name`` is registered (loads nothing)."""
        return self._entries.get(name) is not None

    def _load(self, name: str) -> None:
        """Load the entry point ``name`` once; SpecError naming it when it fails or registers no ``name``."""
        ep = self.entry_points().get(name)
        if ep is None or name in self._tried:
            return
        self._tried.add(name)
        try:
            obj = ep.load()
        except Exception as exc:  # noqa: BLE001 - any failure of a plug-in's import is reported the same way
            raise SpecError(f"{self.what} {name!r}: {_origin(ep)} failed to load: {type(exc).__name__}: {exc}") from exc
        if not isinstance(obj, types.ModuleType) and not self.registered(name):
            if self._adopt is not None:
                self._adopt(name, obj)
            else:
                self[name] = obj
        if not self.registered(name):
            raise SpecError(f"{self.what} {name!r}: {_origin(ep)} loaded but registered no {self.what} {name!r}")

    def load_all(self) -> None:
        """Load every entry point not loaded yet (a failing one: a warning, and its name is left out)."""
        for name in list(self.entry_points()):
            if not self.registered(name):
                try:
                    self._load(name)
                except SpecError as exc:
                    warnings.warn(str(exc), PluginWarning, stacklevel=2)

    # -------------------------------------------------------------------------- mapping
    def __getitem__(self, name: str):
        entry = self._entries.get(name)
        if entry is None:
            self._load(name)
            entry = self._entries.get(name)
        if entry is None:
            raise KeyError(name)
        return entry

    def __setitem__(self, name: str, entry) -> None:
        self._entries[name] = entry

    def __delitem__(self, name: str) -> None:
        del self._entries[name]

    def __iter__(self) -> Iterator[str]:
        self.entry_points()
        return iter([n for n, e in self._entries.items() if e is not None or n not in self._tried])

    def items(self):
        """``(name, entry)`` pairs, every entry point loaded first (:meth:`load_all`: a failing one left out)."""
        self.load_all()
        return super().items()

    def values(self):
        """The entries, every entry point loaded first (:meth:`load_all`: a failing one left out)."""
        self.load_all()
        return super().values()

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def __repr__(self) -> str:
        return f"<pinid registry {self.group}: {', '.join(self)}>"
