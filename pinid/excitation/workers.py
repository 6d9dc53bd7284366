"""Worker processes of an excitation design: the multistart's independent local searches on every core.

The local searches of :func:`pinid.excitation.design.design_excitation`'s multistart do not depend on each
other, so on Linux with more than one core they run in a pool of forked worker processes (which inherit
the design problems: nothing is pickled but the start points and results).  Each search is deterministic
and the results come back in the order of the tasks, so the design is the same whatever the number of
workers; elsewhere, or with one worker, they run one after the other in this process.
"""

from __future__ import annotations

import os
import signal
import sys
import time
import warnings
from collections.abc import Callable

#: What the tasks run on, set before the workers are forked (they inherit it): ``(function, problems)``.
_STATE: tuple[Callable, dict] | None = None


def _pool_size(workers: int | None, jobs: int) -> int:
    """Worker processes for ``jobs`` tasks: ``workers`` (None: one per core), at most ``jobs``; 0 (run in
    this process) off Linux or for fewer than 2."""
    n = workers if workers is not None else (os.cpu_count() or 1)
    n = min(int(n), int(jobs))
    return n if n > 1 and sys.platform.startswith("linux") else 0


def _worker_start() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle: no worker traceback


def _run(task: tuple) -> tuple:
    """One task ``(problem key, *arguments)``: the function's result, its seconds and the problem's counters
    (criterion values, regressor samples) it added."""
    fn, problems = _STATE
    problem = problems[task[0]]
    before = (problem.nfev, problem.regressor_samples)
    start = time.perf_counter()
    out = fn(problem, *task[1:])
    return out, time.perf_counter() - start, problem.nfev - before[0], problem.regressor_samples - before[1]


class _Workers:
    """Run tasks of ``fn(problems[key], *arguments)`` in ``n`` forked workers (0: in this process); a
    context manager.  :meth:`map` returns ``(result, seconds)`` per task, in order, and adds the counters of
    work done in a worker to this process's problems."""

    def __init__(self, fn: Callable, problems: dict, n: int) -> None:
        global _STATE
        _STATE = (fn, problems)
        self.problems, self.n, self.pool = problems, n, None
        if n:
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            with warnings.catch_warnings():  # Python ≥ 3.12 warns about fork with threads (BLAS)
                warnings.simplefilter("ignore", DeprecationWarning)
                self.pool = ProcessPoolExecutor(
                    n, mp_context=multiprocessing.get_context("fork"), initializer=_worker_start
                )

    def map(self, tasks: list[tuple], each: Callable[[int, float], None] | None = None) -> list[tuple]:
        """``(result, seconds)`` of every task, in order; ``each(index, seconds)`` is called as each arrives."""
        results = []
        for i, (task, (out, seconds, nfev, samples)) in enumerate(
            zip(tasks, map(_run, tasks) if self.pool is None else self.pool.map(_run, tasks))
        ):
            if self.pool is not None:  # work done in a worker: count it here
                self.problems[task[0]].nfev += nfev
                self.problems[task[0]].regressor_samples += samples
            results.append((out, seconds))
            if each is not None:
                each(i, seconds)
        return results

    def __enter__(self) -> "_Workers":
        return self

    def __exit__(self, kind, *_) -> None:
        global _STATE
        _STATE = None
        if self.pool is None:
            return
        if kind is not None:  # interrupted or failed: stop the workers now, not after their current search
            self.pool.shutdown(wait=False, cancel_futures=True)
            for process in list(getattr(self.pool, "_processes", {}).values()):
                process.terminate()
        self.pool.shutdown(wait=True)
