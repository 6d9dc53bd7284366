"""A self-contained HTML page from pinid's report Markdown, so that ``report.md`` and ``report.html`` come
from one text.

Renders the small subset of Markdown the reports use — ``#``/``##``/``###`` headings, paragraphs,
``- `` lists, hard line breaks (a line ending in two spaces), pipe tables (``\\|`` for a ``|`` in a cell), fenced code, a paragraph that is one image ``![alt](file)``, and inline
`` `code` ``, ``**bold**`` and ``*emphasis*`` — plus the raw HTML lines that fold a section (``<details>``, ``<details open>``,
``<summary>…</summary>``, ``</details>``: GitHub renders them in report.md too), passed through as they
are; and embeds every image as a ``data:`` URI: the page needs no server, no other file and no network (no
external style sheet, font or script).  Numbers stay on one line and prose cells (a list of names) wrap, so
that the tables fit the page's column (1250 px); on a narrower window a wider table scrolls sideways inside its
own block, so that the page stays readable (1000 px).
"""

from __future__ import annotations

import base64
import html
import re
from collections.abc import Mapping

_IMAGE = re.compile(r"^!\[(?P<alt>.*)\]\((?P<src>[^)\s]+)\)$")
_INLINE = re.compile(r"`([^`]+)`|\*\*(.+?)\*\*|(?<![\w*])\*(?![\s*])([^*]+?)(?<!\s)\*(?![\w*])")
#: Raw HTML lines passed through: the folding of a report's sections.
_RAW = re.compile(r"^(<details( open)?>|</details>|<summary>.*</summary>)$")

STYLE = """\
body { font-family: system-ui, sans-serif; max-width: 1250px; margin: 1.5em auto; padding: 0 1em; color: #222;
       overflow-wrap: break-word; }
h1 { border-bottom: 2px solid #ccc; } h2 { border-bottom: 1px solid #ddd; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.2em 0.55em; text-align: right; }
th { background: #f2f2f2; } td { white-space: nowrap; } td:first-child, th:first-child { text-align: left; }
td.text { white-space: normal; text-align: left; min-width: 18em; }
code { background: #f4f4f4; padding: 0 0.2em; } pre { background: #f4f4f4; padding: 0.7em; overflow-x: auto; }
img { max-width: 100%; height: auto; display: block; margin: 0.6em 0; }
.table { overflow-x: auto; max-width: 100%; } figure { margin: 0.6em 0; }
details { border: 1px solid #ddd; border-radius: 4px; padding: 0.1em 0.8em; margin: 0.4em 0; }
details[open] { padding-bottom: 0.5em; } summary { cursor: pointer; padding: 0.3em 0; }
"""


def _inline(text: str) -> str:
    """Escape ``text`` and render its `` `code` ``, ``**bold**`` and ``*emphasis*`` spans (a ``*`` between
    words or spaces, as in ``2 * 3``, stays a ``*``)."""
    out, pos = [], 0
    for m in _INLINE.finditer(text):
        out.append(html.escape(text[pos : m.start()]))
        if m.group(1) is not None:
            out.append(f"<code>{html.escape(m.group(1))}</code>")
        elif m.group(2) is not None:
            out.append(f"<strong>{_inline(m.group(2))}</strong>")
        else:
            out.append(f"<em>{_inline(m.group(3))}</em>")
        pos = m.end()
    out.append(html.escape(text[pos:]))
    return "".join(out)


def _cells(line: str) -> list[str]:
    """The cells of a table row; ``\\|`` is a literal ``|`` inside a cell (GitHub Markdown)."""
    inner = line.strip()[1:]
    inner = inner[:-1] if inner.endswith("|") and not inner.endswith("\\|") else inner
    return [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", inner)]


#: A cell longer than this is prose (a list of names, a sentence): it wraps, where numbers stay on one line.
TEXT_CELL = 40


def _cell(text: str) -> str:
    """One ``<td>``: numbers and short words on one line, prose (:data:`TEXT_CELL`) wrapped so that the table
    fits the page instead of scrolling sideways."""
    return f'<td class="text">{_inline(text)}</td>' if len(text) > TEXT_CELL else f"<td>{_inline(text)}</td>"


def _image(alt: str, src: str, images: Mapping[str, bytes]) -> str:
    if src not in images:
        raise KeyError(f"report.html: no image data for {src!r} (have {sorted(images)})")
    data = base64.b64encode(images[src]).decode("ascii")
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"></figure>'


def markdown_to_html(text: str, images: Mapping[str, bytes] | None = None, *, title: str = "pinid report") -> str:
    """One HTML page from ``text``; ``images`` maps the file names the text links to their PNG bytes."""
    images = images or {}
    body: list[str] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        line = lines[i]
        if not line.strip():
            i += 1
        elif _RAW.match(line.strip()):
            body.append(line.strip())
            i += 1
        elif line.startswith("```"):
            j = i + 1
            while j < len(lines) and not lines[j].startswith("```"):
                j += 1
            body.append("<pre><code>" + html.escape("\n".join(lines[i + 1 : j])) + "</code></pre>")
            i = j + 1
        elif m := re.match(r"^(#{1,3}) (.*)$", line):
            n = len(m.group(1))
            body.append(f"<h{n}>{_inline(m.group(2))}</h{n}>")
            i += 1
        elif line.startswith("|"):
            j = i
            while j < len(lines) and lines[j].startswith("|"):
                j += 1
            rows = [_cells(r) for r in lines[i:j]]
            head, rest = rows[0], [r for r in rows[1:] if not all(set(c) <= set("-: ") for c in r)]
            body.append(
                '<div class="table"><table><thead><tr>'
                + "".join(f"<th>{_inline(c)}</th>" for c in head)
                + "</tr></thead><tbody>"
                + "".join("<tr>" + "".join(_cell(c) for c in r) + "</tr>" for r in rest)
                + "</tbody></table></div>"
            )
            i = j
        elif line.startswith("- "):
            j = i
            while j < len(lines) and lines[j].startswith("- "):
                j += 1
            body.append("<ul>" + "".join(f"<li>{_inline(r[2:])}</li>" for r in lines[i:j]) + "</ul>")
            i = j
        elif m := _IMAGE.match(line.strip()):
            body.append(_image(m.group("alt"), m.group("src"), images))
            i += 1
        else:
            j = i + 1
            while j < len(lines) and lines[j].strip() and not re.match(r"^(#|\||- |```|!\[|<)", lines[j]):
                j += 1
            # a span may wrap onto the next line; a line ending in two spaces breaks there (Markdown's hard break)
            groups, start = [], i
            for k in range(i, j):
                if lines[k].endswith("  ") or k == j - 1:
                    groups.append(_inline(" ".join(x.strip() for x in lines[start : k + 1])))
                    start = k + 1
            body.append("<p>" + "<br>\n".join(groups) + "</p>")
            i = j
    return (
        '<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        f"<title>{html.escape(title)}</title>\n<style>\n{STYLE}</style>\n</head>\n<body>\n"
        + "\n".join(body)
        + "\n</body>\n</html>\n"
    )
