"""The figure of a simulated recording (``pinid simulate``): per joint the reference and the simulated
position, the tracking error and the measured torque."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pinid.checks import as_floats
from pinid.errors import SpecError
from pinid.report.figures import envelope, fixed_layout, new_figure


def _columns(x, name: str, n: int, nv: int) -> np.ndarray:
    a = as_floats(x, name)
    if a.ndim == 1 and nv == 1:
        a = a[:, None]
    if a.shape != (n, nv):
        raise SpecError(f"{name}: shape {a.shape}, expected ({n}, {nv}) (samples × joints)")
    return a


#: At most this many points per drawn line: a 60 s recording at 1 kHz is 60 000 samples a line, which
#: matplotlib draws in about a second per figure; 2000 points (each of 1000 runs' minimum and maximum,
#: :func:`pinid.report.figures.envelope`) look the same at the figure's width.
_MAX_POINTS = 2_000


def simulation_figure(
    t,
    reference,
    simulated,
    torque,
    joints: Sequence[str],
    *,
    title: str = "",
    error_label: str = "tracking error",
    position_labels: tuple[str, str] = ("reference", "simulated"),
):
    """One row per joint: the reference (dashed) and simulated position [rad], the tracking error
    ``simulated − reference`` [mrad] with its RMS, and the measured torque [N·m], against time ``t`` [s].

    ``reference``, ``simulated``, ``torque``: (N, nv) arrays; ``joints``: the nv joint names;
    ``error_label``, ``position_labels``: what the error column and the two positions are called (the
    floating twin's legs follow a prescribed motion exactly: there the error is the encoder noise of the
    recorded position).  Each line is drawn with at most ~2000 points (each bucket's minimum and maximum;
    the RMS is of every sample).  Returns the figure."""
    if isinstance(joints, str) or not isinstance(joints, Sequence) or not all(isinstance(j, str) for j in joints):
        raise SpecError(f"joints: got {type(joints).__name__}, expected a list of joint names")
    labels = (title, error_label, *position_labels) if isinstance(position_labels, tuple) else (None,)
    if len(labels) != 4 or not all(isinstance(x, str) for x in labels):
        raise SpecError("title, error_label, position_labels: expected a string, a string and two strings")
    t = as_floats(t, "t")
    nv, n = len(joints), len(t)
    if t.ndim != 1 or not nv:
        raise SpecError(f"t: shape {t.shape}, expected (N,) times [s] and at least one joint")
    ref, sim, tau = (
        _columns(x, k, n, nv) for x, k in ((reference, "reference"), (simulated, "simulated"), (torque, "torque"))
    )
    err = 1e3 * (sim - ref)
    fig, axes = new_figure(nv, 3, figsize=(12.0, 0.9 + 1.9 * nv), sharex=True, squeeze=False)
    for j, joint in enumerate(joints):
        ax_q, ax_e, ax_t = axes[j]
        ax_q.plot(*envelope(t, ref[:, j], _MAX_POINTS // 2), "k--", lw=1.0, label=position_labels[0])
        ax_q.plot(*envelope(t, sim[:, j], _MAX_POINTS // 2), lw=0.9, color="C0", label=position_labels[1])
        ax_e.plot(*envelope(t, err[:, j], _MAX_POINTS // 2), lw=0.7, color="C3")
        rms = float(np.sqrt(np.mean(err[:, j] ** 2)))
        ax_e.text(
            0.99,
            0.95,
            f"RMS {rms:.3g} mrad",
            transform=ax_e.transAxes,
            fontsize=8,
            va="top",
            ha="right",
            bbox={"fc": "white", "alpha": 0.8, "lw": 0},
        )
        ax_t.plot(*envelope(t, tau[:, j], _MAX_POINTS // 2), lw=0.6, color="C2")
        ax_q.set_ylabel(f"{joint}\nq [rad]")
        ax_e.set_ylabel("error [mrad]")
        ax_t.set_ylabel("τ [N·m]")
        for ax in (ax_q, ax_e, ax_t):
            ax.grid(alpha=0.3)
    heads = (f"position: {' and '.join(position_labels)}", error_label, "measured torque")
    for ax, head in zip(axes[0], heads):
        ax.set_title(head, fontsize=10)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    axes[0, 0].legend(fontsize=8, loc="upper right")
    if title:  # placed in inches from the top: a tall figure (many joints) keeps it clear of the column heads
        fig.suptitle(title, fontsize=11, y=1 - 0.1 / fig.get_size_inches()[1], va="top")
    fixed_layout(fig, left=1.05, right=0.2, bottom=0.55, top=0.65 if title else 0.35, hspace=0.25, wspace=0.75)
    return fig
