"""Safe file output: write to a temporary file in the same folder, then rename.

A reader never sees a half-written file, and an interrupted run leaves the old file (or none) behind.
"""

from __future__ import annotations

import contextlib
import contextvars
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any
from collections.abc import Iterator

from pinid.errors import OutputError
from pinid.errors import SpecError


#: Whether existing output files may be replaced.  The Python API replaces them (``save()`` saves); the
#: CLI refuses unless ``--force`` is given (:func:`pinid.cli.main.main` sets this for the run).
OVERWRITE: contextvars.ContextVar[bool] = contextvars.ContextVar("pinid_overwrite", default=True)


def check_writable(
    path: str | os.PathLike,
    *,
    overwrite: bool | None = None,
    inputs: tuple[str | os.PathLike, ...] = (),
) -> Path:
    """Check before any work that ``path`` can be written; return it as a Path.

    Raises OutputError if the folder cannot be created or written, if the path is a folder, if it is one
    of ``inputs`` (the same file, also through a symbolic or hard link: never replaced, even with
    ``overwrite``), or if it exists and ``overwrite`` is False (None: the current :data:`OVERWRITE` policy).
    """
    overwrite = OVERWRITE.get() if overwrite is None else overwrite
    p = Path(path)
    if p.is_dir():
        raise OutputError(f"{p}: is a folder, expected a file path")
    for source in inputs:
        if _same_file(p, Path(source)):
            raise OutputError(f"{p}: is the input file {source}; expected a different output path (even with --force)")
    if p.exists() and not overwrite:
        raise OutputError(f"{p}: already exists (use --force to overwrite)")
    folder = p.parent if str(p.parent) else Path(".")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{folder}: cannot create output folder ({exc.strerror or exc})") from None
    if not os.access(folder, os.W_OK):
        raise OutputError(f"{folder}: output folder is not writable")
    return p


def _same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` are the same existing file (the same inode, through any link)."""
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success rename it to ``path``, on error delete it."""
    p = check_writable(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".part", dir=p.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp_path, 0o666 & ~umask)  # mkstemp makes 0600; give the file the usual permissions
    try:
        yield tmp_path
        os.replace(tmp_path, p)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp_path.unlink()
        raise


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` atomically to ``path``."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def jsonable(obj: Any) -> Any:
    """``obj`` with numpy arrays and scalars made plain Python, and NaN and infinities made None (JSON null)."""
    import math

    import numpy as np

    if type(obj) is float:  # the common leaf first
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        if obj.dtype.kind in "iu" or (obj.dtype.kind == "f" and np.isfinite(obj).all()):
            return obj.tolist()  # plain ints and finite floats already: nothing to change element by element
        return jsonable(obj.tolist())
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    if isinstance(obj, np.integer):
        return int(obj)
    return obj


def display_path(path: str | os.PathLike) -> str:
    """``path`` relative to the working directory when it lies below it (what a report or a saved spec
    shows, free of machine paths), else as given."""
    p = Path(path)
    try:
        return str(p.resolve().relative_to(Path.cwd().resolve()))
    except (ValueError, OSError):
        return str(p)


def read_json(path: str | os.PathLike, what: str) -> dict:
    """The JSON object in ``path``; SpecError naming ``what`` was expected if it is missing or not one."""
    if not isinstance(path, (str, os.PathLike)):
        raise SpecError(f"path: got {type(path).__name__}, expected the path of a JSON file ({what})")
    p = Path(path)
    d = parse_spec_text(read_bounded_file(p, f"{what} JSON file"), str(p), f"{what} file", kind="JSON")
    if not isinstance(d, dict):
        raise SpecError(f"{p}: expected a JSON object ({what})")
    return d


#: Largest spec file read (TOML or JSON: specs, drives, payloads, trajectories, saved models) [bytes].
MAX_SPEC_BYTES = 64 * 2**20


