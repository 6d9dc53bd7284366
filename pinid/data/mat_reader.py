"""The MATLAB reader: ``.mat`` files as a lab saves them, v5 / v7 (SciPy) and v7.3 (HDF5, with h5py).

Registered in :mod:`pinid.data.registry` as ``mat`` (suffix ``.mat``).  A mapping spec names a **variable**
as its ``column`` and, for a variable holding several signals (a 26 × N matrix of joint positions), the signal
with ``index`` (0-based)::

    time = { column = "estimatorJointsTime", rebase = true }
    [joints.l_knee]
    q = { column = "estimatorJointsPos", index = 17 }

Signals may lie in rows or in columns: the axis whose length is the number of samples (the length of the
time variable) is the samples' axis, the other one the signals'.  A v7.3 file is HDF5 whose datasets hold
MATLAB's column-major arrays, so h5py shows them transposed; sizes in messages are MATLAB's (``size(x)``).
h5py is an optional dependency (``pip install 'pinid[mat]'``): reading a v7.3 file without it is one line
naming the extra.  One-line errors (DataError, exit 2 in the CLI) name the file and the variable: a variable
that is not there (with the closest name), that is not numeric (char, cell, struct), has more than two
dimensions, whose length differs from the time's, or holds several signals and no ``index`` is given.
"""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pinid.data.registry import Reader, Table, register_reader
from pinid.errors import DataError, SpecError

if TYPE_CHECKING:
    from pinid.data.mapping import SourceSpec

