"""The wearer workflow end to end on the twin (issue 18's figures): stage 1, stage 2, validation, control.

1. Stage 1: a twin recording of the bare exoskeleton (default noise) identified with ``sdp``.
2. The true wearer: the exo + wearer URDF's table wearer drawn away from the tables
   (:func:`pinid.wearer.prior.draw_wearer`), passive moments on; two twin recordings with the wearer's
   active torque (``wearer_torque`` % of the gravity RMS) and default noise — one to identify the
   wearer (stage 2), one on another trajectory to validate.
3. Validation torque RMS of exo + identified wearer, exo + table wearer, exo alone, and the *floor*:
   the RMS of the true exo + wearer model on the same (preprocessed) validation data — what the
   sensor noise and the active torque leave, that no model can explain.
4. Both controllers track a reference on the true plant with each model.

No command calls it: it is the study behind docs/wearer.md's figures, kept in the package (not in the
tests) so that they can be measured again from Python with other settings — tests/benchmarks/bench_wearer.py
(the documented figures) and tests/wearer/test_wearer_experiment.py (the sensor-noise-only case) both call
:func:`wearer_experiment`.  Everything it does goes through the public functions of the wearer stage, the
twin and the identified model; its own code is only the bookkeeping of the four steps.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pinid.checks import count, number
from pinid.errors import SpecError
from pinid.identification.identified import IdentifiedModel
from pinid.problem.recordings import prepare_dataset
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.simulation.twin import WearerLoad, simulate
from pinid.wearer.attach import wearer_links
from pinid.wearer.options import WearerOptions, as_wearer_options
from pinid.wearer.prior import draw_wearer
from pinid.wearer.stage import identify_wearer, stack


def _rms(model, datasets) -> np.ndarray:
    q, dq, ddq, tau = stack(datasets)
    return np.sqrt(np.mean((tau - model.inverse_dynamics(q, dq, ddq)) ** 2, axis=0))


@dataclass(frozen=True)
class WearerTrial:
    """The twin side of :func:`wearer_experiment`: the identification recording's length ``seconds`` [s]
    (validation: half), the wearer's involuntary active torque ``wearer_torque`` [% of the gravity RMS], the
    tracking runs' length ``track_seconds`` [s], the ``seed`` of everything random, and ``true_exponents``,
    the true wearer's passive-moment exponents ``{anatomical joint: (terms, 4)}`` (default the published).
    A wrong type: SpecError (one line)."""

    seconds: float = 60.0
    wearer_torque: float = 5.0
    track_seconds: float = 8.0
    seed: int = 0
    true_exponents: dict | None = None

    def __post_init__(self) -> None:
        number(self.seconds, "WearerTrial seconds", low=0.0, low_open=True)
        number(self.wearer_torque, "WearerTrial wearer_torque", low=0.0)
        number(self.track_seconds, "WearerTrial track_seconds", low=0.0, low_open=True)
        count(self.seed, "WearerTrial seed")
        if self.true_exponents is not None and not isinstance(self.true_exponents, Mapping):
            raise SpecError(
                f"WearerTrial true_exponents: got {type(self.true_exponents).__name__}, "
                "expected {anatomical joint: exponents} or None"
            )


def wearer_experiment(
    exo_urdf,
    exo_with_wearer,
    excitation,
    validation,
    reference,
    *,
    trial: WearerTrial | None = None,
    options: WearerOptions | None = None,
) -> dict:
    """Run the experiment (see the module text) and return its figures.

    ``exo_urdf``: the bare exoskeleton (URDF path or bundled name); ``exo_with_wearer``: its URDF from
    ``pinid wearer``; ``excitation`` / ``validation``: trajectories (FourierTrajectory) of the
    identification and validation recordings; ``reference``: the tracking reference; ``trial``: the
    twin's settings (:class:`WearerTrial`, default its defaults); ``options``: stage 2's
    (:class:`~pinid.wearer.options.WearerOptions`: e.g. ``passive_exponents`` fits the exponents,
    ``prior_weight`` its λ).  Returns ``{"rms": {model: per-joint validation RMS [N·m]}, "floor": per joint
    [N·m], "ratio": {model: RMS / floor, joints pooled}, "tracking": {controller: {model: per-joint RMS
    [rad]}}, "fit": WearerFit}`` with models ``identified``, ``table``, ``exo``.
    """
    from pinid.control.controllers import compare_models
    from pinid.identification.run import identify
    from pinid.identification.study import Study

    if trial is not None and not isinstance(trial, WearerTrial):
        raise SpecError(f"trial: got {type(trial).__name__}, expected WearerTrial (pinid.wearer.experiment)")
    tr = trial or WearerTrial()
    seconds, wearer_torque, seed, true_exponents = tr.seconds, tr.wearer_torque, tr.seed, tr.true_exponents
    exo = RobotModel.from_urdf(exo_urdf)
    exo_run, _ = simulate(exo, excitation, seconds=seconds, seed=seed + 1)
    stage1 = identify(Study(exo, exo_run), ["sdp"])["sdp"].model
    table = RobotModel.from_urdf(exo_with_wearer)
    plant, _ = draw_wearer(table, seed)
    plant = plant.with_passive_exponents(dict(true_exponents or {}))
    worn = wearer_links(plant.urdf_text)
    carried = WearerLoad(worn, torque=wearer_torque)
    train, _ = simulate(plant, excitation, seconds=seconds, seed=seed + 2, wearer=carried)
    valid, _ = simulate(plant, validation, seconds=seconds / 2, seed=seed + 3, wearer=carried)
    train, valid = prepare_dataset(train), prepare_dataset(valid)
    fit = identify_wearer(stage1, table, *stack([train]), options=as_wearer_options(options))
    terms = TermSelection.from_names("fc,fv,passive")
    truth = IdentifiedModel(
        plant,
        terms,
        np.concatenate(
            [plant.inertial_parameters(), np.column_stack([plant.coulomb, plant.viscous, np.ones(plant.nv)]).ravel()]
        ),
    )
    models = {w: fit.model(w) for w in ("identified", "table", "exo")}
    rms = {w: _rms(m, [valid]) for w, m in models.items()}
    floor = _rms(truth, [valid])
    pooled = lambda r: float(np.sqrt(np.mean(r**2) / np.mean(floor**2)))  # noqa: E731
    runs = compare_models(plant, models, reference, seconds=tr.track_seconds, seed=seed, wearer=worn)
    tracking = {
        c: {w: np.array([v["rms"] for v in r["metrics"].values()]) for w, r in by.items()} for c, by in runs.items()
    }
    return {
        "rms": rms,
        "floor": floor,
        "ratio": {w: pooled(r) for w, r in rms.items()},
        "tracking": tracking,
        "fit": fit,
        "joints": plant.joint_names,
    }
