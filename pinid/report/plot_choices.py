"""The choices made by blocked cross-validation (``--cutoff auto``, ``--terms auto``), drawn for the report:
the held-out error against the cut-off, and each step of the term selection."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pinid.errors import SpecError
from pinid.report.figures import fixed_layout, new_figure


def cross_validation_figure(cutoff: Mapping | None = None, terms: Mapping | None = None, *, title: str | None = None):
    """One panel per choice made: ``cutoff`` (the ``data.cutoff`` dict of identification.json: the held-out
    relative RMS [%] against each candidate cut-off [Hz], the choice marked) and ``terms`` (``data.terms_choice``:
    per step the held-out relative RMS [%] of each candidate term set, the start dotted).  The Figure."""
    for name, value in (("cutoff", cutoff), ("terms", terms)):
        if value is not None and not isinstance(value, Mapping):
            raise SpecError(f"{name}: got {type(value).__name__}, expected a dict of identification.json's data")
    panels = [p for p in (cutoff, terms) if p]
    fig, axes = new_figure(1, max(1, len(panels)), figsize=(5.5 * max(1, len(panels)), 3.6), squeeze=False)
    axes = axes[0]
    k = 0
    if cutoff:
        ax = axes[k]
        k += 1
        f = np.asarray(cutoff["candidates_hz"], dtype=float)
        s = np.array([np.nan if v is None else v for v in cutoff["cv_rel_rms_percent"]], dtype=float)
        ok = np.isfinite(s)
        ax.semilogx(f[ok], s[ok], "o-", color="0.25", label="held-out error")
        ax.axvline(cutoff["cutoff_hz"], color="tab:red", ls="--", label=f"chosen: {cutoff['cutoff_hz']:g} Hz")
        ax.set_xlabel("low-pass cut-off [Hz]")
        ax.set_ylabel("held-out relative RMS [%]")
        ax.set_title("cut-off", fontsize=10)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    if terms:
        ax = axes[k]
        steps = [st for st in terms.get("steps") or [] if st]
        start_label, start = next(iter(steps[0].items()), (None, None)) if steps else (None, None)
        chosen = set(terms.get("terms", []))
        labels, values, colours = [], [], []
        for i, step in enumerate(steps[1:], start=1):
            for name, v in sorted(step.items(), key=lambda kv: np.inf if kv[1] is None else kv[1]):
                if v is None:
                    continue
                added = set(name.lstrip("+").split(",")) <= chosen
                labels.append(f"step {i}: {name}")
                values.append(v)
                colours.append("tab:red" if added else "0.6")
        y = np.arange(len(values))[::-1]
        ax.barh(y, values, color=colours, height=0.7)
        ax.set_yticks(y, labels, fontsize=7)
        if start is not None:
            ax.axvline(start, color="0.2", ls=":", label=f"start: {start_label}")
            ax.legend(fontsize=8, loc="lower right")
        if values:
            lo, hi = min([*values, start or values[0]]), max([*values, start or values[0]])
            pad = 0.15 * (hi - lo) + 1e-3 * hi
            ax.set_xlim(lo - pad, hi + pad)
        ax.set_xlabel("held-out relative RMS [%] (red: added)")
        ax.set_title(f"terms: chose {', '.join(terms.get('terms', [])) or 'none'}", fontsize=10)
        ax.grid(alpha=0.3, axis="x")
    fig.suptitle(title or "choices made by blocked cross-validation on the training recordings", fontsize=11)
    fixed_layout(fig, left=0.8, right=0.3, bottom=0.6, top=0.7, wspace=1.6)
    return fig
