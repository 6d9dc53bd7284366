"""Figures, one module per topic.  matplotlib is imported inside the functions (Agg backend); plots
never call ``plt.show()``, take ``ax=None`` where a single axes fits, and return the figure."""

from __future__ import annotations

import functools
import contextlib
import gc
import os
import signal
import sys
import warnings
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from pinid.io import atomic_path, deferred_interrupts, in_writer_process, writing_behind

#: A figure to draw: ``(function, args, kwargs)``; the function returns a matplotlib figure.
Recipe = tuple[Callable, tuple, dict]


#: True in a process that only draws figures to PNG bytes (:func:`render_pngs`' workers): figures are made
#: without pyplot (:func:`new_figure`), which such a process need not import (0.3 s of CPU less at its start)
#: and whose figure managers it need not keep.
_BARE = False

#: :func:`matplotlib.pyplot.subplots`' arguments that go to ``Figure.subplots``; the rest make the figure.
_SUBPLOTS_ARGS = ("sharex", "sharey", "squeeze", "width_ratios", "height_ratios", "subplot_kw", "gridspec_kw")


def new_figure(*args, **kwargs):
    """``plt.subplots(*args, **kwargs)`` on the non-interactive Agg backend.  In a drawing worker
    (:data:`_BARE`) the same figure without pyplot: a ``Figure`` on an Agg canvas, which pyplot does not
    manage (the same pixels, tested)."""
    if _BARE:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        layout = {k: kwargs.pop(k) for k in _SUBPLOTS_ARGS if k in kwargs}
        fig = Figure(**kwargs)
        FigureCanvasAgg(fig)
        axes = fig.subplots(*args, **layout)
    else:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(*args, **kwargs)
    ticks_in_view(fig)  # before any layout pass (tight_layout) makes the ticks
    return fig, axes


def close_figure(fig) -> None:
    """Close ``fig`` in pyplot (free its memory), if pyplot is loaded; a figure without pyplot needs nothing."""
    plt = sys.modules.get("matplotlib.pyplot")
    if plt is not None:
        plt.close(fig)


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


