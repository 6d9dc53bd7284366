"""Figures, one module per topic.  matplotlib is imported inside the functions (Agg backend); plots
never call ``plt.show()``, take ``ax=None`` where a single axes fits, and return the figure."""

from __future__ import annotations

from pinid.io import atomic_path


def new_figure(*args, **kwargs):
    """``plt.subplots(*args, **kwargs)`` on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt.subplots(*args, **kwargs)


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
