"""The CSV reader: delimited text with or without a header line (CSV, TSV, whitespace-separated columns).

Registered in :mod:`pinid.data.registry` as ``csv`` (suffixes ``.csv .txt .tsv .dat`` and none).  The
delimiter is the mapping spec's or guessed from the first data line (``,`` ``;`` tab, else spaces); a
first line of numbers is data, not a header.  Failures name the file, the line and the column.
"""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pinid.data.registry import Reader, Table, register_reader
from pinid.errors import DataError, SpecError

if TYPE_CHECKING:
    from pinid.data.mapping import SourceSpec

#: A number as text (also "nan", "inf", quoted): a first line of these is data, not a header.
FLOAT_RE = re.compile(r"^[\s\"']*[-+]?(\d+\.?\d*([eE][-+]?\d+)?|\.\d+([eE][-+]?\d+)?|nan|inf|infinity)[\s\"']*$", re.I)


def _split(line: str, delimiter: str | None) -> list[str]:
    return line.split() if delimiter is None else line.split(delimiter)


def _read_csv(file: Path, src: SourceSpec, wanted, origin: str) -> Table:
    with open(file, "rb") as fb:
        head = fb.read(65536)
    if b"\x00" in head:
        raise DataError(f"{file}: binary file, expected CSV text (or an .npz file)")
    try:
        f = open(file, encoding="utf-8-sig", newline="")
        lines_consumed = 0
        header_names = None
        first_data = None
        with f:
            for _ in range(src.skip_rows):
                if not f.readline():
                    break
                lines_consumed += 1
            while True:
                line = f.readline()
                if not line:
                    break
                stripped = line.strip()
                if not stripped or stripped.startswith(src.comment):
                    lines_consumed += 1
                    continue
                if src.header and header_names is None:
                    header_names = line.rstrip("\r\n")
                    lines_consumed += 1
                    continue
                first_data = line.rstrip("\r\n")
                break
    except UnicodeDecodeError:
        raise DataError(f"{file}: not UTF-8 text, expected a CSV recording") from None
    if first_data is None:
        raise DataError(
            f"{file}: no data rows"
            + (" after the header" if header_names is not None else "")
            + ", expected at least one row of numbers"
        )
    delim = src.delimiter
    if delim == "whitespace":
        delim = None
    elif delim is None:
        for cand in (",", ";", "\t"):
            if cand in first_data:
                delim = cand
                break
    first_fields = _split(first_data.strip() if delim is None else first_data, delim)
    ncols = len(first_fields)
    if header_names is not None:
        names = [
            h.strip().strip('"').strip("'").strip()
            for h in _split(header_names.strip() if delim is None else header_names, delim)
        ]
        if len(names) != ncols:
            raise DataError(
                f"{file}: the header has {len(names)} columns but the first data row {ncols} "
                "(columns of different lengths); expected the same number"
            )
        if all(FLOAT_RE.match(x) for x in names):
            raise DataError(
                f"{file}: the first row is numbers, not column names; "
                "for a file without a header set header = false in a mapping spec"
            )
        counts = Counter(names)  # linear in the width (names.count per name was quadratic)
        dup = sorted(n for n, c in counts.items() if c > 1 and n)
        if dup:
            raise DataError(f"{file}: column name(s) {dup} appear more than once in the header, expected unique names")
    elif src.names is not None:
        names = list(src.names)
        if len(names) != ncols:
            raise SpecError(f"{origin}: names lists {len(names)} columns, but {file.name} has {ncols}")
    else:
        names = None
    tab = Table(file, names, {}, 0, lines_consumed + 1)
    if src.header and src.names is not None:
        raise SpecError(f"{origin}: names = [...] is for files without a header; set header = false or drop names")
    tab.recognised = names is not None and any(isinstance(c, str) and c in names for c, _, _ in wanted)
    keys = []
    for col, index, where in wanted:
        if index is not None:
            raise SpecError(f"{origin}: {where} index = {index} is for 2-D arrays in NPZ files, not CSV columns")
        k = tab.key(col, where, origin)
        if isinstance(k, int) and k >= ncols:
            raise SpecError(f"{origin}: {where} column {k} is out of range, {file.name} has {ncols} columns (0-based)")
        keys.append(k if isinstance(k, int) else names.index(k))
    usecols = sorted(set(keys))
    if not usecols:
        tab.nrows = 0
        return tab
    try:
        arr = np.loadtxt(
            file,
            delimiter=delim,
            skiprows=lines_consumed,
            usecols=usecols,
            comments=src.comment,
            ndmin=2,
            dtype=float,
            encoding="utf-8-sig",
            quotechar='"',
        )
    except ValueError:
        raise DataError(
            f"{file}: {_bad_line_message(file, delim, lines_consumed, src.comment, ncols, names, usecols, tab.recognised)}"
        ) from None
    # a row shorter than the first one in a column we do not read is still a sign of a cut file
    _check_ragged_tail(file, delim, ncols, lines_consumed)
    col_of = {c: i for i, c in enumerate(usecols)}
    for (col, index, _where), k in zip(wanted, keys):
        tab.data[(col, index)] = arr[:, col_of[k]]
    tab.nrows = arr.shape[0]
    return tab