def as_path(path, name: str = "path", *, error: type = SpecError) -> Path:
    """``path`` (text or os.PathLike, no NUL) as a Path; ``error`` naming the argument ``name`` otherwise."""
    if not isinstance(path, (str, os.PathLike)) or "\x00" in os.fspath(path):
        raise error(f"{name}: got {path!r:.60}, expected a file path (text without NUL, or a pathlib.Path)")
    return Path(path)


def check_input_file(
    path: str | os.PathLike, what: str, *, option: str | None = None, error: type = SpecError, limit: int | None = None
) -> Path:
    """``path`` as a Path if it names a regular file (not a folder, FIFO, device or socket) of at most
    ``limit`` bytes; else ``error`` (one line naming ``option`` if given, the path and ``what`` was
    expected).  What every file option checks before reading: a FIFO would block forever and
    ``/dev/zero`` never ends."""
    if not isinstance(path, (str, os.PathLike)):
        raise error(f"{option or 'path'}: got {type(path).__name__}, expected the path of a {what}")
    p = Path(path)
    where = f"{option} {p}" if option else str(p)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise error(f"{where}: file not found, expected a {what}") from None
    except (OSError, ValueError) as exc:  # a NUL in the name, a name too long, no permission …
        raise error(f"{where}: cannot be read ({getattr(exc, 'strerror', None) or exc}), expected a {what}") from None
    import stat

    if not stat.S_ISREG(st.st_mode):
        kind = (
            "a folder"
            if stat.S_ISDIR(st.st_mode)
            else "a FIFO (named pipe)"
            if stat.S_ISFIFO(st.st_mode)
            else "a device"
            if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode)
            else "a socket"
            if stat.S_ISSOCK(st.st_mode)
            else "not a regular file"
        )
        raise error(f"{where}: is {kind}, expected a {what} (a regular file)")
    if limit is not None and st.st_size > limit:
        raise error(f"{where}: {st.st_size:,} bytes, larger than a {what} should be (at most {limit:,} bytes)")
    return p


def read_bounded_file(
    path: str | os.PathLike,
    what: str,
    *,
    option: str | None = None,
    error: type = SpecError,
    limit: int = MAX_SPEC_BYTES,
) -> bytes:
    """The bytes of the regular file ``path`` (:func:`check_input_file`), reading at most ``limit``
    bytes: a file that grows past it while read (``/proc``, a file being written) is refused too."""
    p = check_input_file(path, what, option=option, error=error, limit=limit)
    where = f"{option} {p}" if option else str(p)
    try:
        with open(p, "rb") as f:
            data = f.read(limit + 1)
    except OSError as exc:
        raise error(f"{where}: cannot be read ({exc.strerror or exc}), expected a {what}") from None
    if len(data) > limit:
        raise error(f"{where}: larger than a {what} should be (at most {limit:,} bytes)")
    return data


#: Deepest nesting of tables and arrays accepted in a spec file (TOML or JSON); real specs use 3 or 4.
MAX_SPEC_DEPTH = 64


def toml_loads(text: str) -> dict:
    """The table in TOML ``text``: :mod:`tomllib` from Python 3.11, the ``tomli`` package before it (the
    dependency ``pyproject.toml`` declares for 3.10).  Raises ``TOMLDecodeError`` (a ValueError)."""
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - exercised by .ci/run on the oldest admitted Python
        import tomli as tomllib
    return tomllib.loads(text)


def parse_spec_text(text: bytes | str, origin: str, what: str, *, kind: str = "TOML") -> Any:
    """The value in a spec file's ``text`` (``kind`` "TOML" or "JSON"); SpecError (one line, naming
    ``origin`` and ``what`` was expected) if it is not UTF-8, not valid, or nested deeper than
    :data:`MAX_SPEC_DEPTH` levels.  The one place pinid parses a user's TOML."""
    try:
        if isinstance(text, bytes):
            text = text.decode("utf-8")
        data = json.loads(text) if kind == "JSON" else toml_loads(text)
    except UnicodeDecodeError:
        raise SpecError(f"{origin}: not UTF-8 text, expected a {what}") from None
    except RecursionError:
        raise SpecError(f"{origin}: nested deeper than {MAX_SPEC_DEPTH} levels, expected a {what}") from None
    except ValueError as exc:  # JSONDecodeError and TOMLDecodeError are ValueErrors
        raise SpecError(f"{origin}: not valid {kind} ({str(exc).splitlines()[0]}), expected a {what}") from None
    _check_depth(data, origin, what)
    return data


