"""Figures, one module per topic.  matplotlib is imported inside the functions (Agg backend); plots
never call ``plt.show()``, take ``ax=None`` where a single axes fits, and return the figure."""

from __future__ import annotations

import os
import signal
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

    # No bbox_inches="tight": it renders the figure twice; every plot lays itself out (fixed_layout or tight_layout).
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=str(path).rsplit(".", 1)[-1], dpi=DPI)
    plt.close(fig)


def _render(recipe: Recipe) -> bytes:
    fn, args, kwargs = recipe
    return figure_png(fn(*args, **kwargs))


def _import_matplotlib() -> None:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot  # noqa: F401


def _worker_start() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle: no worker traceback
    _import_matplotlib()


def _pool_size(workers: int | None, jobs: int | None = None) -> int:
    """Worker processes to draw with: 0 (draw in this process) off Linux or on one core."""
    n = workers if workers is not None else (os.cpu_count() or 1)
    n = n if jobs is None else min(n, jobs)
    return n if n > 1 and sys.platform.startswith("linux") else 0


def _new_pool(n: int):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with warnings.catch_warnings():  # Python ≥ 3.12 warns about fork with threads (BLAS); workers only draw
        warnings.simplefilter("ignore", DeprecationWarning)
        pool = ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("fork"), initializer=_worker_start)
        pool.submit(int)  # a fork pool starts all its workers at the first task: now
    return pool


#: Workers started ahead by :func:`start_figure_workers`, taken by the next :func:`render_pngs`.
_started = None


def start_figure_workers(workers: int | None = None) -> None:
    """Start :func:`render_pngs`'s worker processes now, so that they load matplotlib while the caller
    computes (``pinid identify`` calls it before identifying when it will draw figures).  No-op where
    figures are drawn in this process, or when workers are already waiting."""
    global _started
    n = _pool_size(workers)
    if _started is None and n:
        _started = _new_pool(n)


def render_pngs(recipes: Mapping[str, Recipe], *, workers: int | None = None) -> dict[str, bytes]:
    """Draw each recipe and render it to PNG bytes (:func:`figure_png`), keyed as ``recipes``.

    Figures are independent, so on Linux with more than one core they are drawn in a pool of forked
    worker processes (``workers``, default one per core, at most one per figure): those started by
    :func:`start_figure_workers`, else new ones forked after matplotlib is loaded here.  Elsewhere, or
    with ``workers=1``, one after the other.  The same bytes either way.
    """
    global _started
    keys = list(recipes)
    pool, _started = _started, None
    if pool is None or workers is not None:
        if pool is not None:
            pool.shutdown()
        n = _pool_size(workers, len(keys))
        _import_matplotlib()  # before the fork, so that new workers inherit it
        if not n:
            return {k: _render(recipes[k]) for k in keys}
        pool = _new_pool(n)
    with pool:
        pngs = list(pool.map(_render, [recipes[k] for k in keys]))
    return dict(zip(keys, pngs))
