"""Every registered name is documented by hand where a user looks for it (issue 26: help texts are generated
from the registries; the hand-written pages are checked against them, so that an entry added with one file
and one registry line fails here until its page names it, and a page cannot keep naming a removed one)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from pinid.data.registry import READERS, WRITERS
from pinid.estimators import ESTIMATORS
from pinid.model.terms import TERMS
from pinid.optimizers import OPTIMIZERS

DOCS = Path(__file__).resolve().parents[2] / "docs"
#: Generated from the code (docs/cli.md, docs/api.md): they name every entry by construction.
GENERATED = {"cli.md", "api.md"}


def quoted(text: str) -> set[str]:
    """Names written as code (between backticks) or as a string in a code example."""
    return set(re.findall(r"`([\w-]+)`", text)) | set(re.findall(r"\"([\w-]+)\"", text))


def hand_written() -> str:
    pages = [p for p in sorted(DOCS.rglob("*.md")) if p.name not in GENERATED]
    return "\n".join(p.read_text(encoding="utf-8") for p in [*pages, DOCS.parent / "README.md"])


@pytest.mark.parametrize(
    ("registry", "page"),
    [(ESTIMATORS, "identification.md"), (OPTIMIZERS, "metaheuristics.md"), (READERS, "data.md"), (WRITERS, "data.md")],
    ids=["estimators", "optimizers", "readers", "writers"],
)
def test_every_registered_name_is_on_its_page(registry, page):
    missing = sorted(set(registry) - quoted((DOCS / page).read_text(encoding="utf-8")))
    assert not missing, f"docs/{page} does not name {missing} (registered); say what each is and does"


def test_every_joint_term_is_documented():
    missing = sorted(set(TERMS) - quoted(hand_written()))
    assert not missing, f"no hand-written page names the joint term(s) {missing} (registered)"


def test_the_estimator_table_names_only_registered_methods():
    """The table of docs/identification.md ("| `method` | what | assumptions | settings |") lists methods that
    exist."""
    lines = (DOCS / "identification.md").read_text(encoding="utf-8").splitlines()
    header = [i for i, line in enumerate(lines) if line.startswith("| method | what | assumptions")]
    assert header, "docs/identification.md: the table of methods was not found"
    table = []
    for line in lines[header[0] + 2 :]:  # after the header and its rule; a table ends at its first other line
        if not line.startswith("|"):
            break
        table.append(line)
    rows = [m.group(1) for m in (re.match(r"\| `([\w-]+)` \|", line) for line in table) if m]
    assert len(rows) == len(table), f"docs/identification.md: a row of the methods' table names no method: {table}"
    assert set(rows) <= set(ESTIMATORS), (
        f"docs/identification.md lists unknown methods {sorted(set(rows) - set(ESTIMATORS))}"
    )


def test_the_methods_table_is_generated_from_the_estimators():
    """docs/identification.md's table of methods is :func:`pinid.docgen.methods_table` between its markers
    (``python -m pinid.docgen methods-table --write`` rewrites it), and names every estimator of pinid."""
    from pinid.docgen import methods_table, with_methods_table

    text = (DOCS / "identification.md").read_text(encoding="utf-8")
    assert with_methods_table(text) == text, (
        "docs/identification.md: the methods' table is stale; run python -m pinid.docgen methods-table --write"
    )
    rows = re.findall(r"^\| `([\w-]+)` \|", methods_table(), flags=re.M)
    assert rows == [n for n in ESTIMATORS if not ESTIMATORS.plugin(n)]


def test_the_terms_help_names_every_term_and_group():
    from pinid.cli.common import terms_help
    from pinid.model.terms import TERM_GROUPS

    text = terms_help()
    missing = [n for n in [*TERMS, *TERM_GROUPS] if not re.search(rf"(?<![\w-]){re.escape(n)}(?![\w-])", text)]
    assert not missing, f"--terms help does not name {missing}"


def test_the_checker_sees_a_missing_name():
    assert "newmethod" not in quoted("| `ols` | least squares |") and {"ols"} <= quoted("| `ols` | x |")