def read_toml(path: str | os.PathLike, what: str) -> dict:
    """The table in the TOML file ``path`` (see :func:`parse_spec_text`); SpecError if it is missing."""
    p = Path(path)
    return parse_spec_text(read_bounded_file(p, f"{what} (TOML)"), str(p), what)


def _check_depth(data: Any, origin: str, what: str) -> None:
    level = [data]
    for _ in range(MAX_SPEC_DEPTH + 1):
        level = [v for x in level for v in (x.values() if isinstance(x, dict) else x if isinstance(x, list) else ())]
        if not level:
            return
    raise SpecError(f"{origin}: nested deeper than {MAX_SPEC_DEPTH} levels, expected a {what}")


def json_text(obj: Any) -> str:
    """``obj`` as indented JSON text (through :func:`jsonable`: NaN is written null), ending in a newline."""
    return json.dumps(jsonable(obj), indent=2, sort_keys=False, allow_nan=False) + "\n"


def write_json(path: str | os.PathLike, obj: Any) -> Path:
    """Write ``obj`` as indented JSON atomically to ``path`` (:func:`json_text`)."""
    return write_text(path, json_text(obj))


class Artefacts:
    """The set of output files of one run, written all or nothing.

    Plan every output with :meth:`add` (a path and a function that writes it), then :meth:`write`:

    1. check all of them before anything is written: no two outputs on one path, none exists unless
       overwriting is allowed (``--force``; the :data:`OVERWRITE` policy), every folder can be created
       and written;
    2. write them into a temporary folder next to the destination (``.pinid-*``);
    3. move them into place, then remove the files of an earlier run in ``stale`` folders that this
       run did not write (``clean(folder, patterns)``).

    An error or an interrupt (SIGINT, or SIGTERM under the CLI) before step 3 leaves nothing behind:
    no file, no ``.part``, no empty output folder.  Usable from Python::

        out = Artefacts()
        out.add("run/result.json", lambda p: p.write_text("{}"))
        out.write()   # -> [Path('run/result.json')]
    """

    def __init__(self, *, overwrite: bool | None = None) -> None:
        self.overwrite = OVERWRITE.get() if overwrite is None else overwrite
        self._planned: list[tuple[Path, Any, bool]] = []
        self._stale: list[tuple[Path, tuple[str, ...]]] = []

    def add(self, path: str | os.PathLike, write, *, behind: bool = False) -> Path:
        """Plan ``path``: ``write`` is its content (str or bytes), or a function called with a temporary
        path of the same name that writes the file or returns its content.  ``behind``: a file that can be
        written after the others (a figure, a report): inside :func:`written_behind`, by a forked process
        while the caller goes on.  Returns ``path`` as a Path."""
        p = Path(path)
        self._planned.append((p, write, bool(behind)))
        return p

    def clean(self, folder: str | os.PathLike, patterns) -> None:
        """After a successful write, remove files in ``folder`` matching the glob ``patterns`` (outputs
        of an earlier run) that this run did not write, so a ``--force`` re-run leaves no stale file."""
        self._stale.append((Path(folder), tuple(patterns)))

    @property
    def paths(self) -> list[Path]:
        """The planned output paths, in order."""
        return [p for p, _, _ in self._planned]

    def check(self) -> list[Path]:
        """Check every planned output (see the class docstring) without writing or creating anything."""
        seen: dict[Any, Path] = {}
        for p, _, _ in self._planned:
            key = _same_file_key(p)
            if key in seen:
                raise OutputError(
                    f"{p}: two outputs of this run would be written to the same file "
                    f"(also {seen[key]}); give them different paths"
                )
            seen[key] = p
            if p.is_dir():
                raise OutputError(f"{p}: is a folder, expected a file path")
            if p.exists() and not self.overwrite:
                raise OutputError(f"{p}: already exists (use --force to overwrite)")
            folder = _existing_ancestor(p.parent)
            if not folder.is_dir():
                raise OutputError(f"{folder}: is not a folder, cannot create the output folder {p.parent}")
            if not os.access(folder, os.W_OK | os.X_OK):
                raise OutputError(f"{folder}: output folder is not writable")
        return self.paths

    def write(self) -> list[Path]:
        """Check, write into a temporary folder, move into place; returns the written paths.  Inside
        :func:`written_behind`, the files added with ``behind=True`` are left to a forked process."""
        self.check()
        if not self._planned:
            return []
        behind = _BEHIND is not None and _BEHIND[0] == os.getpid()
        later = [(p, w) for p, w, b in self._planned if b and behind]
        _stage_and_move([(p, w) for p, w, b in self._planned if not (b and behind)])
        if later:
            _write_later(later, self.overwrite)
        written = {_same_file_key(p) for p in self.paths}
        for folder, patterns in self._stale:
            for pattern in patterns:
                for old in folder.glob(pattern):
                    if old.is_file() and _same_file_key(old) not in written:
                        with contextlib.suppress(OSError):
                            old.unlink()
        return self.paths


