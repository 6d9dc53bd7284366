"""The runner behind :func:`pinid.identification.run.identify`, ``compare`` and the floating base: a
:class:`Setup` (the model, the training problem or segmental stages, the validation sets) and
:func:`run_jobs`, which fits one estimator per ``(method, seed, settings)`` job on it — in order, on local
processes or a Dask cluster — and wraps each as an :class:`~pinid.identification.result.IdentificationResult`."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from pinid.data.dataset import Dataset
from pinid.errors import SpecError
from pinid.estimators import Estimator, make_estimator
from pinid.identification.result import IdentificationResult, make_result
from pinid.identification.segmental import Segmental, SegmentalProblem
from pinid.model.base import BaseParameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.parallel import run_parallel
from pinid.problem.problem import IdentificationProblem

if TYPE_CHECKING:
    from pinid.identification.floating import FloatingStack


@dataclass
class Setup:
    """Everything the runs share: the model, the training problem (or segmental stages), validation sets."""

    model: RobotModel
    terms: TermSelection
    base: BaseParameters
    problem: IdentificationProblem
    train: list[Dataset]
    validation: dict[str, list[Dataset]] = field(default_factory=dict)
    segmental: SegmentalProblem | None = None
    stribeck: dict[str, dict] = field(default_factory=dict)  # the Stribeck shapes used (data["stribeck"])
    delay: dict | None = None  # the torque delay used (data["delay"]): given or estimated
    cutoff: dict | None = None  # the cut-off chosen by cross-validation (data["cutoff"]) when asked for "auto"
    terms_choice: dict | None = None  # the terms chosen by cross-validation (data["terms_choice"]) for "auto"
    ripple: dict | None = None  # the ripple periods chosen by cross-validation (data["ripple_periods"]) for "auto"
    sigmoid: dict | None = None  # the sigmoid friction's shapes fitted for "auto" (data["sigmoid"])
    floating: FloatingStack | None = None  # a floating base's recordings, validation rows and convention hints


@dataclass
class Fit:
    """One job's outcome: the fitted estimator, its wrapped result and the fit time [s]."""

    method: str
    seed: int | None
    settings: dict
    estimator: Estimator
    result: IdentificationResult
    seconds: float


def run_jobs(
    s: Setup,
    jobs: Iterable[tuple[str, int | None, dict]],
    *,
    complete: bool = True,
    show_progress: bool | None = False,
    label: str = "methods",
    workers: int | None = 1,
    scheduler=None,
    beside: Callable[[Setup], Any] | None = None,
) -> list:
    """Fit every ``(method, seed, settings)`` job on the setup's problem (or its segmental stages), in the
    jobs' order, on ``workers`` local processes or a Dask ``scheduler`` (:func:`pinid.parallel.run_parallel`).
    ``beside(s)``: one more job, run first on a worker while the fits run (a study's references, so that
    they do not wait alone); its value is the list's last item."""
    if not isinstance(s, Setup):
        raise SpecError(f"s: got {type(s).__name__}, expected the Setup of pinid.identification.run.setup")
    if beside is not None and not callable(beside):
        raise SpecError(f"beside: got {type(beside).__name__}, expected a function of the setup")
    items = [(method, seed, settings, complete) for method, seed, settings in jobs]
    out = run_parallel(
        _fit_job,
        s,
        ([(None, beside)] if beside is not None else []) + items,
        workers=workers,
        scheduler=scheduler,
        show_progress=show_progress,
        label=label,
        describe=lambda job: "references" if job[0] is None else job[0] + ("" if job[1] is None else f" seed {job[1]}"),
    )
    return out[1:] + out[:1] if beside is not None else out


def _fit_job(s: Setup, job: tuple) -> Any:
    if job[0] is None:  # run_jobs' beside
        return job[1](s)
    method, seed, settings, complete = job
    if s.segmental is not None:
        est, target = Segmental(method, settings), s.segmental
    else:
        est, target = make_estimator(method, **settings), s.problem
        s.problem.cache.forget("compressed")  # each run's time includes its QR compression
    t0 = time.perf_counter()
    est.fit(target)
    seconds = time.perf_counter() - t0
    robot = s.model if getattr(s.model, "base", "fixed") == "floating" else None  # not the problem's body view
    result = make_result(s.problem, est, seconds, complete=complete, robot=robot)
    return Fit(method, seed, settings, est, result, seconds)
