"""What ``pinid excite`` prints and writes, reachable from Python: a spec's summary, how much of each limit a
trajectory uses, the evaluation of a given trajectory, and the files of a designed or evaluated excitation
(JSON, CSV samples, figure; all or nothing, :class:`pinid.io.Artefacts`)."""

from __future__ import annotations

import os
import time
from pathlib import Path

from pinid.excitation.evaluation import evaluate_trajectory, limit_violations
from pinid.excitation.spec import ExcitationSpec
from pinid.excitation.trajectory import FourierTrajectory
from pinid.io import Artefacts, json_text
from pinid.model.robot import RobotModel
from pinid.report.figures import save_figure
from pinid.report.plot_excitation import plot_excitation
from pinid.model.robot import as_robot
from pinid.model.floating import FloatingRobotModel
from pinid.errors import SpecError


def spec_text(model: RobotModel, spec: ExcitationSpec) -> str:
    """The robot and the spec in three lines: harmonics, base frequency [rad/s] and period [s], samples,
    rest start, offsets, terms, margin."""
    model = as_robot(model)
    return (
        f"robot {model.name} ({model.urdf_path}), joints {', '.join(model.joint_names)}\n"
        f"spec {spec.source}:\n"
        f"  {spec.harmonics} harmonics, ωf = {spec.base_frequency:.6g} rad/s (period {spec.period:.4g} s), "
        f"{spec.samples} samples, {'start at rest' if spec.rest_start else 'no rest start'}, "
        f"offsets {'optimised' if spec.optimize_offsets else 'fixed'}, terms {','.join(spec.terms.names) or 'none'}"
        + (f", margin {spec.margin:g}" if spec.margin else "")
    )


def _usage_table(spec: ExcitationSpec, extremes: dict, usage: dict, q0) -> str:
    """A table of how much of each limit a trajectory uses: q reached and its limits [rad], the share of the
    range and toward each limit from ``q0``, |dq| [rad/s], |ddq| [rad/s²] and |tau| [N·m] maxima and their use."""
    if not isinstance(spec, ExcitationSpec):
        raise SpecError(f"spec: got {type(spec).__name__}, expected an ExcitationSpec")
    has_tau = any("tau" in u for u in usage.values())
    w = max(8, max(len(j) for j in spec.joints) + 2)
    head = (
        f"  {'joint':<{w}}{'q reached [rad]':>20}{'q limits [rad]':>20}{'range':>7}{'toward lo/hi':>14}"
        f"{'|dq| max':>10}{'use':>6}{'|ddq| max':>11}{'use':>6}" + (f"{'|tau| max':>11}{'use':>6}" if has_tau else "")
    )
    lines = [head]
    for i, j in enumerate(spec.joints):
        e, u = extremes[j], usage[j]
        toward = f"{100 * u['q_low']:.0f}%/{100 * u['q_high']:.0f}%"
        row = (
            f"  {j:<{w}}{e['q_min']:>9.4f} / {e['q_max']:<8.4f}{spec.q_min[i]:>9.4g} / {spec.q_max[i]:<8.4g}"
            f"{100 * u['q_range']:>6.0f}%{toward:>14}{e['dq_abs_max']:>10.3f}{100 * u['dq']:>5.0f}%"
            f"{e['ddq_abs_max']:>11.3f}{100 * u['ddq']:>5.0f}%"
        )
        if "tau" in u:
            row += f"{e.get('tau_abs_max', float('nan')):>11.2f}{100 * u['tau']:>5.0f}%"
        lines.append(row)
    lines.append(
        "  (q limits as given; 'toward lo/hi': how far the motion goes from q0 = "
        + ", ".join(f"{q:.4f}" for q in q0)
        + "\n   towards each position limit; dq [rad/s], ddq [rad/s²])"
    )
    return "\n".join(lines)