def _stage_and_move(entries: list[tuple[Path, Any]]) -> None:
    """Write ``entries`` (:meth:`Artefacts.add`'s path and content) into a temporary folder next to the
    first, then move them into place; on an error or interrupt, remove what was created."""
    import shutil

    if not entries:
        return
    stage = Path(tempfile.mkdtemp(prefix=".pinid-", dir=_existing_ancestor(entries[0][0].parent)))
    created: list[Path] = []
    try:
        staged = []
        for i, (p, write) in enumerate(entries):
            tmp = stage / str(i) / p.name
            tmp.parent.mkdir()
            content = write if isinstance(write, (str, bytes)) else write(tmp)
            if isinstance(content, str):
                tmp.write_text(content, encoding="utf-8")
            elif isinstance(content, bytes):
                tmp.write_bytes(content)
            if not tmp.is_file():
                raise OutputError(f"{p}: its writer produced no file")
            staged.append((tmp, p))
        for _, p in staged:  # create the missing folders, remembering them to undo on failure
            missing = []
            f = p.parent
            while str(f) and not f.exists():
                missing.append(f)
                f = f.parent
            for f in reversed(missing):
                f.mkdir()
                created.append(f)
        for tmp, p in staged:
            try:
                os.replace(tmp, p)
            except OSError:  # another file system
                shutil.move(str(tmp), str(p))
    except BaseException:
        for f in reversed(created):
            with contextlib.suppress(OSError):
                f.rmdir()
        raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def check_outputs(*paths: str | os.PathLike) -> None:
    """Check a run's output paths before the work, creating nothing (:meth:`Artefacts.check`: no two on
    one path, none exists unless ``--force``, every folder can be created and written)."""
    arts = Artefacts()
    for p in paths:
        arts.add(p, "")
    arts.check()


def _same_file_key(p: Path) -> Any:
    """What identifies the file ``p`` names: its resolved path (symbolic links in it followed, so
    ``link/e.json`` and ``target/e.json`` are one file), or, for an existing file, its device and inode
    (hard links too)."""
    try:
        st = os.stat(p)
        return ("inode", st.st_dev, st.st_ino)
    except OSError:
        pass
    try:
        return ("path", Path(os.path.realpath(p)))
    except (OSError, ValueError):
        return ("path", Path(os.path.abspath(p)))


def _existing_ancestor(folder: Path) -> Path:
    """``folder`` or its nearest ancestor that exists (the working directory for a relative empty path)."""
    f = Path(os.path.abspath(folder if str(folder) else "."))
    while not f.exists() and f != f.parent:
        f = f.parent
    return f


