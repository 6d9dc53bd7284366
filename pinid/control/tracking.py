"""A tracking study's reference, table and files: what ``pinid track`` prints and writes, from Python.

The study itself is :func:`pinid.control.controllers.compare_models` (every controller on every model,
the same noise); its result ``{controller: {model: {"metrics", "result"}}}`` is what these functions take.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pinid.excitation.trajectory import FourierTrajectory
from pinid.io import Artefacts, json_text
from pinid.model.robot import RobotModel
from pinid.report.figures import render_pngs
from pinid.report.plot_control import tracking_figure, tracking_models_figure
from pinid.report.text import text_table
from pinid.errors import OutputError, SpecError
from pinid.io import as_path
from pinid.model.robot import as_robot


def sine_reference(plant: RobotModel) -> FourierTrajectory:
    """Seed 001's reference, x_d = sin(0.5πt), scaled into the middle of each joint's range [rad]."""
    plant = as_robot(plant)
    lo = np.where(np.isfinite(plant.lower), plant.lower, -1.0)
    hi = np.where(np.isfinite(plant.upper), plant.upper, 1.0)
    centre, amp = 0.5 * (lo + hi), np.minimum(0.35 * (hi - lo), 0.6)
    return FourierTrajectory(plant.joint_names, 0.5 * np.pi, centre, amp[:, None], np.zeros((plant.nv, 1)))


def load_reference(spec: str, plant: RobotModel) -> FourierTrajectory:
    """The reference ``spec`` names, for ``plant``'s joints: ``"sine"`` (:func:`sine_reference`) or the path
    of a trajectory JSON of ``pinid excite`` (its joints mapped by name)."""
    reference = sine_reference(plant) if spec == "sine" else FourierTrajectory.load(spec)
    return reference.for_joints(plant.joint_names, plant.name)


def tracking_table(table: dict, *, after: float | None = None) -> str:
    """The tracking errors as a text table: per controller, model (a file's name) and joint, the RMS and
    maximum error [mrad] after the start-up, the settling time [s] and the band [mrad] it settles into;
    with ``after`` [s] (where the statistics start), a line below saying what each column covers."""
    if not isinstance(table, dict):
        raise SpecError(f"table: got {type(table).__name__}, expected the tracking table (a dict)")
    if after is not None and (isinstance(after, bool) or not isinstance(after, (int, float)) or not after >= 0):
        raise SpecError(f"after: got {after!r}, expected the start of the statistics in seconds (≥ 0)")
    rows = []
    for c, per_model in table.items():
        for name, entry in per_model.items():
            label = name if name == "nominal" else Path(name).name
            for joint, m in entry["metrics"].items():
                settle = "never" if not np.isfinite(m["settling_time"]) else f"{m['settling_time']:.2f}"
                band = f"{1e3 * m['band']:.3g}" if "band" in m else "-"
                rows.append([c, label, joint, f"{1e3 * m['rms']:.3f}", f"{1e3 * m['max_abs']:.3f}", settle, band])
    header = ["controller", "model", "joint", "RMS [mrad]", "max [mrad]", "settle [s]", "band [mrad]"]
    text = text_table(header, rows, keys=3)
    if after is None:
        return text
    return (
        f"{text}\nRMS, max: over t ≥ {after:g} s (--after; the start-up before it, shaded in the figures, is left out)"
        "\nsettle: from t = 0, the time after which |error| stays inside the band; band: 2 % of the joint's"
        "\nreference range, at least 1 mrad (dotted in the figures)"
    )


def tracking_paths(folder: str | os.PathLike, controllers, *, figures: bool = True) -> list[Path]:
    """The files :func:`write_tracking` writes into ``folder`` for ``controllers`` (to check them early)."""
    folder = as_path(folder, "folder", error=OutputError)
    out = Path(folder)
    if not figures:
        return [out / "tracking.json"]
    return [out / "tracking.json", *(out / f"tracking_{c}.png" for c in controllers), out / "tracking_models.png"]


def _model_labels(names) -> dict[str, str]:
    """A short label per model: its file's name (``nominal`` and ``cad:30`` as given), the path as given
    when two files share a name."""
    short = {n: n if n == "nominal" else Path(n).name for n in names}
    return {n: s if list(short.values()).count(s) == 1 else n for n, s in short.items()}


def write_tracking(
    table: dict,
    folder: str | os.PathLike,
    *,
    plant: RobotModel,
    settings: dict,
    figures: bool = True,
    overwrite: bool | None = None,
) -> list[Path]:
    """Write ``tracking.json`` (the plant's URDF, ``settings`` such as the reference, seconds, after,
    seed, and every metric) and, with ``figures``, one figure ``tracking_<controller>.png`` per controller
    and ``tracking_models.png`` (the RMS error per joint of every model × controller, as grouped bars) into
    ``folder``, all or nothing.  ``overwrite``: replace existing files (None: the :data:`pinid.io.OVERWRITE`
    policy)."""
    if not isinstance(table, dict):
        raise SpecError(f"table: got {type(table).__name__}, expected the tracking table (a dict)")
    if not isinstance(settings, dict):
        raise SpecError(f"settings: got {type(settings).__name__}, expected a dict (reference, seconds, after, seed)")
    out = Path(folder)
    after = float(settings.get("after", 0.0))
    arts = Artefacts(overwrite=overwrite)
    arts.add(
        out / "tracking.json",
        json_text(
            {
                "plant": str(plant.urdf_path),
                **settings,
                "results": {c: {n: e["metrics"] for n, e in pm.items()} for c, pm in table.items()},
            }
        ),
    )
    if not figures:
        return arts.write()
    recipes = {
        f"tracking_{c}.png": (tracking_figure, ({n: e["result"] for n, e in pm.items()},), {"title": c, "after": after})
        for c, pm in table.items()
    }
    labels = _model_labels([n for pm in table.values() for n in pm])
    rms = {
        c: {labels[n]: {j: m["rms"] for j, m in e["metrics"].items()} for n, e in pm.items()} for c, pm in table.items()
    }
    title = f"RMS tracking error per joint after t = {after:g} s: every model × controller"
    recipes["tracking_models.png"] = (tracking_models_figure, (rms,), {"title": title})
    for name, png in render_pngs(recipes).items():  # one figure per core (pinid.report.figures); not written
        arts.add(out / name, png)  # behind: the demo's last step, whose figures nothing else would wait beside
    return arts.write()