def _check_ragged_tail(file: Path, delim: str | None, ncols: int, lines_consumed: int) -> None:
    """Check that the last line has as many fields as the first (a logger killed mid-line)."""
    size = file.stat().st_size
    window = 8192
    with open(file, "rb") as fb:
        while True:  # widen the window until it holds the whole last line (lines of any length)
            fb.seek(max(0, size - window))
            raw = fb.read().rstrip(b"\r\n ")
            if b"\n" in raw or b"\r" in raw or window >= size:
                break
            window *= 4
    tail = raw.decode("utf-8", errors="replace")
    last = tail.splitlines()[-1] if tail else ""
    if not last.strip() or last.lstrip().startswith("#"):
        return
    n = len(_split(last.strip() if delim is None else last, delim))
    if n != ncols:
        raise DataError(
            f"{file}: the last line has {n} fields, the first data line {ncols} "
            "(columns of different lengths: was the file cut short?)"
        )


def _bad_line_message(
    file: Path, delim: str | None, skip: int, comment: str, ncols: int, names, usecols, show: bool
) -> str:
    """Find the first line that loadtxt could not read (slow path, only on error) and say what is wrong
    (``show``: quote the bad field, only for a file recognised as a recording)."""
    with open(file, encoding="utf-8-sig", errors="replace") as f:
        for lineno, line in enumerate(f, start=1):
            if lineno <= skip:
                continue
            body = line.split(comment, 1)[0] if comment else line
            if not body.strip():
                continue
            fields = _split(body.strip() if delim is None else body.rstrip("\r\n"), delim)
            if len(fields) < max(usecols) + 1 or len(fields) != ncols:
                return (
                    f"line {lineno} has {len(fields)} fields, the first data line {ncols} "
                    "(columns of different lengths), expected the same number in every row"
                )
            for c in usecols:
                text = fields[c].strip().strip('"')
                try:
                    float(text)
                except ValueError:
                    col = names[c] if names is not None and show else str(c)
                    what = "an empty field" if not text else f"'{text[:30]}'" if show else "the field"
                    return f"line {lineno}, column '{col}': {what} is not a number, expected numeric data"
    return "cannot be read as CSV numbers"


def _csv_columns(file: Path) -> list[str]:
    with open(file, "rb") as fb:
        if b"\x00" in fb.read(65536):
            raise DataError(f"{file}: binary file, expected CSV text (or an .npz file)")
    try:
        with open(file, encoding="utf-8-sig", newline="") as f:
            for line in f:
                if line.strip() and not line.strip().startswith("#"):
                    break
            else:
                raise DataError(f"{file}: no header line, expected a CSV recording with a header (t, q_<joint>, ...)")
    except UnicodeDecodeError:
        raise DataError(f"{file}: not UTF-8 text, expected a CSV recording") from None
    line = line.rstrip("\r\n")
    delim = next((c for c in (",", ";", "\t") if c in line), None)
    names = [h.strip().strip('"').strip("'").strip() for h in _split(line.strip() if delim is None else line, delim)]
    return names


register_reader(Reader("csv", _read_csv, suffixes=(".csv", ".txt", ".tsv", ".dat", ""), columns=_csv_columns))
