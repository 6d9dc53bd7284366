"""Independent jobs on every core, or on a Dask cluster: ``run_parallel(fn, shared, items)``.

A study (``pinid compare``: methods × seeds; the seed-000/001 reproductions; the coverage benchmark) is a
list of independent jobs that share one large input (the training problem).  :func:`run_parallel` runs
``fn(shared, item)`` for every item and returns the results **in the order of the items**, so that a
parallel study gives the same numbers as a serial one:

* ``workers=1`` (and no scheduler): one after another in this process;
* ``workers=N``: N local processes of the standard library's :mod:`concurrent.futures` (``fork`` where the
  platform has it, so ``shared`` is not copied through a pipe); each runs with one BLAS thread;
* ``scheduler="tcp://host:8786"`` (or a ``distributed.Client``): the jobs go to that Dask cluster
  (``pip install "pinid[dask]"``); ``shared`` is scattered to the workers once.

Progress shows jobs done / total.  Ctrl-C stops every local worker (they ignore the signal themselves, so
no worker prints a traceback) or cancels the cluster's futures, and the interrupt reaches the caller before
anything is written.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
import warnings
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, as_completed, wait
from typing import Any

from pinid.errors import PinidError, SpecError
from pinid.io import deferred_interrupts
from pinid.progress import progress

#: What :func:`run_parallel`'s local workers run: ``(fn, shared)``, set once per worker process.
_WORKER_STATE: dict[str, Any] = {}


def default_workers() -> int:
    """The machine's cores available to this process (at least 1)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # macOS, Windows
        return max(1, os.cpu_count() or 1)


def check_workers(workers: int | None) -> int:
    """``workers`` as a count ≥ 1 (None: :func:`default_workers`); a clear error otherwise."""
    if workers is None:
        return default_workers()
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise SpecError(f"workers: got {workers!r}, expected a whole number of processes ≥ 1")
    return workers


def check_scheduler(scheduler: Any | None) -> Any | None:
    """``scheduler`` unchanged if it is None, a ``distributed.Client`` or a well-formed Dask address
    (``tcp://host:port``, ``host:port``, ``tls://…``, ``inproc://…``); a SpecError naming it otherwise.

    Checks the address's form only (no connection): a host name typed alone fails here, before any work."""
    if scheduler is None:
        return scheduler
    if not isinstance(scheduler, str):
        client = getattr(__import__("sys").modules.get("distributed"), "Client", None)
        if client is not None and isinstance(scheduler, client):
            return scheduler
        raise SpecError(f"scheduler: got {type(scheduler).__name__}, expected an address 'tcp://host:port'")
    expected = "expected an address tcp://host:port (e.g. tcp://127.0.0.1:8786)"
    if not scheduler.strip() or any(c.isspace() for c in scheduler):
        raise SpecError(f"scheduler {scheduler!r}: {expected}")
    try:
        from distributed.comm.addressing import parse_address, parse_host_port
    except ImportError:  # no Dask: _on_dask says how to install it
        return scheduler
    try:
        protocol, location = parse_address(scheduler)
        if protocol in ("tcp", "tls", "ws", "wss", "ucx"):
            host, port = parse_host_port(location)
            if not host or port is None:
                raise ValueError("no host or port")
    except (ValueError, TypeError) as e:
        raise SpecError(f"scheduler {scheduler!r}: {expected} ({e})") from None
    return scheduler


