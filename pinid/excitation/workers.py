"""Worker processes of an excitation design: the multistart's independent local searches on every core.

The local searches of :func:`pinid.excitation.design.design_excitation`'s multistart do not depend on each
other, so on Linux with more than one core they run in a pool of forked worker processes (which inherit
the design problems: nothing is pickled but the start points and results).  Each search is deterministic
and the results come back in the order of the tasks, so the design is the same whatever the number of
workers; elsewhere, or with one worker, they run one after the other in this process.
"""

from __future__ import annotations

import sys
import time
import warnings
from collections.abc import Callable

from pinid.parallel import LocalWorkers, default_workers


def pool_size(workers: int | None, jobs: int) -> int:
    """Worker processes for ``jobs`` tasks: ``workers`` (None: one per core), at most ``jobs``; 0 (run in
    this process) off Linux or for fewer than 2."""
    n = workers if workers is not None else default_workers()
    n = min(int(n), int(jobs))
    return n if n > 1 and sys.platform.startswith("linux") else 0


def _run(shared: tuple[Callable, dict], task: tuple) -> tuple:
    """One task ``(problem key, *arguments)``: the function's result, its seconds and the problem's counters
    (criterion values, regressor samples) it added."""
    fn, problems = shared
    problem = problems[task[0]]
    before = (problem.nfev, problem.regressor_samples)
    start = time.perf_counter()
    out = fn(problem, *task[1:])
    return out, time.perf_counter() - start, problem.nfev - before[0], problem.regressor_samples - before[1]


class SearchWorkers:
    """Run tasks of ``fn(problems[key], *arguments)`` in ``n`` forked workers (0: in this process; the
    pool of :class:`pinid.parallel.LocalWorkers`); a context manager.  :meth:`map` returns
    ``(result, seconds)`` per task, in order, and adds the counters of work done in a worker to this
    process's problems."""

    def __init__(self, fn: Callable, problems: dict, n: int) -> None:
        self.problems, self.n = problems, n
        with warnings.catch_warnings():  # Python ≥ 3.12 warns about fork with threads (BLAS)
            warnings.simplefilter("ignore", DeprecationWarning)
            self.pool = LocalWorkers(_run, (fn, problems), n)

    def map(self, tasks: list[tuple], each: Callable[[int, float], None] | None = None) -> list[tuple]:
        """``(result, seconds)`` of every task, in order; ``each(index, seconds)`` is called as each arrives."""
        results = []
        for i, (out, seconds, nfev, samples) in self.pool.results(tasks):
            if self.n > 1:  # work done in a worker: count it here
                self.problems[tasks[i][0]].nfev += nfev
                self.problems[tasks[i][0]].regressor_samples += samples
            results.append((out, seconds))
            if each is not None:
                each(i, seconds)
        return results

    def __enter__(self) -> "SearchWorkers":
        return self

    def __exit__(self, kind, *rest) -> None:
        self.pool.__exit__(kind, *rest)
