"""The NPZ reader: an archive of named numpy arrays (``numpy.savez``), one per column.

Registered in :mod:`pinid.data.registry` as ``npz`` (suffix ``.npz``).  A 2-D array's column is chosen
with ``index`` in the mapping spec; every array's declared size is checked against the archive before it
is read.
"""

from __future__ import annotations

import zipfile
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pinid.data.registry import Reader, Table, register_reader
from pinid.errors import DataError, SpecError

if TYPE_CHECKING:
    from pinid.data.mapping import SourceSpec


def _open_npz(file: Path):
    """``np.load(file)`` of an NPZ archive; DataError naming the file if it is not one (a ``.npy`` file
    renamed ``.npz``, text, a damaged archive)."""
    if not zipfile.is_zipfile(file):
        with open(file, "rb") as f:
            npy = f.read(6) == b"\x93NUMPY"
        raise DataError(
            f"{file}: "
            + ("holds a single array (a .npy file)" if npy else "not an NPZ archive (not a zip file)")
            + ", expected an NPZ archive of named arrays (numpy.savez)"
        )
    try:
        npz = np.load(file, allow_pickle=False)
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise DataError(f"{file}: not a readable NPZ file ({exc})") from None
    if not hasattr(npz, "files"):
        raise DataError(f"{file}: holds a single array, expected an NPZ archive of named arrays")
    return npz


def _npz_array(npz, file: Path, col: str) -> np.ndarray:
    """The array ``col`` of an open NPZ archive, after checking that the size its header declares is what
    the archive holds (a header declaring 8 TB is refused before anything is allocated)."""
    member = col if col in npz.zip.namelist() else f"{col}.npy"
    try:
        info = npz.zip.getinfo(member)
        with npz.zip.open(member) as f:
            version = np.lib.format.read_magic(f)
            read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            shape, _, dtype = read(f, max_header_size=10000)
            header = f.tell()
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
        raise DataError(f"{file}: array '{col}' cannot be read ({str(exc).splitlines()[0]})") from None
    declared = int(np.prod(shape, dtype=object)) * dtype.itemsize
    if declared > info.file_size - header:
        raise DataError(
            f"{file}: array '{col}' declares shape {tuple(shape)} ({declared:,} bytes) but the archive holds "
            f"{max(info.file_size - header, 0):,} bytes of it; the file is damaged or not a recording"
        )
    try:
        return np.asarray(npz[col])
    except ValueError as exc:
        raise DataError(f"{file}: array '{col}' cannot be read ({exc})") from None


def _read_npz(file: Path, src: SourceSpec, wanted, origin: str) -> Table:
    npz = _open_npz(file)
    names = list(npz.files)
    tab = Table(file, names, {}, 0, None)
    tab.recognised = any(isinstance(c, str) and c in names for c, _, _ in wanted)
    lengths: dict[str, int] = {}
    with npz:
        for col, index, where in wanted:
            if isinstance(col, int):
                raise SpecError(
                    f"{origin}: {where} column {col}: NPZ arrays have names, not indices; "
                    + (f"expected one of {', '.join(names)}" if tab.recognised else "expected a name")
                )
            tab.key(col, where, origin)
            a = _npz_array(npz, file, col)
            if a.dtype.kind not in "fiub":
                raise DataError(f"{file}: array '{col}' has type {a.dtype}, expected numbers")
            if index is not None:
                if a.ndim != 2 or index >= a.shape[1]:
                    raise SpecError(
                        f"{origin}: {where} index {index}: array '{col}' has shape {a.shape}, "
                        "expected a 2-D (samples, columns) array with that column"
                    )
                a = a[:, index]
            elif a.ndim != 1:
                raise DataError(
                    f"{file}: array '{col}' has shape {a.shape}, expected one value per sample "
                    "(1-D); for a 2-D array give index = ... in the mapping spec"
                )
            tab.data[(col, index)] = a.astype(float, copy=False)  # float64 arrays as read: no copy
            lengths[f"{col}" + ("" if index is None else f"[:, {index}]")] = len(a)
    if len(set(lengths.values())) > 1:
        parts = ", ".join(f"'{k}' {v}" for k, v in lengths.items())
        raise DataError(f"{file}: columns of different lengths ({parts}), expected one value per sample in each")
    tab.nrows = next(iter(lengths.values())) if lengths else 0
    return tab


def _npz_columns(file: Path) -> list[str]:
    with _open_npz(file) as npz:
        return list(npz.files)


register_reader(Reader("npz", _read_npz, suffixes=(".npz",), columns=_npz_columns))