def run_parallel(
    fn: Callable[[Any, Any], Any],
    shared: Any,
    items: Sequence[Any],
    *,
    workers: int | None = 1,
    scheduler: Any = None,
    show_progress: bool | None = False,
    label: str = "jobs",
    describe: Callable[[Any], str] | None = None,
) -> list:
    """``[fn(shared, item) for item in items]``, run on ``workers`` local processes or a Dask ``scheduler``.

    ``fn`` must be a module-level function (it is pickled by reference); ``shared`` and the items must be
    picklable.  ``describe(item)``: the text the progress bar shows for a job (serial runs only).
    """
    if not callable(fn):
        raise SpecError(f"fn: got {type(fn).__name__}, expected a function of (shared, item)")
    if isinstance(items, (str, bytes)) or not isinstance(items, Sequence):
        raise SpecError(f"items: got {type(items).__name__}, expected a sequence of jobs")
    workers = check_workers(workers)
    bar = progress(len(items), label, enabled=show_progress)
    try:
        if scheduler is not None:
            return _on_dask(fn, shared, items, scheduler, bar)
        if workers == 1 or len(items) <= 1:
            out = []
            for item in items:
                if describe is not None:
                    bar.set_description(describe(item))
                out.append(fn(shared, item))
                bar.update(1)
            return out
        return _on_processes(fn, shared, items, min(workers, len(items)), bar)
    finally:
        bar.close()


# ============================================================================================ local
def _start_worker(fn: Callable, shared: Any) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent stops the workers; none prints a traceback
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # a terminating signal ends a worker silently
    _WORKER_STATE["fn"], _WORKER_STATE["shared"] = fn, shared


def _run_in_worker(indexed: tuple[int, Any]) -> tuple[int, bytes]:
    from pinid.blas import single_threaded_blas

    index, item = indexed
    with single_threaded_blas():  # N processes on N cores: one BLAS thread each
        value = _WORKER_STATE["fn"](_WORKER_STATE["shared"], item)
    # pickled here and unpickled by the caller itself: a result that cannot be unpickled raises there, where
    # multiprocessing's own result thread would die and leave the pool waiting for ever
    return index, pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)


def _unpickled(data: bytes, item: Any) -> Any:
    try:
        return pickle.loads(data)
    except Exception as e:
        raise PinidError(f"job {item!r}: its result could not be carried back from the worker process ({e})") from None


#: Python ≥ 3.12's DeprecationWarning at a fork in a process with threads (muted around the workers' fork).
_FORK_WARNING = r"This process \(pid=\d+\) is multi-threaded, use of fork\(\) may lead to deadlocks"


def _context() -> multiprocessing.context.BaseContext:
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


class LocalWorkers:
    """``workers`` local processes (0 or 1: this process) that run ``fn(shared, item)``, kept for several
    rounds of jobs; a context manager.  Leaving it by an exception (Ctrl-C, a job's error) stops every
    worker at once; leaving it normally lets them finish."""

    def __init__(self, fn: Callable[[Any, Any], Any], shared: Any, workers: int) -> None:
        self.fn, self.shared = fn, shared
        self.executor = None
        if workers > 1:
            self.executor = ProcessPoolExecutor(
                workers, mp_context=_context(), initializer=_start_worker, initargs=(fn, shared)
            )
            # every worker forked now (with fork, the executor starts them all at its first job, before its own
            # thread), not at the first real job, after a progress bar has started its thread.  Python ≥ 3.12
            # warns of any fork in a process with threads; these workers only run fn, so that warning is muted.
            with warnings.catch_warnings(), deferred_interrupts():  # an interrupt: raised once they are up
                warnings.filterwarnings("ignore", message=_FORK_WARNING, category=DeprecationWarning)
                self.executor.submit(int)

    def results(
        self, items: Sequence, *, ordered: bool = True, more: Callable | None = None
    ) -> Iterator[tuple[int, Any]]:
        """``(index, result)`` of every item: in the items' order, or as they finish (``ordered=False``).
        ``more(item, result)``: the items that can start now that ``item`` is done (a list, often empty),
        submitted at once behind those waiting and indexed after every item before them (as they finish)."""
        if more is not None:
            yield from self._growing(list(items), more)
            return
        if self.executor is None:
            yield from ((i, self.fn(self.shared, item)) for i, item in enumerate(items))
            return
        futures = [self.executor.submit(_run_in_worker, (i, item)) for i, item in enumerate(items)]
        try:
            for future in futures if ordered else as_completed(futures):
                index, data = future.result()
                yield index, _unpickled(data, items[index])
        finally:
            for future in futures:  # left early (an error, Ctrl-C, the caller stopped): nothing more starts
                future.cancel()

    def _growing(self, items: list, more: Callable) -> Iterator[tuple[int, Any]]:
        """:meth:`results` with ``more``: ``items`` grows as the jobs they wait for finish."""
        if self.executor is None:
            i = 0
            while i < len(items):
                value = self.fn(self.shared, items[i])
                items += more(items[i], value)
                yield i, value
                i += 1
            return
        futures = {self.executor.submit(_run_in_worker, (i, item)): i for i, item in enumerate(items)}
        try:
            while futures:
                finished, _ = wait(futures, return_when=FIRST_COMPLETED)
                for future in finished:
                    del futures[future]
                    index, data = future.result()
                    value = _unpickled(data, items[index])
                    for item in more(items[index], value):
                        items.append(item)
                        futures[self.executor.submit(_run_in_worker, (len(items) - 1, item))] = len(items) - 1
                    yield index, value
        finally:
            for future in futures:  # left early (an error, Ctrl-C, the caller stopped): nothing more starts
                future.cancel()

    def __enter__(self) -> "LocalWorkers":
        return self

    def __exit__(self, kind, *_) -> None:
        # the executor is dropped here, not left to the garbage collector: a forked worker of a later pool
        # that collected it would wake its (absent) manager thread through a pipe and could block for ever
        executor, self.executor = self.executor, None
        if executor is None:
            return
        if kind is None:
            executor.shutdown(wait=True)
            return
        # Ctrl-C or a job's error: stop every worker now, then let it reach the caller
        stop_workers(executor)