#: The first bytes of an HDF5 file (at offset 0, 512, 1024 … : MATLAB v7.3 puts it after a 512-byte user block).
HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: MATLAB classes that are numbers (a v7.3 dataset's ``MATLAB_class`` attribute).
NUMERIC_CLASSES = ("double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64")
#: The optional extra that reads v7.3 files.
EXTRA = "pip install 'pinid[mat]' (h5py)"


def mat_version(file: Path) -> str:
    """``"7.3"`` for an HDF5-based MAT file, ``"5"`` for a v5/v7 one (also v4, which has no header text)."""
    with open(file, "rb") as f:
        head = f.read(1032)
    if head[:19] == b"MATLAB 7.3 MAT-file" or HDF5_SIGNATURE in (head[:8], head[512:520], head[1024:1032]):
        return "7.3"
    return "5"


def _size(shape) -> str:
    return "×".join(str(int(n)) for n in shape)


class _Variables:
    """The top-level numeric variables of one MAT file, loaded on demand, in MATLAB's orientation."""

    def __init__(self, file: Path) -> None:
        self.file, self.version = file, mat_version(file)
        if self.version == "7.3":
            try:
                import h5py
            except ImportError:
                raise DataError(
                    f"{file}: a MATLAB v7.3 file (HDF5) needs h5py, which is not installed; expected {EXTRA}, "
                    "or the file saved as v7 (save(..., '-v7'))"
                ) from None
            try:
                self.h5 = h5py.File(file, "r")
            except OSError as exc:
                raise DataError(f"{file}: not a readable MATLAB v7.3 (HDF5) file ({exc})") from None
            self.names = [k for k in self.h5.keys() if not k.startswith("#")]
        else:
            from scipy.io import loadmat, whosmat

            self.h5, self._loadmat = None, loadmat
            try:
                self._whos = {name: (shape, cls) for name, shape, cls in whosmat(file)}
            except (ValueError, TypeError, OSError, NotImplementedError) as exc:
                raise DataError(f"{file}: not a readable MATLAB file ({str(exc).splitlines()[0]})") from None
            self.names = list(self._whos)
        self._cache: dict[str, np.ndarray] = {}

    def close(self) -> None:
        if self.h5 is not None:
            self.h5.close()

    def array(self, name: str, where: str) -> np.ndarray:
        """The variable as a float array of at most 2 dimensions, MATLAB's orientation; DataError otherwise."""
        if name in self._cache:
            return self._cache[name]
        if self.h5 is not None:
            import h5py

            node = self.h5[name]
            cls = node.attrs.get("MATLAB_class", b"")
            cls = cls.decode() if isinstance(cls, bytes) else str(cls)
            if not isinstance(node, h5py.Dataset) or cls not in (*NUMERIC_CLASSES, "logical"):
                what = "a sparse matrix" if "MATLAB_sparse" in node.attrs else f"a MATLAB {cls or 'object'}"
                raise DataError(f"{self.file}: variable '{name}' ({where}) is {what}, expected a numeric array")
            if node.attrs.get("MATLAB_empty", 0):
                raise DataError(f"{self.file}: variable '{name}' ({where}) is empty, expected a numeric array")
            a = np.asarray(node[()])
            if a.dtype.kind == "V":  # a compound (real, imag): complex
                raise DataError(f"{self.file}: variable '{name}' ({where}) is complex, expected real numbers")
            a = a.T  # HDF5 holds MATLAB's column-major array: transposed back to MATLAB's size
        else:
            cls = self._whos[name][1]
            if cls not in (*NUMERIC_CLASSES, "logical"):
                raise DataError(f"{self.file}: variable '{name}' ({where}) is a MATLAB {cls}, expected a numeric array")
            a = np.asarray(self._loadmat(self.file, variable_names=[name], squeeze_me=False)[name])
            if a.dtype.kind == "c":
                raise DataError(f"{self.file}: variable '{name}' ({where}) is complex, expected real numbers")
        if a.ndim > 2:
            raise DataError(
                f"{self.file}: variable '{name}' ({where}) has size {_size(a.shape)}, expected a vector or a matrix "
                "(signals in rows or columns)"
            )
        a = np.atleast_2d(a).astype(float, copy=False)
        self._cache[name] = a
        return a


def _samples_axis(a: np.ndarray, n: int, name: str, file: Path, where: str, time_name: str) -> int:
    """The axis of ``a`` (MATLAB size r × c) that runs over the ``n`` samples; DataError when none or both do."""
    r, c = a.shape
    along = [ax for ax, m in enumerate((r, c)) if m == n]
    if not along:
        raise DataError(
            f"{file}: variable '{name}' ({where}) has size {r}×{c}, but the time '{time_name}' has {n} samples; "
            f"expected {n} samples along its rows or its columns"
        )
    if len(along) == 2 and n > 1:
        raise DataError(
            f"{file}: variable '{name}' ({where}) has size {r}×{c}: {n} signals of {n} samples, so its samples' axis "
            "is ambiguous; expected a matrix with another number of signals than samples"
        )
    return along[0] if len(along) == 1 else 1


def _read_mat(file: Path, src: SourceSpec, wanted, origin: str) -> Table:
    mat = _Variables(file)
    try:
        names = mat.names
        tab = Table(file, names, {}, 0, None)
        tab.recognised = any(isinstance(c, str) and c in names for c, _, _ in wanted)
        for col, _index, where in wanted:
            if not isinstance(col, str):
                raise SpecError(
                    f"{origin}: {where} column {col}: a MATLAB file's variables have names, not column indices; "
                    f"expected a variable name and index = ... for its signal ({', '.join(names[:40])})"
                )
            if col not in names:
                close = difflib.get_close_matches(col, names, n=1)
                hint = f" (did you mean '{close[0]}'?)" if close else ""
                raise DataError(
                    f"{file}: variable '{col}' ({where.strip('[]')}) is not in the file{hint}; "
                    f"its variables: {', '.join(names[:40])}"
                )
        # the number of samples: the time variable's length, else the first vector's, else the longer axis
        time_col = None if src.time is None else src.time.column
        if isinstance(time_col, str):
            t = mat.array(time_col, "time")
            if 1 not in t.shape:
                raise DataError(
                    f"{file}: variable '{time_col}' (time) has size {_size(t.shape)}, expected a vector of time stamps "
                    "(1×N or N×1)"
                )
            n, time_name = t.size, time_col
        else:
            arrays = [mat.array(c, w) for c, _, w in wanted]
            vectors = [a.size for a in arrays if 1 in a.shape]
            n = vectors[0] if vectors else max(arrays[0].shape)
            time_name = f"rate {src.time.rate:g} Hz" if src.time is not None and src.time.rate else "time"
        for col, index, where in wanted:
            a = mat.array(col, where.strip("[]"))
            w = where.strip("[]")
            if a.size == n and 1 in a.shape:
                signals = a.reshape(1, n)
            else:
                ax = _samples_axis(a, n, col, file, w, time_name)
                signals = a if ax == 1 else a.T  # (signals, samples)
            k = signals.shape[0]
            if index is None:
                if k != 1:
                    raise DataError(
                        f"{file}: variable '{col}' ({w}) holds {k} signals of {n} samples (size {_size(a.shape)}); "
                        f"expected index = 0 … {k - 1} in the mapping spec to choose one"
                    )
                tab.data[(col, None)] = signals[0]
            else:
                if index >= k:
                    raise DataError(
                        f"{file}: variable '{col}' ({w}) holds {k} signal{'s' if k > 1 else ''} of {n} samples "
                        f"(size {_size(a.shape)}), so index = {index} is out of range; expected index 0 … {k - 1}"
                    )
                tab.data[(col, index)] = signals[index]
        tab.nrows = n
        return tab
    finally:
        mat.close()


def _mat_example(path: Path, names: list[str], data: np.ndarray) -> Path:
    """A v5 MAT file of dataset-format columns (for the reader contract suite)."""
    from scipy.io import savemat

    path = Path(path).with_suffix(".mat")
    savemat(path, {n: np.asarray(data[:, i], dtype=float).reshape(1, -1) for i, n in enumerate(names)})
    return path


register_reader(Reader("mat", _read_mat, suffixes=(".mat",), example=_mat_example))
