"""What ``pinid simulate`` makes and writes around the twin (:func:`pinid.simulation.twin.simulate`),
reachable from Python: a CAD model (the truth perturbed) and its place in the truth, and the run's files —
the recording, its truth, the noise-free signals, the CAD URDF — all or nothing (:class:`pinid.io.Artefacts`)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from pinid.data.dataset import Dataset, as_dataset
from pinid.data.formats import write_recording
from pinid.io import Artefacts
from pinid.model.base import base_parameters
from pinid.model.export import identified_urdf
from pinid.model.regressor import standard_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.simulation.cad import perturb
from pinid.simulation.twin import save_truth
from pinid.errors import OutputError
from pinid.io import as_path
from pinid.model.robot import as_robot
from pinid.errors import SpecError


def cad_model(model: RobotModel, percent: float, seed: int) -> RobotModel:
    """A "CAD" model of ``model``: its inertial parameters perturbed by about ``percent`` %, physically
    consistent (:func:`~pinid.simulation.twin.perturb`), seeded by ``seed`` (apart from the twin's noise)."""
    model = as_robot(model)
    return perturb(model, percent, np.random.default_rng(np.random.SeedSequence([int(seed), 1])))


def cad_truth(truth: dict, model: RobotModel, cad: RobotModel, percent: float) -> dict:
    """The ``"cad"`` entry of a twin's ``truth``: ``percent`` and the CAD model's standard parameters (named
    as the truth's) and base parameters (those of ``model``), with the default terms (fc, fv)."""
    terms = TermSelection()
    theta = standard_parameters(cad, terms)
    bp = base_parameters(model, terms)
    return {
        "percent": float(percent),
        "standard": {"names": truth["standard"]["names"], "values": theta.tolist()},
        "base": {"names": bp.names, "values": bp.from_standard(theta).tolist()},
    }


def truth_path_for(path: str | os.PathLike) -> Path:
    """Where a recording's truth goes by default: ``run.csv`` → ``run.truth.json``."""
    path = as_path(path)
    p = Path(path)
    return p.with_name(p.stem + ".truth.json")


def simulation_paths(path, *, truth_path=None, true_signals=None, cad_urdf=None, figure=None) -> list[Path]:
    """The files :func:`write_simulation` writes for these arguments, in its order (to check them early)."""
    path = as_path(path, error=OutputError)
    extra = (true_signals, cad_urdf, figure)
    return [Path(path), Path(truth_path or truth_path_for(path))] + [Path(p) for p in extra if p]


def write_simulation(
    recording: Dataset,
    truth: dict,
    path: str | os.PathLike,
    *,
    truth_path: str | os.PathLike | None = None,
    true_signals: str | os.PathLike | None = None,
    cad: RobotModel | None = None,
    cad_urdf: str | os.PathLike | None = None,
    figure: str | os.PathLike | None = None,
    reference: np.ndarray | None = None,
    overwrite: bool | None = None,
) -> list[Path]:
    """Write a twin's run (:func:`pinid.simulation.twin.simulate`'s ``(recording, truth)``, fixed or floating
    base), all or nothing: the ``recording`` at ``path`` (CSV or NPZ; a floating one with its floating
    channels), the ``truth`` as JSON (default :func:`truth_path_for`; without its in-memory ``signals``),
    with ``true_signals`` the noise-free signals ``truth["signals"]``, with ``cad_urdf`` the URDF of the
    ``cad`` model (its percent from ``truth["cad"]``), with ``figure`` a PNG of the run
    (:func:`pinid.report.plot_simulation.simulation_figure`; written behind, :func:`pinid.io.written_behind`):
    per joint, on a fixed base the ``reference`` positions (N, nv) [rad] at the recording's times and the
    simulated ones ``truth["signals"].q``, on a floating base (no ``reference``: the legs follow it exactly)
    the prescribed ones ``truth["signals"].q`` and the recorded ones; their difference and the recorded
    torque.  ``overwrite``: replace existing files (None: the :data:`pinid.io.OVERWRITE` policy, which the
    CLI's ``--force`` sets)."""
    recording = as_dataset(recording, "recording")
    if not isinstance(truth, dict):
        raise SpecError(f"truth: got {type(truth).__name__}, expected the truth dict of simulate")
    if (figure or true_signals) and "signals" not in truth:
        raise SpecError('truth: no "signals", expected the truth dict of simulate (its JSON leaves them out)')
    if figure is not None and reference is None and recording.floating is None:
        raise SpecError("reference: got None, expected the reference positions (N, nv) [rad] to draw the figure")
    arts = Artefacts(overwrite=overwrite)
    arts.add(path, lambda p: write_recording(p, recording))
    arts.add(truth_path or truth_path_for(path), lambda p: save_truth(p, truth))
    if true_signals:
        arts.add(true_signals, lambda p: write_recording(p, truth["signals"]))
    if cad_urdf:
        terms = TermSelection()
        arts.add(
            cad_urdf,
            lambda p: identified_urdf(
                cad,
                standard_parameters(cad, terms),
                terms,
                p,
                origin="a CAD model written by pinid simulate",
                comment=f"the truth's inertial parameters perturbed by about {truth['cad']['percent']:g} %, "
                f"seed {truth['seed']}",
            ),
        )
    if figure:
        arts.add(figure, lambda _: _figure_png(recording, truth, reference), behind=True)
    return arts.write()


def _figure_png(recording: Dataset, truth: dict, reference) -> bytes:
    """The PNG of :func:`write_simulation`'s ``figure``."""
    from pinid.report.figures import figure_png
    from pinid.report.plot_simulation import simulation_figure

    true = truth["signals"]
    if recording.floating is None:
        title = f"pinid simulate: {truth['robot']}, seed {truth['seed']}, {recording.n} samples"
        fig = simulation_figure(recording.t, reference, true.q, recording.tau, recording.joints, title=title)
        return figure_png(fig)
    # a floating base: the legs follow the prescribed positions exactly, the recorded ones differ by the noise
    title = f"pinid simulate --base floating: {truth['kind']} {truth['robot']}, {true.n} samples"
    fig = simulation_figure(
        true.t,
        true.q,
        recording.q,
        recording.tau if recording.tau is not None else true.tau,  # the exact torque when none is recorded
        true.joints,
        title=title,
        error_label="recorded − prescribed (encoder noise)",
        position_labels=("prescribed", "recorded"),
    )
    return figure_png(fig)


#: Width of what ``pinid simulate`` prints [columns].
WIDTH = 100


def _wrapped(label: str, items: list[str], column: int) -> list[str]:
    """``label`` indented by 2, then ``items`` comma-separated from ``column`` on, wrapped at :data:`WIDTH`
    between items (never inside one), each continuation aligned at ``column``."""
    lines, line = [], f"  {label}".ljust(column)
    for k, item in enumerate(items):
        text = item + ("," if k < len(items) - 1 else "")
        if len(line) > column and len(line) + 1 + len(text) > WIDTH:
            lines.append(line)
            line = " " * column
        line += ("" if len(line) == column else " ") + text
    return lines + [line]


def simulation_text(
    recording: Dataset, truth: dict, path, *, truth_path=None, true_signals=None, cad_urdf=None, figure=None
) -> str:
    """What ``pinid simulate`` prints after :func:`write_simulation`: each file written, with the samples,
    rate, joints and tracking error [rad] of the recording and the parameter counts of the truth; of a floating
    base's run what was simulated and recorded, then the files."""
    recording = as_dataset(recording, "recording")
    if recording.floating is not None:
        return _floating_text(recording, truth, simulation_paths(path, truth_path=truth_path, figure=figure))
    track = [f"{j} {v:.2g}" for j, v in truth["tracking"]["rms_error"].items()]
    first = "\n".join(  # one labelled block each, wrapped at WIDTH and aligned (a UR5's names are long)
        [f"wrote {path} ({recording.n} samples at {truth['rates']['sample']} Hz)"]
        + _wrapped("joints", recording.joints, 28)
        + _wrapped("tracking error rms [rad]", track, 28)
    )
    lines = [
        first,
        f"wrote {truth_path or truth_path_for(path)} ({len(truth['standard']['names'])} standard, "
        f"{len(truth['base']['names'])} base parameters)",
    ]
    if true_signals:
        lines.append(f"wrote {true_signals} (noise-free signals)")
    if cad_urdf:
        lines.append(f"wrote {cad_urdf} (CAD model: inertia perturbed by about {truth['cad']['percent']:g} %)")
    if figure:
        lines.append(f"wrote {figure} (per joint: reference and simulated q, tracking error, measured torque)")
    return "\n".join(lines)


def _floating_text(recording: Dataset, truth: dict, written: list[Path]) -> str:
    """:func:`simulation_text` of a floating base's run (``pinid simulate --base floating``)."""
    rec, s = recording.floating, truth["signals"]
    what = [f"{len(s.joints)} joints"]
    what.append(f"IMU on {rec.imu_frame}" if rec.imu_frame else "base pose (motion capture)")
    what += [f"wrench on {k} (link frame)" for k in rec.wrenches] + [f"force plate under {k}" for k in rec.plates]
    if rec.contacts:
        what.append("contact phases")
    return (
        f"simulated {truth['kind']} {truth['robot']} on a floating base: {s.n} samples, "
        f"{s.duration:.3g} s; recorded {', '.join(what)}\nwrote " + ", ".join(str(p) for p in written)
    )
