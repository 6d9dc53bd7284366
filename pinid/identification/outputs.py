"""The files a comparison writes, planned as one :class:`pinid.io.Artefacts` and written all or nothing:
what ``pinid compare`` writes, reachable from Python.  The report and figure modules (matplotlib) load
only when figures are asked for."""

from __future__ import annotations

import os
from pathlib import Path

from pinid.io import Artefacts
from pinid.report.figures import save_figure

#: Every file a comparison writes (patterns): what a ``--force`` re-run removes of an earlier run's.
COMPARISON_FILES = ("comparison.json", "comparison.md", "compare_*.png")


def comparison_markdown(comp, *, command: str | None = None, figures=()) -> str:
    """``comparison.md``: the command line (when given), the comparison table, the identified values
    (mean ± spread over the seeds) and links to the ``figures`` (file names)."""
    block = f"```\n{command}\n```\n\n" if command else ""
    return (f"# Comparison on {comp.robot['name']}\n\n{block}```\n{comp.table()}\n```\n\nIdentified base parameters "
            f"(mean ± spread over the seeds):\n\n```\n{comp.values_table()}\n```\n"
            + "".join(f"\n![{name}]({name})\n" for name in figures))


def write_comparison(comp, folder: str | os.PathLike, *, command: str | None = None, figures: bool = True,
                     overwrite: bool | None = None) -> list[Path]:
    """Write a :class:`~pinid.identification.compare.Comparison` into ``folder``: ``comparison.json``,
    ``comparison.md`` (:func:`comparison_markdown`) and, with ``figures``, the ``compare_*.png`` figures;
    all or nothing, an earlier comparison's files there removed.  ``overwrite``: replace existing files
    (None: the :data:`pinid.io.OVERWRITE` policy, which the CLI's ``--force`` sets).  Returns the paths."""
    out = Path(folder)
    figs = {}
    if figures:
        from pinid.report.plot_compare import comparison_figures  # deferred: matplotlib, on use only

        figs = comparison_figures(comp)
    arts = Artefacts(overwrite=overwrite)
    arts.add(out / "comparison.json", lambda p: comp.save(p))
    arts.add(out / "comparison.md", comparison_markdown(comp, command=command, figures=figs))
    for name, fig in figs.items():
        arts.add(out / name, lambda p, fig=fig: save_figure(fig, p))
    arts.clean(out, COMPARISON_FILES)
    return arts.write()
