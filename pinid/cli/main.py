"""The ``pinid`` command.  Each subcommand lives in ``pinid/cli/<name>.py`` and provides

* ``HELP`` (one line), ``DESCRIPTION`` (what it reads, what it writes, an example),
* ``add_arguments(parser)`` and ``run(args) -> int``.

Adding a subcommand is one file plus one entry in :data:`COMMANDS`.  Errors derived from
:class:`~pinid.errors.PinidError` (bad input) become one line on stderr and exit status 2, with no
traceback; any other exception is a bug and becomes one line and exit status 1 (``PINID_DEBUG=1``
re-raises it with its traceback).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import re
import os
import signal
import sys
import threading
import warnings
from collections.abc import Sequence
from pathlib import Path

from pinid import __version__
from pinid.errors import PinidError
from pinid.io import OVERWRITE
from pinid.progress import MODE

#: Subcommands in the order ``pinid --help`` lists them.
COMMANDS: tuple[str, ...] = (
    "info",
    "wearer",
    "excite",
    "simulate",
    "identify",
    "compare",
    "track",
    "export",
    "flex",
    "demo",
)


#: The papers the help texts cite as "seed NNN" (the project's seed papers, docs/tutorials/).
SOURCES: dict[str, str] = {
    "000": "Zha, Sheng, Guo, Qiu, Deng, Wang 2019, Dynamic parameter identification of a lower extremity "
    "exoskeleton using RLS-PSO, Appl. Sci. 9, 324",
    "001": "Shi, Kou, Chen, Wang, Guo 2024, Model parameters identification and backstepping control of lower "
    "limb exoskeleton based on enhanced whale algorithm",
    "002": "Zha et al. 2019, the RLS-PSO paper of seed 000 (its abstract and introduction)",
    "003": "Int. J. Eng. 33(9) 2020 (doi 10.5829/ije.2020.33.09c.14), parameter identification of a target "
    "tracker robot with flexible (belt) joints using PSO",
}


def sources_epilog(text: str) -> str | None:
    """A "sources:" section naming each paper ``text`` cites as "seed NNN" (None when it cites none)."""
    import re
    import textwrap

    cited = sorted(set(re.findall(r"\bseed (\d{3})\b", text)) & set(SOURCES))
    if not cited:
        return None
    lines = ["sources:"]
    for n in cited:
        lines += textwrap.wrap(SOURCES[n], 100, initial_indent=f"  seed {n}  ", subsequent_indent=" " * 12)
    return "\n".join(lines)


def _add_sources(p: argparse.ArgumentParser) -> None:
    """Give ``p`` (and each action of a command with actions) the sources its help cites."""
    text = (p.description or "") + " ".join(a.help or "" for a in p._actions)
    for a in p._actions:
        if isinstance(a, argparse._SubParsersAction):
            text += " ".join(c.help or "" for c in a._choices_actions)
            for child in a.choices.values():
                child.formatter_class = argparse.RawDescriptionHelpFormatter
                _add_sources(child)
    p.epilog = sources_epilog(text)


class _Parser(argparse.ArgumentParser):
    #: Values that start with "-" but are numbers or lists of them ("-1,0", "-0.5", "-1e-3:2"): read as an option's
    #: value, not as an unknown option (argparse's own pattern takes only "-1" and "-1.5"; pinid has no option
    #: that looks like a number).
    NEGATIVE_VALUE = re.compile(r"^-\.?\d[\d.,:eE+\-]*$")

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = self.NEGATIVE_VALUE

    def error(self, message: str) -> None:  # argparse's own errors: one line, exit 2
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``pinid`` command with every available subcommand."""
    parser = _Parser(
        prog="pinid",
        description="Identify the rigid-body dynamics of a robot from its URDF and measured data.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Every command takes --force (replace existing outputs) and --progress/--no-progress: long work\n"
        "(excitation design, metaheuristics, compare, flex) shows a progress bar on stderr when it is a\n"
        "terminal, and otherwise (CI, logs, pipes) a line every 5 s and one at the end; --no-progress shows\n"
        "none.  PINID_PROGRESS=1 or 0 overrides both, from Python too (where the default is a bar on a\n"
        "terminal only).",
    )
    parser.add_argument("--version", action="version", version=f"pinid {__version__}")
    # every command's namespace: the parser that read it (pinid demo reads its steps' command lines with it)
    parser.set_defaults(command_parser=parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name in COMMANDS:
        mod = importlib.import_module(f"pinid.cli.{name}")
        p = sub.add_parser(
            name, help=mod.HELP, description=mod.DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
        )
        mod.add_arguments(p)
        if not any("--force" in a.option_strings for a in p._actions):
            p.add_argument("--force", action="store_true", help="overwrite output files that already exist")
        _add_progress_argument(p)
        _add_sources(p)
        p.set_defaults(command_function=mod.run)
    return parser


def _add_progress_argument(p: argparse.ArgumentParser, default=None) -> None:
    """--progress/--no-progress on a command, or on each action of a command that has actions (pinid flex)."""
    actions = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
    for child in actions[0].choices.values() if actions else ():
        # before or after the action (pinid flex --no-progress fit, pinid flex fit --no-progress); the
        # action's own default is left out so that it does not undo the command's
        _add_progress_argument(child, default=argparse.SUPPRESS)
    p.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=default,
        help="progress of long work on stderr: a bar on a terminal, otherwise a line every few seconds "
        "(default); --no-progress: none",
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``pinid`` console script; returns the exit status."""
    with _quiet_startup_interrupt():  # Ctrl-C while numpy, scipy, Pinocchio load: one line, status 130
        parser = build_parser()
        args = parser.parse_args(argv)
        if not getattr(args, "command_function", None):
            parser.print_help()
            return 2
        _preload()
    OVERWRITE.set(bool(getattr(args, "force", False)))  # the CLI never replaces a file unless told to
    token = MODE.set("auto" if getattr(args, "progress", None) is None else args.progress)
    from pinid.blas import cli_blas_threads  # deferred: pinid --help does not load it

    _sigterm_as_interrupt()
    try:
        check_input_files(args)
        with cli_blas_threads(), _one_line_warnings(args.command):
            status = int(args.command_function(args) or 0)
            sys.stdout.flush()  # a closed pipe shows here, not at the interpreter's exit
            return status
    except BrokenPipeError:  # the reader went away (`pinid info | head -1`): not the user's error, no message
        return _closed_stdout()
    except PinidError as exc:
        print(f"pinid {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"pinid {args.command}: interrupted; no output file was written", file=sys.stderr)
        return 2
    except (OSError, MemoryError) as exc:
        print(f"pinid {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except Exception as exc:  # a bug, not bad input: still one line (status 1); PINID_DEBUG=1 shows the traceback
        if os.environ.get("PINID_DEBUG"):
            raise
        where = exc.__traceback__
        while where is not None and where.tb_next is not None:
            where = where.tb_next
        at = f" at {Path(where.tb_frame.f_code.co_filename).name}:{where.tb_lineno}" if where is not None else ""
        message = " ".join(str(exc).split())  # one line, whatever the exception's text
        print(
            f"pinid {args.command}: internal error: {type(exc).__name__}: {message}{at} "
            "(a bug: please report it; PINID_DEBUG=1 shows the traceback)",
            file=sys.stderr,
        )
        return 1
    finally:
        MODE.reset(token)  # main() called from Python leaves no command-line setting behind


#: Exit status of a run interrupted (Ctrl-C) before its work began: 128 + SIGINT, as a shell reports it.
EXIT_INTERRUPTED_AT_START = 130


@contextlib.contextmanager
def _quiet_startup_interrupt():
    """While the command starts (its modules and their extensions load), Ctrl-C ends it at once with one
    line and status 130: nothing has been written yet, and a KeyboardInterrupt raised inside an extension
    module's import gives a traceback or an unrelated error ("PyCapsule_Import could not import module
    datetime").  The previous handler is put back before the work, where Ctrl-C cleans up the outputs."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        os.write(2, b"pinid: interrupted while starting; nothing was written\n")
        os._exit(EXIT_INTERRUPTED_AT_START)

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _preload() -> None:
    """Load the heavy extension modules every command uses (numpy, scipy.linalg, Pinocchio) while
    :func:`_quiet_startup_interrupt` holds Ctrl-C."""
    import numpy  # noqa: F401
    import scipy.linalg  # noqa: F401

    import pinid.model.robot  # noqa: F401  (Pinocchio)


#: Options that name an input file, per parsed-argument name: what the file is.  ``truth`` is an input
#: of ``compare`` only (``simulate --truth`` is an output).
INPUT_FILE_OPTIONS = {
    "urdf": "URDF file",
    "urdf_true": "URDF file",
    "drives": "drives file (TOML)",
    "spec": "spec file",
    "comfort": "comfort limits file (TOML)",
    "evaluate": "trajectory JSON file",
    "excitation": "trajectory JSON file",
    "reference": "trajectory JSON file",
    "data": "recording",
    "validate": "recording",
    "payload_data": "recording",
    "first_data": "recording",
    "first_validate": "recording",
    "mapping": "mapping spec (TOML)",
    "exo": "model JSON file",
    "model": "model file",
    "payload": "payload file (TOML)",
    "x0": "JSON file",
}

#: Input options whose value may also be a folder (a ROS 2 bag is a folder).
FOLDER_INPUTS = {"data", "validate", "payload_data", "first_data", "first_validate"}


def check_input_files(args: argparse.Namespace) -> None:
    """Every input-file option whose value names an existing path must name a regular file (a folder for
    recordings): a FIFO would block forever, ``/dev/zero`` never ends.  SpecError naming the option
    (:func:`pinid.io.check_input_file`; the readers bound the size they read)."""
    from pinid.io import check_input_file

    names = dict(INPUT_FILE_OPTIONS)
    if args.command == "compare":
        names["truth"] = "truth JSON file"
    for dest, what in names.items():
        values = getattr(args, dest, None)
        for v in values if isinstance(values, list) else [values]:
            if not isinstance(v, str) or not os.path.lexists(v):
                continue  # absent: a robot name, a preset, or the reader's own "not found"
            if dest in FOLDER_INPUTS and os.path.isdir(v):
                continue
            check_input_file(v, what, option="--" + dest.replace("_", "-"))


@contextlib.contextmanager
def _one_line_warnings(command: str):
    """Warnings as one line each on stderr, ``pinid COMMAND: warning: …`` (not Python's file:line form)."""

    def show(message, category, filename, lineno, file=None, line=None):
        print(f"pinid {command}: warning: {' '.join(str(message).split())}", file=sys.stderr)

    with warnings.catch_warnings():
        warnings.showwarning = show
        yield


def _sigterm_as_interrupt() -> None:
    """Handle SIGTERM like SIGINT (KeyboardInterrupt), so the all-or-nothing output writer
    (:class:`pinid.io.Artefacts`) cleans up after ``kill`` as it does after Ctrl-C."""

    def handler(signum, frame):
        raise KeyboardInterrupt

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, handler)


#: Exit status when the reader of stdout closed the pipe: 128 + SIGPIPE, what a Unix tool killed by it reports.
BROKEN_PIPE_STATUS = 128 + 13


def _closed_stdout() -> int:
    """Point stdout at the null device (the interpreter's final flush must not fail again) and return
    :data:`BROKEN_PIPE_STATUS`: the output was cut short on purpose by its reader (docs/checks.md)."""
    with contextlib.suppress(OSError, ValueError):
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    return BROKEN_PIPE_STATUS


if __name__ == "__main__":
    sys.exit(main())
