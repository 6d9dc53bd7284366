"""Plain-text tables for the terminal that fit a width: columns sized to their longest cell, and a table
wider than ``width`` split into several, each repeating the key (first) columns."""

from __future__ import annotations

from collections.abc import Sequence

#: Width the terminal tables fit [characters].
WIDTH = 120


def text_table(
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    *,
    width: int = WIDTH,
    keys: int = 1,
    right: bool = True,
    indent: str = "",
) -> str:
    """``header`` and ``rows`` as aligned text: the first ``keys`` columns left-aligned and repeated in every
    part when the table is split to fit ``width``; the others right-aligned (``right``) or left-aligned."""
    table = [list(map(str, header))] + [list(map(str, r)) for r in rows]
    widths = [max(len(r[i]) for r in table) for i in range(len(header))]
    key_width = sum(widths[:keys]) + 2 * keys + len(indent)
    parts, part, used = [], [], key_width
    for i in range(keys, len(header)):
        if part and used + widths[i] > width:
            parts.append(part)
            part, used = [], key_width
        part.append(i)
        used += widths[i] + 2
    parts.append(part)
    out = []
    for cols in parts:
        if out:
            out.append("")
        idx = list(range(keys)) + cols
        for k, r in enumerate(table):
            cells = [r[i].ljust(widths[i]) if i < keys or not right else r[i].rjust(widths[i]) for i in idx]
            out.append((indent + "  ".join(cells)).rstrip())
            if k == 0:
                out.append(indent + "  ".join("-" * widths[i] for i in idx))
    return "\n".join(out)