def stop_workers(executor: ProcessPoolExecutor) -> None:
    """Stop a process pool's workers at once, killed then joined: its own shutdown would wait for the running
    jobs (Python < 3.14 has no terminate_workers), and a pool interrupted while its workers start (SIGTERM,
    Ctrl-C) never starts the thread that would end them, so the interpreter's exit would wait for ever."""
    if not isinstance(executor, ProcessPoolExecutor):
        raise SpecError(f"executor: got {type(executor).__name__}, expected a ProcessPoolExecutor")
    processes = list((getattr(executor, "_processes", None) or {}).values())
    executor.shutdown(wait=False, cancel_futures=True)
    for process in processes:
        process.kill()
    for process in processes:
        process.join()


def _on_processes(fn: Callable, shared: Any, items: Sequence, workers: int, bar) -> list:
    results: list = [None] * len(items)
    with LocalWorkers(fn, shared, workers) as pool:
        for index, value in pool.results(items, ordered=False):
            results[index] = value
            bar.update(1)
    return results


# ============================================================================================ Dask
def _dask_job(fn: Callable, shared: Any, item: Any) -> Any:
    from pinid.blas import single_threaded_blas

    with single_threaded_blas():
        return fn(shared, item)


def _on_dask(fn: Callable, shared: Any, items: Sequence, scheduler: Any, bar) -> list:
    try:
        import distributed
    except ImportError:
        raise SpecError(
            f'scheduler {scheduler!r}: Dask is not installed; install it with: pip install "pinid[dask]"'
        ) from None
    check_scheduler(scheduler)
    own = isinstance(scheduler, str)
    if not own and not isinstance(scheduler, distributed.Client):
        raise SpecError(f"scheduler: got {type(scheduler).__name__}, expected an address 'tcp://host:port'")
    try:
        client = distributed.Client(scheduler, timeout="10s") if own else scheduler
    except (OSError, TimeoutError) as e:
        raise SpecError(f"scheduler {scheduler!r}: no Dask scheduler answers there ({e})") from None
    except ValueError as e:  # an address Dask cannot parse that check_scheduler let through
        raise SpecError(f"scheduler {scheduler!r}: expected an address tcp://host:port ({e})") from None
    futures = []
    try:
        shared_future = client.scatter(shared, broadcast=True)
        futures = client.map(_dask_job, [fn] * len(items), [shared_future] * len(items), items, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        results: list = [None] * len(items)
        for future in distributed.as_completed(futures):
            results[index[future.key]] = future.result()
            bar.update(1)
        return results
    except BaseException:
        client.cancel(futures)
        raise
    finally:
        if own:
            client.close()