@contextlib.contextmanager
def deferred_interrupts() -> Iterator[None]:
    """Hold Ctrl-C and SIGTERM while worker processes are forked: a pool interrupted while its workers
    start never starts the thread that ends them, and the interpreter's exit (or the caller reading the
    command's output) would wait for them for ever.  A signal that came is raised when the block ends, to
    the handler that was in place.  Outside the main thread: no change.  Forked children inherit the holding
    handler: their initializer sets their own."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    came: list[int] = []
    kinds = (signal.SIGINT, signal.SIGTERM)
    previous = {kind: signal.signal(kind, lambda signum, frame: came.append(signum)) for kind in kinds}
    try:
        yield
    finally:
        for kind, handler in previous.items():
            signal.signal(kind, handler)
        if came:
            signal.raise_signal(came[0])


# ------------------------------------------------------------------------------------------ written behind
#: Inside :func:`written_behind`: ``(the pid of the process that opened it, [(process, pipe, paths), …])``.
_BEHIND: tuple[int, list] | None = None
#: True in a process forked by :func:`written_behind` to write files (it draws its figures itself).
_WRITING_LATER = False


def writing_behind() -> bool:
    """True inside :func:`written_behind` in the process that opened it: files added with ``behind=True``
    are written by other processes (so a command need not start figure workers of its own)."""
    return _BEHIND is not None and _BEHIND[0] == os.getpid()


def in_writer_process() -> bool:
    """True in a process forked by :func:`written_behind` to write files: draw in this one process."""
    return _WRITING_LATER


@contextlib.contextmanager
def written_behind() -> Iterator[None]:
    """Inside the block, :meth:`Artefacts.write` leaves the files added with ``behind=True`` (figures, a
    report) to a forked process and returns at once, so that the caller goes on while they are drawn (Linux
    with more than one core; elsewhere they are written in turn as usual).  ``pinid demo`` runs its steps in
    such a block.  The block's end waits for every such process and raises the first one's error as an
    :class:`OutputError` (the files written before stay: the caller's own all-or-nothing undoes them); an
    error or interrupt inside the block stops them first."""
    global _BEHIND
    previous = _BEHIND
    if sys.platform.startswith("linux") and (os.cpu_count() or 1) > 1:
        _BEHIND = (os.getpid(), [])
    running = _BEHIND[1] if _BEHIND is not previous else []
    try:
        yield
        for proc, pipe, paths in running:
            try:
                error = pipe.recv()
            except EOFError:
                error = "the process writing them ended without a word"
            proc.join()
            if error:
                raise OutputError(f"{display_path(paths[0])} (written behind): {error}")
    finally:
        for proc, pipe, _ in running:
            if proc.is_alive():
                proc.terminate()
                proc.join(timeout=2)  # a SIGTERM that came before the process set its handlers is held
            if proc.is_alive():
                proc.kill()
            proc.join()
            pipe.close()
        _BEHIND = previous


def _write_later(entries: list[tuple[Path, Any]], overwrite: bool) -> None:
    """Fork the process that writes ``entries`` for :func:`written_behind`."""
    import multiprocessing
    import warnings

    ctx = multiprocessing.get_context("fork")
    pipe, child = ctx.Pipe(duplex=False)
    sys.stdout.flush()  # what is buffered now would be written again by the child
    sys.stderr.flush()
    with warnings.catch_warnings():  # Python ≥ 3.12 warns about fork with threads (BLAS)
        warnings.simplefilter("ignore", DeprecationWarning)
        with deferred_interrupts():
            proc = ctx.Process(target=_writer, args=(entries, overwrite, child), daemon=True)
            proc.start()
    child.close()
    _BEHIND[1].append((proc, pipe, [p for p, _ in entries]))


def _writer(entries: list[tuple[Path, Any]], overwrite: bool, conn) -> None:
    """The forked process of :func:`_write_later`: write ``entries`` all or nothing, send None or the error."""
    import signal

    global _BEHIND, _WRITING_LATER
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's: it stops this process
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _BEHIND, _WRITING_LATER = None, True
    try:
        arts = Artefacts(overwrite=overwrite)
        for p, write in entries:
            arts.add(p, write)
        arts.write()
        conn.send(None)
    except BaseException as exc:  # noqa: BLE001 - sent to the parent, which raises it
        conn.send(str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    finally:
        conn.close()
