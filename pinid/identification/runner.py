"""The runner behind :func:`pinid.identification.run.identify`, ``compare`` and the floating base: a
:class:`Setup` (the model, the training problem or segmental stages, the validation sets) and
:func:`run_jobs`, which fits one estimator per ``(method, seed, settings)`` job on it — in order, on local
processes or a Dask cluster — and wraps each as an :class:`~pinid.identification.result.IdentificationResult`."""

from __future__ import annotations

import importlib
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
from pinid.parallel import LocalWorkers, check_workers, run_parallel
from pinid.problem.problem import IdentificationProblem
from pinid.progress import choose, progress

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
    offsets: Any = None  # the offsets per recording profiled out of the problem (identification.offsets)
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
    after: Callable[[Fit], Any] | None = None,
    fit_progress: bool | None = None,
) -> list:
    """Fit every ``(method, seed, settings)`` job on the setup's problem (or its segmental stages), in the
    jobs' order, on ``workers`` local processes or a Dask ``scheduler`` (:func:`pinid.parallel.run_parallel`).
    ``beside(s)``: one more job, run first on a worker while the fits run (a study's references, so that
    they do not wait alone); its value is the list's last item.  ``after(fit)``: what each job returns
    instead of its :class:`Fit`, computed where the job ran (a study's validation of each run).
    ``fit_progress``: whether each fit shows its own progress (a metaheuristic's search; None: the rules of
    :mod:`pinid.progress`), set around it with :func:`pinid.progress.choose`, on the workers too.

    On local processes, which share no cache, the fits that several jobs keep in the problem's cache
    (:meth:`~pinid.estimators.base.Estimator.shared_work`: the RLS run of ``rls`` and of every RLS-PSO seed)
    run first, once each, beside ``beside`` and the jobs that need none (the costliest first:
    :attr:`~pinid.estimators.base.Estimator.cost`); the jobs that need them are sent with their values as soon
    as they are done, so that no worker redoes them and none waits (the same numbers: the same computation)."""
    if not isinstance(s, Setup):
        raise SpecError(f"s: got {type(s).__name__}, expected the Setup of pinid.identification.run.setup")
    for name, fn in (("beside", beside), ("after", after)):
        if fn is not None and not callable(fn):
            raise SpecError(f"{name}: got {type(fn).__name__}, expected a function")
    if fit_progress is not None and not isinstance(fit_progress, bool):
        raise SpecError(f"fit_progress: got {fit_progress!r}, expected True, False or None")
    fits = [("fit", (method, seed, settings, complete)) for method, seed, settings in jobs]
    local = check_workers(workers) > 1 and scheduler is None and len(fits) > 1
    made = [make_estimator(job[0], **job[2]) for _, job in fits] if local else []
    shared = [est.shared_work() for est in made] if local and s.segmental is None else []
    for module in dict.fromkeys(m for est in made for m in est.lazy_imports()):
        importlib.import_module(module)  # what the fits import on first use: once here, not in every worker
    head = [("beside", beside)] if beside is not None else []
    later = [i for i, tasks in enumerate(shared) if tasks]
    now = [i for i in range(len(fits)) if i not in set(later)]
    if local:  # the costliest first (Estimator.cost), so that no long job ends alone; results kept in job order
        now, later = (sorted(ids, key=lambda i: -type(made[i]).cost) for ids in (now, later))
    items = head + [("shared", task) for task in dict.fromkeys(t for i in later for t in shared[i])]
    items += [fits[i] for i in now]
    if later:  # the jobs that need a shared fit start as soon as it is done, its values sent along
        s.problem.W  # noqa: B018 -- the shared fit reads the whole W: built here once, not in each worker
        waiting = [(i, fits[i][1], shared[i]) for i in later]
        out, value = _with_shared(s, items, now, waiting, (after, fit_progress), (workers, show_progress, label))
    else:
        done = run_parallel(
            _fit_job,
            (s, after, fit_progress),
            items,
            workers=workers,
            scheduler=scheduler,
            show_progress=show_progress,
            label=label,
            describe=_describe,
        )
        value = next((r for (kind, _), r in zip(items, done) if kind == "beside"), None)
        out = [None] * len(fits)
        for i, r in zip(now, (r for (kind, _), r in zip(items, done) if kind == "fit")):
            out[i] = r
    return out + ([value] if beside is not None else [])


