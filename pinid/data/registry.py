"""File formats as a registry: a :class:`Reader` or :class:`Writer` per format, chosen by suffix (or asked).

A reader turns one file (or folder) into named numeric columns (a :class:`Table`); the mapping spec
(:mod:`pinid.data.mapping`) then says which column is which joint's q, dq, ddq or tau, with units and
signs.  A writer stores pinid's dataset format (``t, q_<joint>, …``).  CSV and NPZ are registered by
:mod:`pinid.data.csv_reader` and :mod:`pinid.data.npz_reader` (readers) and :mod:`pinid.data.formats`
(writers); a new format is one module that calls :func:`register_reader` / :func:`register_writer` and
one import line in ``pinid/data/__init__.py`` (docs/extending.md); another package's reader is an entry point
of the group ``pinid.readers`` (a module that calls :func:`register_reader`, or a :class:`Reader`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from collections.abc import Callable

import numpy as np

from pinid.errors import DataError, SpecError
from pinid.io import as_path
from pinid.plugins import Registry


class Table:
    """Columns of one file, read once.

    ``names``: the file's column names (None for a headerless CSV: columns are 0-based indices);
    ``data``: ``{(column, index): 1-D float array}`` for every requested column (``index`` selects a
    column of a 2-D array, else None); ``nrows``: samples; ``line0``: the file line of the first sample
    (for messages; None when lines mean nothing, as in NPZ); ``row0``: index of the first kept row.
    """

    def __init__(self, path: Path, names: list[str] | None, data: dict, nrows: int, line0: int | None) -> None:
        self.path, self.names, self.data, self.nrows, self.line0 = path, names, data, nrows, line0
        self.row0 = 0
        self.recognised = True  # False: none of the spec's column names is in the file, whose names are then not shown

    def key(self, column: str | int, where: str, origin: str) -> str | int:
        """``column`` checked against the file's columns (SpecError naming the closest one)."""
        import difflib

        if isinstance(column, int):
            if self.names is not None and column >= len(self.names):
                raise SpecError(
                    f"{origin}: {where} column {column} is out of range, {self.path.name} has "
                    f"{len(self.names)} columns (0-based index)"
                )
            return column
        if self.names is None or column not in self.names:
            if self.names is None:
                raise SpecError(
                    f"{origin}: {where} column {column!r}: {self.path.name} has no header "
                    "(header = false); give a 0-based index or name the columns with names = [...]"
                )
            if not self.recognised:
                raise SpecError(
                    f"{origin}: {where} column {column!r} is not in {self.path.name}, nor is any other "
                    "column the spec names; expected a recording with those columns (its contents are not shown)"
                )
            close = difflib.get_close_matches(column, self.names, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise SpecError(
                f"{origin}: {where} column {column!r} is not in {self.path.name}{hint}; "
                f"its columns: {', '.join(self.names[:40])}"
            )
        return column

    def values(self, ref, origin: str) -> np.ndarray:
        """The raw column of a mapping spec's column reference (``ref.column``, ``ref.index``)."""
        return self.data[(ref.column, ref.index)]


@dataclass(frozen=True)
class Reader:
    """A file format pinid reads.

    ``read(file, source, wanted, origin) -> Table``: read the ``wanted`` columns of ``file``
    (``source``: the mapping spec's :class:`~pinid.data.mapping.SourceSpec` of that file: delimiter,
    header, rows …; ``origin``: the spec's name, for messages).  ``columns(file) -> names``: the
    column names, for files in pinid's dataset format read without a mapping spec (None: this format
    always needs a spec).  ``suffixes``: claimed suffixes (lower case, with the dot); ``match(path)``:
    claims a path whatever its suffix (e.g. a ROS 2 bag folder); ``folder``: the recording is a folder.
    ``example(path, names, data) -> path``: for a format pinid does not write, makes a small file of
    dataset-format columns (``names``, ``data`` (samples, columns)) at ``path`` (or beside it, returned),
    so that the reader contract suite (tests/contracts/test_reader_contract.py) can read it back; a reader with a
    writer of the same name needs none.
    """

    name: str
    read: Callable[..., Table]
    suffixes: tuple[str, ...] = ()
    columns: Callable[[Path], list[str]] | None = None
    match: Callable[[Path], bool] | None = None
    folder: bool = False
    example: Callable[[Path, list[str], np.ndarray], Path] | None = None


@dataclass(frozen=True)
class Writer:
    """A format pinid writes recordings in: ``write(tmp_path, names, data, digits)`` with ``names`` the
    dataset-format column names and ``data`` (samples, columns) floats; the caller makes it atomic."""

    name: str
    write: Callable[[Path, list[str], np.ndarray, int], None]
    suffixes: tuple[str, ...] = ()


#: Readers by format name; other packages add theirs through entry points of the group ``pinid.readers``.
READERS: Registry = Registry("pinid.readers", "reader", adopt=lambda name, reader: register_reader(reader))
WRITERS: dict[str, Writer] = {}


def register_reader(reader: Reader) -> Reader:
    """Add (or replace) a reader; returns it."""
    if not isinstance(reader, Reader):
        raise SpecError(f"reader: got {type(reader).__name__}, expected a pinid.data.registry.Reader")
    READERS[reader.name] = reader
    return reader


def register_writer(writer: Writer) -> Writer:
    """Add (or replace) a writer; returns it."""
    if not isinstance(writer, Writer):
        raise SpecError(f"writer: got {type(writer).__name__}, expected a pinid.data.registry.Writer")
    WRITERS[writer.name] = writer
    return writer


def _suffixes(table: dict) -> str:
    return ", ".join(s for x in table.values() for s in x.suffixes)


def reader_for(file: Path, fmt: str = "auto") -> Reader:
    """The reader of ``file``: ``fmt`` by name, or (``"auto"``) the first whose ``match`` claims the path,
    else the one claiming its suffix.  DataError when none does; SpecError for an unknown ``fmt``."""
    file = as_path(file, "file", error=DataError)
    if fmt != "auto":
        if fmt not in READERS:
            raise SpecError(f"format = {fmt!r}, expected one of {', '.join(READERS)} or 'auto' (by suffix)")
        return READERS[fmt]
    for r in READERS.values():
        if r.match is not None and r.match(file):
            return r
    suffix = file.suffix.lower()
    for r in READERS.values():
        if suffix in r.suffixes:
            return r
    raise DataError(
        f"{file}: unknown file type '{file.suffix}', expected one of {_suffixes(READERS)}; "
        'or set format = "csv" in the mapping spec'
    )


def writer_for(path: Path) -> Writer:
    """The writer claiming ``path``'s suffix; DataError naming the suffixes pinid writes."""
    path = as_path(path, error=DataError)
    suffix = path.suffix.lower()
    for w in WRITERS.values():
        if suffix in w.suffixes:
            return w
    names = " or ".join(s for w in WRITERS.values() for s in w.suffixes)
    raise DataError(f"{path}: unknown suffix '{path.suffix}', expected {names} for a recording")
