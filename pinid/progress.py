"""Progress of long work (excitation design, metaheuristics, comparisons, simulations), on stderr.

On a terminal: a tqdm bar.  Not on a terminal (CI, a log file, a pipe): from the command line, one
sparse line every :data:`INTERVAL` seconds (``pinid: slsqp 3/9 (33 %), 12 s, best 30.1``) and one when
long work ends, so a log shows that work goes on; from Python, nothing.

Who decides, first match wins:

1. a caller's explicit ``enabled=True``/``False`` (e.g. ``show_progress=False``), or, for work given none,
   the choice of an enclosing :func:`choose` block (a comparison's runs on workers: off);
2. ``PINID_PROGRESS=1`` (always on) or ``PINID_PROGRESS=0`` (always off);
3. the command line's ``--progress`` (on) / ``--no-progress`` (off) — :data:`MODE`;
4. otherwise: the command line shows progress (bar or lines); Python shows a bar on a terminal only,
   outside CI.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import time
from collections.abc import Iterator

#: Seconds between two progress lines when stderr is not a terminal.
INTERVAL = 5.0

#: The command line's choice: True (``--progress``), False (``--no-progress``), "auto" (neither), or None
#: outside the command line (Python use).
MODE: contextvars.ContextVar[bool | str | None] = contextvars.ContextVar("pinid_progress", default=None)


#: The choice of the innermost :func:`choose` block (None: none).
_CHOICE: contextvars.ContextVar[bool | None] = contextvars.ContextVar("pinid_progress_choice", default=None)


@contextlib.contextmanager
def choose(enabled: bool | None) -> Iterator[None]:
    """Within the block, long work given no ``enabled`` of its own (an estimator's fit, a metaheuristic's
    search) shows its progress as ``enabled`` says (None: as outside the block, the rules of the module
    text).  SpecError for anything but True, False or None."""
    if enabled is not None and not isinstance(enabled, bool):
        from pinid.errors import SpecError

        raise SpecError(f"enabled: got {enabled!r}, expected True, False or None")
    token = _CHOICE.set(_CHOICE.get() if enabled is None else enabled)
    try:
        yield
    finally:
        _CHOICE.reset(token)


def _wanted(enabled: bool | None) -> bool:
    if enabled is None:
        enabled = _CHOICE.get()
    if enabled is not None:
        return bool(enabled)
    env = os.environ.get("PINID_PROGRESS")
    if env in ("0", "1"):
        return env == "1"
    mode = MODE.get()
    if mode is None:  # Python: a bar on a terminal, outside CI
        return sys.stderr.isatty() and not os.environ.get("CI")
    return mode is not False


class Lines:
    """The tqdm methods pinid uses (``update``, ``set_description``, ``set_postfix_str``, ``close``, a
    context manager), printing the state to stderr every ``interval`` seconds (default :data:`INTERVAL`) from a background thread (so a
    single long step shows too) and once more at the end if it printed at all."""

    def __init__(self, total: int | None, desc: str, *, interval: float | None = None) -> None:
        import threading

        interval = INTERVAL if interval is None else interval
        self.total, self.desc, self.postfix, self.n = total, desc, "", 0
        self.start = time.monotonic()
        self.printed = False
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, args=(interval,), daemon=True, name="pinid-progress")
        self._thread.start()

    def line(self) -> str:
        """The current state as one line."""
        done = f"{self.n}/{self.total} ({100 * self.n / self.total:.0f} %)" if self.total else f"{self.n} steps"
        return f"pinid: {self.desc} {done}, {time.monotonic() - self.start:.0f} s" + (
            f", {self.postfix}" if self.postfix else ""
        )

    def _print(self) -> None:
        print(self.line(), file=sys.stderr, flush=True)
        self.printed = True

    def _run(self, interval: float) -> None:
        while not self._stop.wait(interval):
            self._print()

    def update(self, n: int = 1) -> None:
        self.n += n

    def set_description(self, desc: str, refresh: bool = True) -> None:
        self.desc = desc

    def set_postfix_str(self, s: str = "", refresh: bool = True) -> None:
        self.postfix = s

    def close(self) -> None:
        if self._stop.is_set():
            return
        self._stop.set()
        self._thread.join()
        if self.printed:  # long work: say how it ended
            self._print()

    def __enter__(self) -> Lines:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def shown(enabled: bool | None = None) -> bool:
    """Whether long work shows its progress, given a caller's ``enabled`` (the rules of the module text)."""
    if enabled is not None and not isinstance(enabled, (bool, int)):
        from pinid.errors import SpecError

        raise SpecError(f"enabled: got {enabled!r}, expected True, False or None")
    return _wanted(enabled)


def progress(total: int | None, desc: str, *, enabled: bool | None = None):
    """Progress of ``total`` steps (None: unknown): a tqdm bar, sparse :class:`Lines`, or a silent bar.
    Use ``.update(n)`` and ``.close()``, or a ``with`` block."""
    from tqdm.auto import tqdm

    on = _wanted(enabled)
    if on and not sys.stderr.isatty():
        return Lines(total, desc)
    return tqdm(total=total, desc=desc, disable=not on, leave=False, dynamic_ncols=True, file=sys.stderr)
