"""``pinid simulate`` in one call, whatever the base: the twin follows a trajectory, its truth is completed (the
CAD model of ``--perturb``, the wearer drawn by ``--wearer-draw``, the command) and the run's files are written,
all or nothing; the call returns what the command prints.  The twin itself is :mod:`pinid.simulation.twin` (a
floating base, a :class:`~pinid.model.floating.FloatingRobotModel`: :mod:`pinid.simulation.floating_twin`),
the files :mod:`pinid.simulation.outputs`.  The options come in groups, each for the base it fits:
:class:`FixedBase` and :class:`~pinid.simulation.twin.WearerLoad` for a fixed base,
:class:`~pinid.simulation.floating_twin.BaseSensors` for a floating one, :class:`Outputs` for both; a group
given for the other base is refused (SpecError, one line)."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence

from pinid.checks import of_type
from pinid.errors import SpecError
from pinid.io import as_path
from pinid.model.floating import FloatingRobotModel
from pinid.model.robot import RobotModel, as_robot
from pinid.simulation.floating_twin import BaseSensors
from pinid.simulation.outputs import cad_model, cad_truth, simulation_text, write_simulation
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import Controller, Friction, Rates, Sensors, WearerLoad, simulate


@dataclasses.dataclass(frozen=True)
class FixedBase:
    """The fixed-base twin's options (:func:`~pinid.simulation.twin.simulate`): its ``rates``, ``controller``,
    ``friction`` and ``sensors`` groups (None: their defaults) and ``perturb`` [%]: the feed-forward from a CAD
    model that far from the truth (``truth["cad"]``; :attr:`Outputs.cad_urdf` writes it)."""

    rates: Rates | None = None
    controller: Controller | None = None
    friction: Friction | None = None
    sensors: Sensors | None = None
    perturb: float | None = None

    def __post_init__(self) -> None:
        for key, kind in (("rates", Rates), ("controller", Controller), ("friction", Friction), ("sensors", Sensors)):
            of_type(getattr(self, key), kind, f"FixedBase {key}", f"a {kind.__name__} or None")
        of_type(self.perturb, (int, float), "FixedBase perturb", "a percentage or None")


@dataclasses.dataclass(frozen=True)
class Outputs:
    """What a run writes besides the recording: ``truth_path`` (default ``<path stem>.truth.json``),
    ``figure`` (a PNG of the run: per joint the reference and simulated position, their difference, the
    recorded torque), for a fixed base ``true_signals`` (the noise-free signals) and ``cad_urdf`` (the CAD
    model of :attr:`FixedBase.perturb`); ``command``: the command line kept in ``truth["command"]``."""

    truth_path: str | os.PathLike | None = None
    true_signals: str | os.PathLike | None = None
    cad_urdf: str | os.PathLike | None = None
    figure: str | os.PathLike | None = None
    command: str | None = None

    def __post_init__(self) -> None:
        for key in ("truth_path", "true_signals", "cad_urdf", "figure"):
            of_type(getattr(self, key), (str, os.PathLike), f"Outputs {key}", "a path or None")
        of_type(self.command, str, "Outputs command", "a command line or None")

    def files(self) -> dict:
        """The paths, as :func:`~pinid.simulation.outputs.write_simulation` takes them."""
        return {k: getattr(self, k) for k in ("truth_path", "true_signals", "cad_urdf", "figure")}


def _group(value, kind: type, name: str):
    if value is None:
        return kind()
    if not isinstance(value, kind):
        raise SpecError(f"{name}: got {type(value).__name__}, expected {kind.__name__} or None")
    return value


def simulate_and_write(
    model: RobotModel,
    excitation: str,
    path: str | os.PathLike,
    *,
    seconds: float | None = None,
    seed: int = 0,
    flip: Sequence[str] = (),
    fixed: FixedBase | None = None,
    floating: BaseSensors | None = None,
    wearer: WearerLoad | None = None,
    outputs: Outputs | None = None,
) -> str:
    """Simulate ``model`` (the truth) following ``excitation`` for ``seconds`` [s] (default 60 on a fixed base,
    10 on a floating one), write the recording at ``path`` with its truth and return what ``pinid simulate``
    prints.

    A fixed base (:func:`~pinid.simulation.twin.simulate`): ``excitation`` as
    :func:`~pinid.simulation.trajectories.load_trajectory` takes it (a trajectory JSON, a bundled name or a
    preset, ``flip`` negating joints), the twin's options ``fixed`` (:class:`FixedBase`), the ``wearer`` it
    carries (:class:`~pinid.simulation.twin.WearerLoad`); written by :func:`~pinid.simulation.outputs.write_simulation`, summed up
    by :func:`~pinid.simulation.outputs.simulation_text`.  A floating base
    (:class:`~pinid.model.floating.FloatingRobotModel`, :mod:`pinid.simulation.floating_twin`): ``excitation``
    "gait" walks, anything else is a trajectory the suspended legs follow
    (:func:`~pinid.simulation.twin.simulate` of a floating model; no ``flip``), with the options ``floating``
    (:class:`~pinid.simulation.floating_twin.BaseSensors`: noise, IMU, sample rate); written and summed up by the
    same two.  ``outputs``: the other files and the command line (:class:`Outputs`).  A group for the other base:
    SpecError."""
    model = as_robot(model)
    path = as_path(path)
    if not isinstance(excitation, str):
        raise SpecError(f"excitation: got {type(excitation).__name__}, expected a trajectory path, name or preset")
    outputs = _group(outputs, Outputs, "outputs")
    if isinstance(model, FloatingRobotModel):
        for name, value in (("fixed", fixed), ("wearer", wearer)):
            if value is not None:
                raise SpecError(
                    f"{name}: a {type(value).__name__} is for a fixed-base twin, not the floating {model.name}"
                )
        return _floating_and_write(
            model, excitation, path, seconds, seed, flip, _group(floating, BaseSensors, "floating"), outputs
        )
    if floating is not None:
        raise SpecError(
            f"floating: a {type(floating).__name__} is for a floating-base twin, not the fixed-base {model.name}"
        )
    fixed, wearer = _group(fixed, FixedBase, "fixed"), _group(wearer, WearerLoad, "wearer")
    trajectory = load_trajectory(excitation, model, flip=flip)
    cad = None if fixed.perturb is None else cad_model(model, fixed.perturb, seed)
    controller = fixed.controller
    if cad is not None:  # the feed-forward's model
        controller = dataclasses.replace(controller or Controller(), feedforward_model=cad)
    ds, truth = simulate(
        model,
        trajectory,
        seconds=60.0 if seconds is None else seconds,
        seed=seed,
        rates=fixed.rates,
        controller=controller,
        friction=fixed.friction,
        sensors=fixed.sensors,
        wearer=wearer,
        progress=None,
    )
    if cad is not None:
        truth["cad"] = cad_truth(truth, model, cad, fixed.perturb)
    if outputs.command is not None:
        truth["command"] = outputs.command
    files = outputs.files()
    reference = trajectory.for_joints(model.joint_names, model.name).evaluate(ds.t)[0] if outputs.figure else None
    write_simulation(ds, truth, path, cad=cad, reference=reference, **files)
    return simulation_text(ds, truth, path, **files)


def _floating_and_write(model, excitation, path, seconds, seed, flip, sensors: BaseSensors, outputs: Outputs) -> str:
    """``pinid simulate --base floating``: the gait or suspended twin, its truth and files."""
    unused = [k for k in ("true_signals", "cad_urdf") if getattr(outputs, k) is not None]
    if unused:
        raise SpecError(
            f"outputs {', '.join(unused)}: written by a fixed-base twin only, not the floating {model.name}"
        )
    if flip:
        raise SpecError(f"flip {list(flip)}: the floating twin takes the trajectory as it is (flip it in its JSON)")
    seconds = 10.0 if seconds is None else seconds
    recording, truth = simulate(model, excitation, seconds=seconds, seed=seed, sensors=sensors)
    if outputs.command is not None:
        truth["command"] = outputs.command
    write_simulation(recording, truth, path, truth_path=outputs.truth_path, figure=outputs.figure)
    return simulation_text(recording, truth, path, truth_path=outputs.truth_path, figure=outputs.figure)