def envelope(x, y, columns: int) -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` thinned for a line plot ``columns`` pixels wide: the samples split into ``columns``
    consecutive runs of (nearly) equal length, of each run its first minimum and first maximum of ``y``,
    in their order (one sample when they coincide).  Drawn as a line it covers the same pixels as every
    sample (each column spans its run's extremes; peaks and noise bands stay), unlike every k-th sample.
    Unchanged when there are no more than ``2 * columns`` samples or ``y`` is not all finite."""
    x, y = np.asarray(x), np.asarray(y)
    n = len(y)
    if n <= 2 * columns or not np.isfinite(y).all():
        return x, y
    starts = np.linspace(0, n, columns + 1).astype(np.intp)[:-1]  # every run has at least two samples
    run = np.repeat(np.arange(columns), np.diff(np.append(starts, n)))
    picks = []
    for reduce in (np.minimum, np.maximum):
        hit = np.flatnonzero(y == reduce.reduceat(y, starts)[run])
        _, first = np.unique(run[hit], return_index=True)  # the first sample of each run at its extreme
        picks.append(hit[first])
    keep = np.unique(np.concatenate(picks))  # sorted: time order, a coinciding min and max once
    return x[keep], y[keep]


#: Resolution of every saved figure [dots per inch]; a 10-inch-wide figure is 1000 px, the width of a report
#: page on a screen (issue 45: 120 before; the pixels drawn and encoded fall by a third, the text stays
#: readable: 10 pt is 14 px).
DPI = 100

#: zlib level of the PNG figures: 3 encodes the 12-panel torque figure of a 6-DOF arm in 0.085 s (6: 0.13 s)
#: for a file 5 % larger.
PNG_COMPRESSION = 3


@functools.cache
def _in_view_class():
    from matplotlib.ticker import Locator, MaxNLocator

    class InView(Locator):
        """``base``'s tick locations without those outside the axis' view, remembered while the view and
        the room for ticks stay the same.  Matplotlib makes a tick (two lines, two texts, a grid line)
        for every location its locator gives, one or two beyond each end, and then draws only those in
        the view; and it asks the locator again for every layout pass, spine and label position (10 times
        an axis per figure)."""

        def __init__(self, base):
            self.base = base
            self.axis = base.axis
            self._key, self._locs = None, None

        def set_axis(self, axis):
            self.axis = axis
            self.base.set_axis(axis)
            self._key = None

        def set_params(self, **kwargs):
            self.base.set_params(**kwargs)
            self._key = None

        def __call__(self):
            axis = self.axis
            if axis is None:
                return self.base()
            view = axis.get_view_interval()
            # what a MaxNLocator's (AutoLocator's) ticks depend on; any other locator is asked each time
            key = (*view, axis.get_tick_space()) if isinstance(self.base, MaxNLocator) else None
            if key is None or key != self._key:
                locs = self.base()
                if len(locs):
                    transform = axis.get_transform()
                    lo, hi = sorted(transform.transform(view))
                    tol = 1e-6 * (hi - lo)  # matplotlib draws those within 1e-10 of the span: keep a margin
                    locs = [loc for loc, x in zip(locs, transform.transform(locs)) if lo - tol <= x <= hi + tol]
                self._key, self._locs = key, locs
            return list(self._locs)

        def tick_values(self, vmin, vmax):
            return self.base.tick_values(vmin, vmax)

        def nonsingular(self, v0, v1):
            return self.base.nonsingular(v0, v1)

        def view_limits(self, vmin, vmax):
            return self.base.view_limits(vmin, vmax)

    return InView


def ticks_in_view(fig) -> None:
    """Give every axis of ``fig`` only the tick locations inside its view (the same picture: matplotlib
    draws no tick outside it, but makes an object for each, the costliest part of drawing a plot with many
    panels).  Idempotent; shared axes share one locator, wrapped once."""
    from matplotlib.ticker import NullLocator

    in_view = _in_view_class()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for ticker in (axis.major, axis.minor):
                if not isinstance(ticker.locator, (in_view, NullLocator)):
                    ticker.locator = in_view(ticker.locator)


def png_bytes(fig) -> bytes:
    """``fig`` drawn at :data:`DPI` as PNG bytes (the figure stays open): the pixels of
    ``fig.savefig(format="png", dpi=DPI)``, without its alpha channel when the figure is opaque (it is
    unless made transparent), at zlib level :data:`PNG_COMPRESSION`.  A quarter of savefig's encoding
    time on a tall figure (the 12-panel torque figure of a 6-DOF arm: 0.09 s instead of 0.29 s;
    docs/benchmarks.md), and a smaller file."""
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image, PngImagePlugin

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    fig.set_dpi(DPI)
    ticks_in_view(fig)
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    image = Image.fromarray(rgba)
    if rgba[..., 3].min() == 255:
        image = image.convert("RGB")
    info = PngImagePlugin.PngInfo()
    info.add_text("Software", "pinid (matplotlib, Agg)")
    buf = io.BytesIO()
    image.save(buf, format="png", compress_level=PNG_COMPRESSION, pnginfo=info)
    return buf.getvalue()


def figure_png(fig) -> bytes:
    """``fig`` as PNG bytes (:func:`png_bytes`), and close it: one rendering for a file and an HTML page."""
    try:
        return png_bytes(fig)
    finally:
        close_figure(fig)


def save_figure(fig, path) -> None:
    """Save ``fig`` atomically to ``path`` (format from the suffix; PNG as :func:`figure_png`) and close it."""
    # No bbox_inches="tight": it renders the figure twice; every plot lays itself out (fixed_layout or tight_layout).
    fmt = str(path).rsplit(".", 1)[-1]
    try:
        with atomic_path(path) as tmp:
            if fmt.lower() == "png":
                Path(tmp).write_bytes(png_bytes(fig))
            else:
                fig.savefig(tmp, format=fmt, dpi=DPI)
    finally:
        close_figure(fig)


def _render(recipe: Recipe) -> bytes | list[bytes]:
    fn, args, kwargs = recipe
    drawn = fn(*args, **kwargs)
    return drawn if isinstance(drawn, list) else figure_png(drawn)


def _import_matplotlib(bare: bool = False) -> None:
    """Load matplotlib (and pyplot, unless ``bare``: a drawing worker's figures need none, :data:`_BARE`)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    if bare:
        import matplotlib.backends.backend_agg  # noqa: F401
        import matplotlib.figure  # noqa: F401
    else:
        import matplotlib.pyplot  # noqa: F401


def _warm_up() -> None:
    """Draw a small figure with text, a line and ticks to PNG once, so that what matplotlib loads at its
    first drawing (the font files and their glyph caches, the text layout caches, PIL's PNG encoder: 0.1–0.3 s
    of CPU) is loaded in the process that forks the drawing workers, not again in each of them."""
    fig, ax = new_figure(figsize=(2.0, 1.5))
    ax.plot([0.0, 1.0], [0.0, 1.0], lw=1.0, label="warm-up")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("τ [N·m]")
    ax.set_title("warm-up", fontsize="medium")
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)
    fig.suptitle("warm-up")
    figure_png(fig)


def _worker_start(warm: bool = False) -> None:
    global _BARE
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle: no worker traceback
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's deferred_interrupts handler
    gc.disable()  # loading makes objects that all live on: nothing for a collection to find
    _BARE = True  # this process only draws to PNG bytes: no pyplot
    _import_matplotlib(bare=True)
    if warm:
        _warm_up()
    gc.freeze()  # what is loaded now lives as long as the worker: no collection need look at it again
    gc.enable()


def _pool_size(workers: int | None, jobs: int | None = None) -> int:
    """Worker processes to draw with: 0 (draw in this process) off Linux, on one core, or in a process that
    writes files behind its parent (:func:`pinid.io.written_behind`: the parent's core is busy)."""
    if in_writer_process():
        return 0
    n = workers if workers is not None else (os.cpu_count() or 1)
    n = n if jobs is None else min(n, jobs)
    return n if n > 1 and sys.platform.startswith("linux") else 0


def _new_pool(n: int):
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with warnings.catch_warnings():  # Python ≥ 3.12 warns about fork with threads (BLAS); workers only draw
        warnings.simplefilter("ignore", DeprecationWarning)
        with deferred_interrupts():  # an interrupt while the workers start: raised once they are up
            gc.freeze()  # the workers' collections skip what they inherit (and leave its pages shared)
            try:
                pool = ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("fork"), initializer=_worker_start)
                pool.submit(int)  # a fork pool starts all its workers at the first task: now
            finally:
                gc.unfreeze()
    return pool


def _load_and_draw(conn, caller_end, n: int) -> None:
    """The process :class:`_Loader` forks: loads matplotlib, forks ``n`` drawing workers that inherit it,
    then draws the recipes it receives on ``conn`` and sends back ``("ok", pngs)`` or ``("error", exc)``."""
    caller_end.close()  # the caller's end, inherited: closed here, so that the caller closing it ends the input
    _worker_start(warm=True)  # the drawing workers inherit what the first drawing loads
    pool = _new_pool(n)
    try:
        recipes = conn.recv()
    except EOFError:  # shut down unused
        recipes = None
    if recipes is not None:
        try:
            out = ("ok", list(pool.map(_render, recipes)))
        except Exception as exc:  # noqa: BLE001 (raised in the caller's process)
            out = ("error", exc)
        try:
            conn.send(out)
        except (BrokenPipeError, ConnectionResetError):  # the caller is gone (interrupted): nothing to say
            pass
        except Exception as exc:  # noqa: BLE001 (an exception that does not pickle)
            with contextlib.suppress(OSError):
                conn.send(("error", RuntimeError(f"drawing a figure failed: {type(exc).__name__}: {exc}")))
    pool.shutdown(cancel_futures=True)


class _Loader:
    """Workers started ahead: one process loads matplotlib while the caller computes, then forks the ``n``
    workers that draw, so that matplotlib is loaded once (0.65 s of CPU) instead of in every worker, which
    on two cores would take the time from the caller's work.  Used once, like a pool: ``map``, ``shutdown``."""

    def __init__(self, n: int):
        import atexit
        import multiprocessing

        ctx = multiprocessing.get_context("fork")
        self._conn, theirs = ctx.Pipe()
        with warnings.catch_warnings():  # Python ≥ 3.12 warns about fork with threads (BLAS); it only draws
            warnings.simplefilter("ignore", DeprecationWarning)
            with deferred_interrupts():  # an interrupt while it starts: raised once it is up
                gc.freeze()  # its collections skip what it inherits (and leave its pages shared)
                try:
                    self._process = ctx.Process(
                        target=_load_and_draw, args=(theirs, self._conn, n), name="pinid-figures"
                    )
                    self._process.start()
                finally:
                    gc.unfreeze()
        theirs.close()
        atexit.register(self.shutdown)  # before multiprocessing's exit handler joins it: it must not wait

    def map(self, fn: Callable, recipes: list) -> list:
        if fn is not _render:
            raise ValueError("_Loader draws recipes only")
        self._conn.send(recipes)
        try:
            status, out = self._conn.recv()
        except EOFError:
            raise RuntimeError("the figure workers ended before drawing (killed?)") from None
        if status != "ok":
            raise out
        return out

    def shutdown(self) -> None:
        import atexit

        if not self._conn.closed:
            self._conn.close()  # an unused loader sees the end of its input and stops
            self._process.join()
        atexit.unregister(self.shutdown)

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.shutdown()


#: Workers started ahead by :func:`start_figure_workers`, taken by the next :func:`render_pngs`.
_started = None


def start_figure_workers(workers: int | None = None) -> None:
    """Start :func:`render_pngs`'s worker processes now, so that they load matplotlib (once, forked from one
    process that loaded it: :class:`_Loader`) while the caller computes (``pinid identify`` calls it before identifying when it will draw figures).  No-op where
    figures are drawn in this process, or when workers are already waiting."""
    global _started
    n = _pool_size(workers)
    if _started is None and n and not writing_behind():  # files written behind: drawn by another process
        _started = _Loader(n)


def render_pngs(recipes: Mapping[str | tuple[str, ...], Recipe], *, workers: int | None = None) -> dict[str, bytes]:
    """Draw each recipe and render it to PNG bytes (:func:`figure_png`), keyed as ``recipes``.  A recipe
    keyed by a tuple of names draws several figures itself: its function returns their PNG bytes, a
    list in the order of the names (one worker draws them, e.g. one figure redrawn per method).

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
            return _by_name(keys, [_render(recipes[k]) for k in keys])
        pool = _new_pool(n)
    with pool:
        pngs = list(pool.map(_render, [recipes[k] for k in keys]))
    return _by_name(keys, pngs)


def _by_name(keys: list, pngs: list) -> dict[str, bytes]:
    """``{name: png}`` from the recipes' keys (a name or a tuple of names) and what each drew."""
    out: dict[str, bytes] = {}
    for key, png in zip(keys, pngs):
        out.update(zip(key, png) if isinstance(key, tuple) else [(key, png)])
    return out


def figure_workers() -> int:
    """How many processes :func:`render_pngs` draws in by default: 1 (this one) off Linux or on one core."""
    return max(1, _pool_size(None))