def evaluate_excitation(
    model: RobotModel, trajectory: FourierTrajectory, spec: ExcitationSpec
) -> tuple[FourierTrajectory, dict]:
    """Evaluate a given trajectory under ``spec`` (designing nothing): the trajectory with the evaluation
    in its ``meta`` (condition number, log det, feasibility, limits, extremes, usage: the JSON ``pinid
    excite --evaluate`` writes) and :func:`~pinid.excitation.evaluation.evaluate_trajectory`'s dict.  A floating
    robot's on its joints with the base held still (``model.fixed_base``), as its design."""
    model = as_robot(model)
    if isinstance(model, FloatingRobotModel):
        model = model.fixed_base
    spec.validate(model)
    started = time.perf_counter()
    ev = evaluate_trajectory(model, trajectory, spec)
    report = dict(trajectory.meta)
    report.update(
        condition_number=ev["condition_number"],
        criterion="cond",
        log_det=ev["log_det"],
        feasible=ev["feasible"],
        limits=spec.limits_dict(),
        extremes=ev["extremes"],
        usage=ev["usage"],
        optimizer=None,
        seconds=round(time.perf_counter() - started, 3),
        spec=spec.source,
        samples=spec.samples,
        terms=spec.terms.names,
    )
    t = trajectory
    return FourierTrajectory(t.joints, t.base_frequency, t.q0, t.a, t.b, meta=report), ev


def evaluation_text(source: str, spec: ExcitationSpec, ev: dict, q0, *, usage: bool = True) -> str:
    """:func:`evaluate_excitation`'s result as text: condition number, log det, inside the limits or not,
    the :func:`_usage_table` (with ``usage``) and every limit the trajectory leaves."""
    if not isinstance(spec, ExcitationSpec):
        raise SpecError(f"spec: got {type(spec).__name__}, expected an ExcitationSpec")
    lines = [
        f"{source}: condition number {ev['condition_number']:.6g} (base regressor, {spec.samples} samples), "
        f"log det {ev['log_det']:.6g}, {'inside' if ev['feasible'] else 'OUTSIDE'} the limits"
        + (", starts at rest" if ev["rest_start"] else "")
    ]
    if usage:
        lines.append(_usage_table(spec, ev["extremes"], ev["usage"], q0))
    lines += [f"  outside: {line}" for line in limit_violations(ev["extremes"], spec)]
    return "\n".join(lines)


def design_text(result, spec: ExcitationSpec, *, usage: bool = True) -> str:
    """A design's result as text: condition number (and log det with the logdet criterion), time,
    evaluations, and with ``usage`` the :func:`_usage_table`."""
    if not isinstance(spec, ExcitationSpec):
        raise SpecError(f"spec: got {type(spec).__name__}, expected an ExcitationSpec")
    crit = "" if spec.criterion == "cond" else f", log det(WᵀW) {result.log_det:.6g} (criterion logdet)"
    text = (
        f"condition number {result.condition_number:.6g}{crit} in {result.seconds:.1f} s "
        f"({result.nfev} criterion evaluations, {result.details['regressor_samples']} regressor samples)"
    )
    if usage:
        text += "\n" + _usage_table(spec, result.extremes, result.usage, result.trajectory.q0)
    return text


def excitation_paths(*, json=None, plot=None, csv=None) -> list[Path]:
    """The files :func:`write_excitation` writes for these arguments, in its order (to check them early)."""
    return [Path(p) for p in (plot, csv, json) if p]


def write_excitation(
    trajectory: FourierTrajectory,
    spec: ExcitationSpec,
    report: dict,
    *,
    json: str | os.PathLike | None = None,
    plot: str | os.PathLike | None = None,
    csv: str | os.PathLike | None = None,
    rate: float = 1000.0,
    periods: float = 1.0,
    overwrite: bool | None = None,
) -> list[Path]:
    """Write an excitation, all or nothing: ``plot`` a figure of q, dq, ddq against the limits; ``csv``
    the trajectory sampled at ``rate`` [Hz] for ``periods`` periods; ``json`` the ``report`` (the
    trajectory and its design or evaluation).  ``overwrite``: replace existing files (None: the
    :data:`pinid.io.OVERWRITE` policy, which the CLI's ``--force`` sets).  Returns the paths written."""
    if not isinstance(trajectory, FourierTrajectory):
        raise SpecError(f"trajectory: got {type(trajectory).__name__}, expected a FourierTrajectory")
    arts = Artefacts(overwrite=overwrite)
    if plot:

        def draw(p):
            cond = report.get("condition_number")
            title = f"{len(trajectory.joints)}-joint excitation, condition number {cond:.4g}" if cond else None
            save_figure(plot_excitation(trajectory, spec, title=title), p)

        arts.add(plot, draw, behind=True)
    if csv:
        arts.add(csv, lambda p: trajectory.to_csv(p, rate, periods * trajectory.period))
    if json:
        arts.add(json, json_text(report))
    return arts.write()
