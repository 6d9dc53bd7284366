"""Pictures of the wearer (``pinid wearer``, stage 2): where the segments attach on the exoskeleton in its
zero pose, and the identified segment masses and centres of mass against the anthropometric tables."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pinid.errors import SpecError
from pinid.report.figures import new_figure

#: A point counts as off the sagittal plane (a frontal view is drawn) beyond this |y| [m].
PLANAR = 1e-3


def _zero_pose_points(urdf_text: str, segments: Mapping[str, Mapping]) -> tuple[list, dict]:
    """The robot of ``urdf_text`` in its zero pose (Pinocchio's neutral configuration, every joint of the
    URDF at 0), in the world frame [m]: ``(bones, placed)`` with ``bones`` the ``(start, end)`` pairs of
    the kinematic chain (each joint to its parent joint, each fixed link's frame to its joint; not the
    wearer's) and ``placed`` per segment of ``segments`` (:func:`pinid.wearer.attach.wearer_segments`,
    in the frame of its exo link) its ``"attach"`` point (the link's frame), ``"com"``, ``"start"`` and
    ``"end"``."""
    import pinocchio as pin

    if not isinstance(urdf_text, str):
        raise SpecError(f"urdf_text: got {type(urdf_text).__name__}, expected the text of a URDF")
    if not isinstance(segments, Mapping):
        raise SpecError(f"segments: got {type(segments).__name__}, expected {{segment: {{link, com, start, end}}}}")
    model = pin.buildModelFromXML(urdf_text)
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    joints = [data.oMi[i].translation.copy() for i in range(model.njoints)]
    bones = [(joints[model.parents[i]], joints[i]) for i in range(1, model.njoints)]
    for f, frame in enumerate(model.frames):
        if frame.type == pin.FrameType.BODY and not frame.name.startswith("wearer_"):
            p = data.oMf[f].translation
            if np.linalg.norm(p - joints[frame.parentJoint]) > 1e-6:
                bones.append((joints[frame.parentJoint], p.copy()))
    placed = {}
    for seg, s in segments.items():
        if not model.existFrame(s["link"]):
            raise SpecError(f"segments: {seg}'s link {s['link']!r} is not a link of urdf_text")
        M = data.oMf[model.getFrameId(s["link"])]
        placed[seg] = {"attach": M.translation.copy()} | {
            k: M.act(np.asarray(s[k], dtype=float)) for k in ("com", "start", "end")
        }
    return bones, placed


def attachment_figure(urdf_text: str, segments: Mapping[str, Mapping], *, title: str = ""):
    """Where the wearer's segments attach: the robot's kinematic chain in its zero pose (grey), each
    segment (a thick line from its proximal to its distal end), the exo link frame it is strapped to
    (square) and its centre of mass (circle), labelled; a sagittal x–z view, plus a frontal y–z view when
    the robot leaves the sagittal plane (:func:`_zero_pose_points`).  The CoM markers carry the gid
    ``com:<segment>``, the attachment markers ``attach:<segment>``, the segments ``segment:<segment>``.  Returns the figure."""
    bones, placed = _zero_pose_points(urdf_text, segments)
    points = np.array([p for b in bones for p in b] + [p for s in placed.values() for p in s.values()])
    frontal = bool(np.abs(points[:, 1] - points[:, 1].mean()).max() > PLANAR)
    views = [("sagittal (x forward, z up)", 0, "x [m]")] + ([("frontal (y left, z up)", 1, "y [m]")] if frontal else [])
    fig, axes = new_figure(1, len(views), figsize=(5.2 * len(views), 6.6), squeeze=False)
    for ax, (name, h, label) in zip(axes[0], views):
        for a, b in bones:
            ax.plot([a[h], b[h]], [a[2], b[2]], "-", color="0.4", lw=1.8, solid_capstyle="round", zorder=3)
        labels: dict[tuple, list[str]] = {}  # segments drawn on one spot (both legs, side on) share a label
        for k, (seg, s) in enumerate(placed.items()):
            colour = f"C{k % 10}"
            ax.plot(
                [s["start"][h], s["end"][h]],
                [s["start"][2], s["end"][2]],
                "-",
                color=colour,
                lw=7,
                alpha=0.35,
                gid=f"segment:{seg}",
            )
            if np.linalg.norm(s["start"] - s["attach"]) > PLANAR:  # a segment starting away from its frame
                ax.plot([s["attach"][h], s["start"][h]], [s["attach"][2], s["start"][2]], ":", color=colour, lw=1.2)
            ax.plot([s["attach"][h]], [s["attach"][2]], "s", color=colour, ms=7, mec="k", zorder=4, gid=f"attach:{seg}")
            ax.plot([s["com"][h]], [s["com"][2]], "o", color=colour, ms=8, mec="k", zorder=5, gid=f"com:{seg}")
            labels.setdefault((round(s["com"][h], 3), round(s["com"][2], 3)), []).append(seg)
        for (u, z), names in labels.items():
            ax.annotate(" / ".join(names), (u, z), xytext=(7, 3), textcoords="offset points", fontsize=8)
        ax.set_aspect("equal", adjustable="datalim")
        ax.margins(0.12)
        ax.grid(alpha=0.3)
        ax.set_xlabel(label)
        ax.set_ylabel("z [m]")
        ax.set_title(name, fontsize=10)
    handles = [
        axes[0, 0].plot([], [], "-", color="0.4", lw=1.8)[0],
        axes[0, 0].plot([], [], "-", color="C0", lw=7, alpha=0.35)[0],
        axes[0, 0].plot([], [], "ks", mfc="w")[0],
        axes[0, 0].plot([], [], "ko", mfc="w")[0],
    ]
    what = [
        "exoskeleton, zero pose (joints, fixed frames)",
        "segment (table length)",
        "attachment: exo link frame",
        "segment CoM",
    ]
    fig.legend(handles, what, loc="lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(title or "where the wearer's segments attach", fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    return fig


def _bodies(result: Mapping) -> list[str]:
    return [j for j in result["bodies"] if f"{j}.m" in result["parameters"]]


def segment_masses_figure(result: Mapping, *, title: str = ""):
    """Stage 2 against the tables: per exo body carrying wearer segments (``result["bodies"]``), the
    identified mass [kg] of the wearer's share (bars) with the table's value marked (black line), and its
    centre of mass about the joint frame [m] (``m·c / m``; one bar per coordinate the tables or the fit
    move off zero), the table's marked the same way.  ``result``: the stage-2 ``identification.json`` dict
    (``parameters``, ``table``, ``bodies`` and, when given, ``marks``).  Returns the figure."""
    if not isinstance(result, Mapping) or not all(k in result for k in ("parameters", "table", "bodies")):
        raise SpecError("result: expected the stage-2 result dict (parameters, table, bodies)")
    bodies = _bodies(result)
    fit, table, marks = result["parameters"], result["table"], result.get("marks") or {}
    mass = np.array([[fit[f"{j}.m"], table[f"{j}.m"]] for j in bodies])
    com = np.array(
        [[[fit[f"{j}.m{a}"] / fit[f"{j}.m"], table[f"{j}.m{a}"] / table[f"{j}.m"]] for a in "xyz"] for j in bodies]
    )  # (bodies, axis, identified | table)
    shown = [a for a in range(3) if np.abs(com[:, a, :]).max() > 1e-6]
    fig, (ax_m, ax_c) = new_figure(1, 2, figsize=(4.0 + 1.6 * len(bodies), 4.6), squeeze=True)
    x = np.arange(len(bodies))
    ax_m.bar(x, mass[:, 0], 0.6, color="C0", label="identified")
    ax_m.hlines(mass[:, 1], x - 0.38, x + 0.38, color="k", lw=2, label="table", gid="table:m")
    for k in range(len(bodies)):  # the identified value inside its bar, clear of the table's line
        ax_m.text(x[k], 0.5 * mass[k, 0], f"{mass[k, 0]:.3g} kg", ha="center", va="center", color="w", fontsize=8)
    ax_m.set_ylabel("wearer's mass on the body [kg]")
    ticks = [f"{j}\n({', '.join(result['bodies'][j])})" for j in bodies]
    ax_m.set_xticks(
        x, [t + (f"\nm: {marks[f'{j}.m']}" if f"{j}.m" in marks else "") for t, j in zip(ticks, bodies)], fontsize=8
    )
    ax_m.set_title("mass", fontsize=10)
    width = 0.8 / max(len(shown), 1)
    for k, a in enumerate(shown):
        pos = x - 0.4 + (k + 0.5) * width
        ax_c.bar(pos, com[:, a, 0], width * 0.9, color=f"C{k + 1}", label=f"c{'xyz'[a]} identified")
        ax_c.hlines(com[:, a, 1], pos - 0.45 * width, pos + 0.45 * width, color="k", lw=2, gid=f"table:c{'xyz'[a]}")
    ax_c.plot([], [], "k-", lw=2, label="table")
    ax_c.axhline(0, color="0.3", lw=0.6)
    ax_c.set_xticks(x, ticks, fontsize=8)
    ax_c.set_ylabel("centre of mass about the joint frame [m]")
    ax_c.set_title("centre of mass (m·c / m)", fontsize=10)
    for ax in (ax_m, ax_c):
        ax.grid(axis="y", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(title or "stage 2 against the tables: the wearer's share of each body", fontsize=11)
    fig.tight_layout()
    return fig


def _panel(ax, figsize: tuple[float, float] = (6.0, 3.5)):
    """``(figure, axes)``: ``ax`` and its figure, or a new figure of one panel."""
    return new_figure(figsize=figsize) if ax is None else (ax.figure, ax)


def base_parameters_figure(names: list[str], base, table, *, ax=None):
    """Stage 2's base parameters: each one identified (bar) and from the tables (black mark), on a
    symmetric-log axis (masses [kg], first moments [kg·m], inertias [kg·m²] and scale factors share it);
    into ``ax`` when given.  Returns the figure."""
    base, table = np.asarray(base, dtype=float), np.asarray(table, dtype=float)
    if not (len(names) == len(base) == len(table)):
        raise SpecError(f"names, base, table: lengths {len(names)}, {len(base)}, {len(table)}, expected equal ones")
    fig, ax = _panel(ax, (6.0, 1.2 + 0.28 * len(names)))
    y = np.arange(len(names))
    ax.barh(y, base, 0.6, color="C0", label="identified")
    ax.vlines(table, y - 0.38, y + 0.38, color="k", lw=2, label="table", gid="table")
    ax.set_yticks(y, [str(n) for n in names], fontsize=7)
    ax.invert_yaxis()
    scale = np.abs(np.concatenate([base, table]))
    ax.set_xscale("symlog", linthresh=max(1e-2 * float(scale.max(initial=0.0)), 1e-9))
    ax.axvline(0, color="0.3", lw=0.6)
    ax.set_xlabel("value (SI units of each parameter; symmetric log)")
    ax.set_title("stage 2: the wearer's base parameters against the tables", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def prior_weight_figure(cross_validation: Mapping, chosen: float, *, ax=None):
    """The held-out torque RMS [N·m] per prior weight λ of stage 2's blocked cross-validation
    (``cross_validation``: ``{"weights", "heldout_rms", "folds"}``), the ``chosen`` λ marked; λ = 0 drawn at
    the left end of the log axis.  Into ``ax`` when given.  Returns the figure."""
    if not isinstance(cross_validation, Mapping) or not {"weights", "heldout_rms"} <= set(cross_validation):
        raise SpecError("cross_validation: expected the dict of choose_prior_weight (weights, heldout_rms, folds)")
    fig, ax = _panel(ax)
    w = np.asarray(cross_validation["weights"], dtype=float)
    rms = np.asarray(cross_validation["heldout_rms"], dtype=float)
    floor = 0.1 * w[w > 0].min() if np.any(w > 0) else 1.0  # where λ = 0 sits on the log axis
    x = np.where(w > 0, w, floor)
    ax.plot(x, rms, "o-", color="C0", label="held-out torque RMS")
    pick = int(np.argmin(np.abs(w - chosen)))
    ax.plot(x[pick], rms[pick], "o", ms=11, mfc="none", mec="C3", mew=2, label=f"chosen λ = {chosen:g}")
    ax.set_xscale("log")
    ax.set_xticks(x, [f"{v:g}" for v in w], fontsize=8)
    ax.set_xlabel("prior weight λ")
    ax.set_ylabel("held-out torque RMS [N·m]")
    ax.set_title(f"stage 2: λ by {cross_validation.get('folds', '?')}-fold blocked cross-validation", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def rms_figure(rms: Mapping[str, Mapping[str, float]], kind: str = "validation", *, ax=None):
    """Stage 2's torque RMS error [N·m] per joint (``rms``: ``{model: {joint: rms}}``, :meth:`WearerFit.rms`'s
    form) of exo + identified wearer, exo + table wearer and exo alone, grouped bars; ``kind`` names the
    recordings in the title.  Into ``ax`` when given.  Returns the figure."""
    if not isinstance(rms, Mapping) or not rms:
        raise SpecError("rms: expected {model: {joint: torque RMS}} (WearerFit.rms)")
    models = list(rms)
    joints = list(next(iter(rms.values())))
    fig, ax = _panel(ax)
    x = np.arange(len(joints))
    width = 0.8 / len(models)
    labels = {"identified": "exo + identified wearer", "table": "exo + table wearer", "exo": "exo alone"}
    for k, m in enumerate(models):
        ax.bar(
            x - 0.4 + (k + 0.5) * width, [rms[m][j] for j in joints], width * 0.9, color=f"C{k}", label=labels.get(m, m)
        )
    ax.set_xticks(x, joints, fontsize=8)
    ax.set_ylabel("torque RMS error [N·m]")
    ax.set_title(f"stage 2: torque RMS error per joint ({kind})", fontsize=10)
    ax.grid(axis="y", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