def _with_shared(s: Setup, items: list, now: list[int], waiting: list[tuple], how: tuple, run: tuple) -> tuple:
    """``(results by job, beside's value)`` of :func:`run_jobs` on local workers when some jobs need a shared
    fit: ``items`` (``beside``, the shared fits, the jobs ``now``) first; each ``waiting`` job (its index, job
    and the shared fits it needs) is sent with the shared values as soon as the fits it needs are done, behind
    the jobs not yet started (the same computation as if its worker had made them: the same numbers)."""
    workers, show_progress, label = run
    kept, finished, queued = {}, set(), list(items)
    slot = dict(zip([k for k, (kind, _) in enumerate(items) if kind == "fit"], now))

    def more(item: tuple, result) -> list:
        if item[0] != "shared":
            return []
        s.problem.cache.keep(result)  # this process's cache too: what is read after the fits
        kept.update(result)
        finished.add(item[1])
        ready = [w for w in waiting if set(w[2]) <= finished]
        waiting[:] = [w for w in waiting if w not in ready]
        new = [("after shared", (i, job, dict(kept))) for i, job, _ in ready]
        queued.extend(new)
        return new

    out: list = [None] * (len(now) + len(waiting))
    value = None
    n = min(check_workers(workers), len(items) + len(waiting))
    with (
        LocalWorkers(_fit_job, (s, *how), n) as pool,
        progress(len(items) + len(waiting), label, enabled=show_progress) as bar,
    ):
        for index, result in pool.results(items, more=more):
            kind, what = queued[index]
            if kind == "beside":
                value = result
            elif kind == "fit":
                out[slot[index]] = result
            elif kind == "after shared":
                out[what[0]] = result
            bar.update(1)
    return out, value


def _describe(job: tuple) -> str:
    kind, what = job
    if kind == "beside":
        return "references"
    if kind == "shared":
        return f"{what[0]} (shared)"
    return what[0] + ("" if what[1] is None else f" seed {what[1]}")


def _fit_job(shared: tuple[Setup, Callable | None, bool | None], job: tuple) -> Any:
    """One item of :func:`run_jobs`: a fit (its :class:`Fit`, or ``after(fit)``), ``beside``'s value, or a
    shared fit (the problem cache's entries it made, for the caller's cache)."""
    s, after, fit_progress = shared
    kind, job = job
    if kind == "after shared":  # a job that needs shared fits, sent with their values
        _, job, entries = job
        s.problem.cache.keep(entries)
        kind = "fit"
    if kind == "beside":
        return job(s)
    if kind == "shared":
        before = s.problem.cache.entries()
        make_estimator(job[0], **dict(job[1])).fit(s.problem)
        return {k: v for k, v in s.problem.cache.entries().items() if before.get(k) is not v}
    method, seed, settings, complete = job
    if s.segmental is not None:
        est, target = Segmental(method, settings), s.segmental
    else:
        est, target = make_estimator(method, **settings), s.problem
        s.problem.cache.forget("compressed")  # each run's time includes its QR compression
    t0 = time.perf_counter()
    with choose(fit_progress):
        est.fit(target)
    seconds = time.perf_counter() - t0
    robot = s.model if getattr(s.model, "base", "fixed") == "floating" else None  # not the problem's body view
    result = make_result(s.problem, est, seconds, complete=complete, robot=robot)
    fit = Fit(method, seed, settings, est, result, seconds)
    return fit if after is None else after(fit)
