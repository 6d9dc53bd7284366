"""Figures, one module per topic.  matplotlib is imported inside the functions (Agg backend); plots
never call ``plt.show()``, take ``ax=None`` where a single axes fits, and return the figure."""

from __future__ import annotations

import os
import sys
import warnings
from collections.abc import Callable, Mapping

from pinid.io import atomic_path

#: A figure to draw: ``(function, args, kwargs)``; the function returns a matplotlib figure.
Recipe = tuple[Callable, tuple, dict]


def new_figure(*args, **kwargs):
    """``plt.subplots(*args, **kwargs)`` on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt.subplots(*args, **kwargs)


def fixed_layout(
    fig, *, left: float, right: float, bottom: float, top: float, hspace: float = 0.0, wspace: float = 0.0
) -> None:
    """Place ``fig``'s subplot grid by margins and gaps in inches (``hspace``/``wspace``: the gap between
    rows/columns).  Cheaper than ``tight_layout``, which measures every label with an extra draw."""
    width, height = fig.get_size_inches()
    gs = fig.axes[0].get_gridspec() if fig.axes else None
    nrows, ncols = gs.get_geometry() if gs is not None else (1, 1)
    inner_h = height - top - bottom
    inner_w = width - left - right
    fig.subplots_adjust(
        left=left / width,
        right=1 - right / width,
        bottom=bottom / height,
        top=1 - top / height,
        hspace=hspace * nrows / max(inner_h - hspace * (nrows - 1), 1e-6),
        wspace=wspace * ncols / max(inner_w - wspace * (ncols - 1), 1e-6),
    )


#: Resolution of every saved figure [dots per inch]; a 10-inch-wide figure is 1200 px.
DPI = 120


def figure_png(fig) -> bytes:
    """``fig`` as PNG bytes (at :data:`DPI`), and close it: one rendering for a file and an HTML page."""
    import io

    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    plt.close(fig)
    return buf.getvalue()


def save_figure(fig, path) -> None:
    """Save ``fig`` atomically to ``path`` (format from the suffix) and close it."""
    import matplotlib.pyplot as plt

    # No bbox_inches="tight": it renders the figure twice; every plot lays itself out (tight_layout).
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=str(path).rsplit(".", 1)[-1], dpi=DPI)
    plt.close(fig)


def _render(recipe: Recipe) -> bytes:
    fn, args, kwargs = recipe
    return figure_png(fn(*args, **kwargs))


def render_pngs(recipes: Mapping[str, Recipe], *, workers: int | None = None) -> dict[str, bytes]:
    """Draw each recipe and render it to PNG bytes (:func:`figure_png`), keyed as ``recipes``.

    Figures are independent, so on Linux with more than one core they are drawn in a pool of forked
    worker processes (``workers``, default one per core, at most one per figure), matplotlib imported
    once before the fork; elsewhere, or with ``workers=1``, one after the other.  Same bytes either way.
    """
    import matplotlib  # imported here, before any fork, so that the workers inherit it

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot  # noqa: F401

    keys = list(recipes)
    workers = min(len(keys), workers if workers is not None else (os.cpu_count() or 1))
    if workers <= 1 or not sys.platform.startswith("linux"):
        return {k: _render(recipes[k]) for k in keys}
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with warnings.catch_warnings():  # Python ≥ 3.12 warns about fork with threads (BLAS); workers only draw
        warnings.simplefilter("ignore", DeprecationWarning)
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
            pngs = list(pool.map(_render, [recipes[k] for k in keys]))
    return dict(zip(keys, pngs))
