"""What ``pinid flex`` prints and writes, reachable from Python: a spec's check, a fit's summary, and the
files of a twin, a fit and a rigid-vs-flexible comparison (each set all or nothing, :class:`pinid.io.Artefacts`)."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

from pinid.flexible.recording import FlexRecording
from pinid.flexible.spec import FlexSpec
from pinid.flexible.output_error import OutputErrorProblem, classify, problem_from_spec, sensitivity
from pinid.flexible.result import OutputErrorResult
from pinid.io import Artefacts, json_text
from pinid.report.figures import save_figure
from pinid.report.plot_flexible import plot_angles
from pinid.errors import OutputError, SpecError
from pinid.io import as_path


def check_spec(spec: FlexSpec, recording: FlexRecording) -> tuple[str, dict]:
    """``pinid flex check``: the drives, the recording, the RK4 step and which free parameters the recording
    makes observable (relative standard deviations at the truth, or the nominal values, for the spec's
    noise, at least 0.1 mrad).  Returns the text and its JSON form ``{"spec", "step", "sensitivity"}``."""
    if not isinstance(spec, FlexSpec):
        raise SpecError(f"spec: got {type(spec).__name__}, expected a FlexSpec (load_flex_spec)")
    prob = problem_from_spec(spec, recording)
    model, rec = prob.model, recording
    lines = [
        f"robot {spec.robot.name} ({spec.robot.urdf_path}); backend: {model.backends}; "
        f"Coulomb smoothing {model.coulomb_speed:g} rad/s"
    ]
    lines += [f"  {d.joint:<12} {'flexible' if d.flexible else 'rigid':<9} ratio {d.ratio:g}" for d in model.drives]
    lines.append(
        f"recording: {rec.source}, {rec.n} samples at {1 / rec.dt:g} Hz, input {rec.input}; "
        f"RK4 step {1e3 * prob.step:.3g} ms ({int(round(rec.dt / prob.step))} per sample)"
    )
    noise = max(spec.fit.noise, 1e-4)
    sens = sensitivity(prob, noise=noise)
    lines.append(
        f"observability at {'the truth' if prob.truth else 'the nominal values'} "
        f"(relative std for {1e3 * noise:g} mrad angle noise; condition {sens['condition']:.3g}):"
    )
    for n, lo, hi in zip(prob.free, prob.lower, prob.upper):
        rs = sens["rel_std"][n]
        lines.append(f"  {n:<16} [{lo:>9.4g}, {hi:>9.4g}]  rel. std {100 * rs:>10.3g} %  {classify(rs)}")
    return "\n".join(lines), {"spec": spec.to_dict(), "step": prob.step, "sensitivity": sens}


def result_text(res: OutputErrorResult) -> str:
    """A fit as text: per parameter fitted, truth, error %, bounds; then the cost, the RMS angle errors
    [mrad], the simulations, the time and the integrator's step and tolerance."""
    if not isinstance(res, OutputErrorResult):
        raise SpecError(f"res: got {type(res).__name__}, expected an OutputErrorResult")
    rows = [["parameter", "fitted", "truth", "error %", "lower", "upper"]] + res.table()
    w = [max(len(r[i]) for r in rows) for i in range(6)]
    lines = ["  " + "  ".join(c.rjust(w[i]) if i else c.ljust(w[i]) for i, c in enumerate(r)) for r in rows]
    lines.append(
        f"  cost ({res.cost_kind}) {res.cost:.6g}; "
        + "; ".join(f"{j}: RMS {1e3 * m['rms']:.4g} mrad" for j, m in res.metrics.items())
        + f"; {res.nfev} simulations in {res.seconds:.1f} s (RK4 step {1e3 * res.step:.3g} ms, integrator "
        f"tolerance {res.extra.get('integrator_error', float('nan')):.2g} rad)"
    )
    return "\n".join(lines)


def twin_paths(path: str | os.PathLike) -> list[Path]:
    """The files :func:`write_twin` writes: the recording and its truth (``<path>.json``)."""
    path = as_path(path, error=OutputError)
    return [Path(path), Path(str(path) + ".json")]


def write_twin(recording: FlexRecording, path: str | os.PathLike, *, overwrite: bool | None = None) -> list[Path]:
    """Write a twin's recording (CSV or NPZ, by the suffix) and its ``meta`` (truth, noise, seed …) as
    ``<path>.json``, both or neither.  ``overwrite``: None follows :data:`pinid.io.OVERWRITE`."""
    if not isinstance(recording, FlexRecording):
        raise SpecError(f"recording: got {type(recording).__name__}, expected a FlexRecording")
    arts = Artefacts(overwrite=overwrite)
    data, truth = twin_paths(path)
    arts.add(data, lambda p: replace(recording, meta={}).save(p))
    arts.add(truth, json_text(recording.meta))
    return arts.write()


def write_fit(
    res: OutputErrorResult,
    path: str | os.PathLike,
    *,
    problem: OutputErrorProblem | None = None,
    plot: str | os.PathLike | None = None,
    overwrite: bool | None = None,
) -> list[Path]:
    """Write a fit's JSON (:meth:`OutputErrorResult.save`) and, with ``plot`` (needs its ``problem``), a
    figure of the measured and simulated angles; both or neither."""
    if not isinstance(res, OutputErrorResult):
        raise SpecError(f"res: got {type(res).__name__}, expected an OutputErrorResult")
    arts = Artefacts(overwrite=overwrite)
    arts.add(path, lambda p: res.save(p))
    if plot:
        fig = plot_angles(
            problem.recording.t,
            problem.recording.q,
            {problem.label: problem.simulate(res.x).q[0]},
            problem.model.joint_names,
            title=f"{problem.label} model, {res.method}",
        )
        arts.add(plot, lambda p: save_figure(fig, p))
    return arts.write()


def write_fit_comparison(
    comparison: dict,
    path: str | os.PathLike,
    *,
    spec: FlexSpec,
    recording: FlexRecording,
    plot: str | os.PathLike | None = None,
    overwrite: bool | None = None,
) -> list[Path]:
    """Write what :func:`~pinid.flexible.output_error.compare_rigid_flexible` returned as JSON (the
    recording, the spec, both fits) and, with ``plot``, a figure of the measured and simulated angles;
    both or neither."""
    if not isinstance(comparison, dict):
        raise SpecError(f"comparison: got {type(comparison).__name__}, expected the dict of compare_rigid_flexible")
    arts = Artefacts(overwrite=overwrite)
    arts.add(
        path,
        json_text(
            {
                "recording": recording.source,
                "spec": spec.source,
                "flexible": comparison["flexible"].to_dict(),
                "rigid": comparison["rigid"].to_dict(),
            }
        ),
    )
    if plot:
        fig = plot_angles(
            comparison["t"],
            comparison["measured"],
            comparison["simulated"],
            spec.robot.joint_names,
            title="rigid vs flexible joints (seed 003 Figs. 6-7)",
        )
        arts.add(plot, lambda p: save_figure(fig, p))
    return arts.write()
