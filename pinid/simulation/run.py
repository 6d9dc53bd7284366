"""``pinid simulate`` in one call: the twin follows a trajectory, its truth is completed (the CAD model of
``--perturb``, the wearer drawn by ``--wearer-draw``, the command) and the run's files are written, all or
nothing; the call returns what the command prints.  The twin itself is :mod:`pinid.simulation.twin` (a
floating base: :mod:`pinid.simulation.floating_twin`), the files :mod:`pinid.simulation.outputs`."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence

from pinid.errors import SpecError
from pinid.io import as_path
from pinid.model.robot import RobotModel, as_robot
from pinid.simulation.floating_twin import BaseSensors
from pinid.simulation.outputs import (
    floating_text,
    write_floating_run,
    cad_model,
    cad_truth,
    drawn_wearer_truth,
    simulation_text,
    write_simulation,
)
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import Controller, Friction, Rates, Sensors, simulate


def simulate_and_write(
    model: RobotModel,
    excitation: str,
    path: str | os.PathLike,
    *,
    seconds: float = 60.0,
    seed: int = 0,
    flip: Sequence[str] = (),
    rates: Rates | None = None,
    controller: Controller | None = None,
    friction: Friction | None = None,
    sensors: Sensors | BaseSensors | None = None,
    wearer: dict | None = None,
    drawn_wearer: tuple[dict, dict] | None = None,
    wearer_torque: float = 0.0,
    perturb: float | None = None,
    truth_path: str | os.PathLike | None = None,
    true_signals: str | os.PathLike | None = None,
    cad_urdf: str | os.PathLike | None = None,
    figure: str | os.PathLike | None = None,
    command: str | None = None,
) -> str:
    """Simulate ``model`` (the truth) following ``excitation`` (:func:`~pinid.simulation.trajectories.load_trajectory`:
    a trajectory JSON, a bundled name or a preset, ``flip`` negating joints) for ``seconds`` [s], write the
    recording at ``path`` with its truth (:func:`~pinid.simulation.outputs.write_simulation`) and return the
    summary :func:`~pinid.simulation.outputs.simulation_text` gives.

    ``rates``, ``controller``, ``friction``, ``sensors``: the twin's option groups (:func:`~pinid.simulation.twin.simulate`);
    ``wearer``: the wearer segments the twin carries (:func:`pinid.wearer.attach.wearer_links`; the caller
    finds them: the wearer is a layer above the twin); ``drawn_wearer``: ``(table values, drawn values)`` when
    ``model``'s wearer was drawn away from the tables (:func:`pinid.wearer.prior.draw_wearer`), kept in
    ``truth["wearer"]["drawn"]``;
    ``wearer_torque`` [%]: the wearer's involuntary torque; ``perturb`` [%]: the feed-forward from a CAD model
    that far from the truth (``truth["cad"]``; ``cad_urdf`` writes it); ``figure``: a PNG of the run (per
    joint the reference and simulated position, the tracking error, the recorded torque); ``command``: the
    command line kept in ``truth["command"]``.

    A floating model (``pinid simulate --base floating``) runs the floating twin (:func:`~pinid.simulation.twin.simulate`;
    ``excitation`` also "gait"; ``sensors`` a :class:`~pinid.simulation.floating_twin.BaseSensors`, the rate
    ``rates.sample`` or ``rates.control``) and writes its recording and truth
    (:func:`~pinid.simulation.outputs.write_floating_run`); the fixed-base options (``flip``,
    ``controller``, ``friction``, the wearer's, ``perturb``, ``true_signals``, ``cad_urdf``) raise SpecError.
    """
    model = as_robot(model)
    path = as_path(path)
    if not isinstance(excitation, str):
        raise SpecError(f"excitation: got {type(excitation).__name__}, expected a trajectory path, name or preset")
    if model.base == "floating":
        fixed = {"flip": flip or None, "controller": controller, "friction": friction, "wearer": wearer}
        fixed |= {"drawn_wearer": drawn_wearer, "wearer_torque": wearer_torque or None, "perturb": perturb}
        fixed |= {"true_signals": true_signals, "cad_urdf": cad_urdf}
        wrong = [k for k, v in fixed.items() if v is not None]
        if wrong:
            raise SpecError(f"{wrong[0]}: for a fixed-base model only, {model.name} has a floating base")
        run = simulate(model, excitation, seconds=seconds, seed=seed, rates=rates, sensors=sensors or BaseSensors())
        if command is not None:
            run.truth["command"] = command
        return floating_text(run, write_floating_run(run, path, truth_path, figure=figure))
    trajectory = load_trajectory(excitation, model, flip=flip)
    cad = None if perturb is None else cad_model(model, perturb, seed)
    if cad is not None:  # the feed-forward's model
        controller = dataclasses.replace(controller or Controller(), feedforward_model=cad)
    ds, truth = simulate(
        model,
        trajectory,
        seconds=seconds,
        seed=seed,
        rates=rates,
        controller=controller,
        friction=friction,
        sensors=sensors,
        wearer_torque=wearer_torque,
        wearer=wearer,
        progress=None,
    )
    if cad is not None:
        truth["cad"] = cad_truth(truth, model, cad, perturb)
    if drawn_wearer is not None:
        truth["wearer"]["drawn"] = drawn_wearer_truth(*drawn_wearer)
    if command is not None:
        truth["command"] = command
    files = {"truth_path": truth_path, "true_signals": true_signals, "cad_urdf": cad_urdf, "figure": figure}
    reference = trajectory.for_joints(model.joint_names, model.name).evaluate(ds.t)[0] if figure else None
    write_simulation(ds, truth, path, cad=cad, reference=reference, **files)
    return simulation_text(ds, truth, path, **files)
