"""``pinid demo``: the whole loop on the bundled exoskeleton leg, with the embedded defaults."""

from __future__ import annotations

import argparse
import contextlib
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from pinid.cli.common import methods_from_args, seed_int
from pinid.estimators import ESTIMATORS, quick_methods
from pinid.io import check_outputs, written_behind

HELP = "run the whole loop on the bundled exoskeleton leg: excite, simulate, identify, validate, track"

#: The demo's steps: (title, what it does in the help), in the order run; :func:`steps` gives their commands.
STEPS: tuple[tuple[str, str], ...] = (
    (
        "design the excitation (a short search: 8 starts, 1 polished)",
        "pinid excite: the Fourier excitation under seed 001's Table 2 limits (the default search of\n"
        "pinid excite takes half a minute)",
    ),
    ("record the training run on the twin", "pinid simulate: 60 s of the twin following the designed excitation"),
    (
        "record the validation run (seed 001's Table 3 trajectory)",
        "pinid simulate: 30 s of the twin following a DIFFERENT trajectory, seed 001's published\nTable 3 excitation",
    ),
    (
        "identify with every estimator, validate, export",
        "pinid identify: every registered estimator, validated on the second recording; identified\n"
        "URDFs, report.md and report.html (-v prints every method's detail)",
    ),
    (
        "track with a CAD model (inertia 30 % off, no friction) and with the identified model",
        "pinid track: backstepping and computed torque on a CAD model (30 % off) vs the identified model",
    ),
)


def _description() -> str:
    listed = "\n".join(
        f"  {i}. {title}\n" + "\n".join(f"       {line}" for line in detail.splitlines())
        for i, (title, detail) in enumerate(STEPS, 1)
    )
    return f"""\
Runs every step of pinid on urdf/exo_leg.urdf with its embedded defaults, exactly as the separate
commands would; each step prints its number, its title and its command:

{listed}

Reads only what ships with pinid.  Writes into FOLDER (default demo/): excitation.json / .png / .csv,
train.csv, validate.csv (+ .truth.json each), identification/ (identification.json, model_*.json,
identified_*.urdf, report.md, report.html, figures), track/ (tracking.json, figures).  Takes about
half a minute.

examples:
  pinid demo
  pinid demo -o /tmp/pinid-demo --seed 3
"""


DESCRIPTION = _description()


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--output", default="demo", metavar="FOLDER", help="output folder; default demo/")
    p.add_argument("--seed", type=seed_int, default=1, help="random seed of the recordings; default 1")
    p.add_argument(
        "--methods",
        default=None,
        help="estimators to run (default: every registered one but those that simulate the robot or are "
        f"left out of the defaults, {', '.join(sorted(set(ESTIMATORS) - set(quick_methods())))}; see pinid identify --help)",
    )
    p.add_argument(
        "-v",
        "--verbose",
        action="store_true",
        help="print every method's detail in the identify step (pinid identify --verbose)",
    )


def steps(out: str, seed: int, methods: str, verbose: bool = False) -> list[tuple[str, list[str]]]:
    """The demo as a list of (title, pinid command line)."""
    table3 = "seed001_table3"  # ships with pinid (pinid.resources.bundled_trajectories)
    commands = [
        [
            "excite",
            "--urdf",
            "exo_leg",
            "--starts",
            "8",
            "--option",
            "polish=1",
            "-o",
            f"{out}/excitation.json",
            "--plot",
            f"{out}/excitation.png",
            "--csv",
            f"{out}/excitation.csv",
        ],
        [
            "simulate",
            "--urdf",
            "exo_leg",
            "--excitation",
            f"{out}/excitation.json",
            "--seconds",
            "60",
            "--seed",
            str(seed),
            "-o",
            f"{out}/train.csv",
        ],
        [
            "simulate",
            "--urdf",
            "exo_leg",
            "--excitation",
            table3,
            "--seconds",
            "30",
            "--seed",
            str(seed + 1),
            "-o",
            f"{out}/validate.csv",
        ],
        [
            "identify",
            "--urdf",
            "exo_leg",
            "--data",
            f"{out}/train.csv",
            "--validate",
            f"{out}/validate.csv",
            "--methods",
            methods,
            "--workers",
            str(min(2, os.cpu_count() or 1)),
            "-o",
            f"{out}/identification",
        ]
        + (["--verbose"] if verbose else []),
        [
            "track",
            "--urdf-true",
            "exo_leg",
            "--model",
            "cad:30",
            "--model",
            f"{out}/identification/identification.json",
            "--seconds",
            "6",
            "-o",
            f"{out}/track",
        ],
    ]
    return [(title, argv) for (title, _), argv in zip(STEPS, commands, strict=True)]


def run(args: argparse.Namespace) -> int:
    check_outputs(f"{args.output}/excitation.json")  # before the work, creating nothing
    methods = ",".join(methods_from_args(args)) if args.methods else ",".join(quick_methods())
    started = time.perf_counter()
    plan = steps(args.output, args.seed, methods, args.verbose)
    folder = all_or_nothing(Path(args.output), replace=args.force)
    with folder, written_behind(), _Ahead(args, plan[AHEAD][1]) as ahead:  # figures drawn beside the next step
        for i, (title, argv) in enumerate(plan, 1):
            print(f"\n[{i}/{len(plan)}] {title}\n$ pinid {' '.join(argv)}", flush=True)
            if i - 1 == AHEAD and ahead.done():
                continue  # run on the second core while the steps before it ran; its output printed now
            step = args.command_parser.parse_args(argv)  # the parser of this command line: the same options
            step.command_function(step)  # errors propagate: the demo stops at the first failing step
    print(f"\ndemo finished in {time.perf_counter() - started:.0f} s; everything is in {args.output}/:")
    print(summary_text(args.output))
    return 0


#: The step run ahead, in a forked process, while the steps before it run (index in :func:`steps`): the
#: validation recording, which follows a bundled trajectory and needs nothing the demo made before it.
AHEAD = 2


class _Ahead:
    """Step :data:`AHEAD` run in a forked process from the start (Linux, more than one core), its standard
    output and errors kept; :meth:`done` waits for it and prints them.  When it failed, or cannot run ahead,
    :meth:`done` is False and the step runs in turn as usual (its error, if any, raised there).  A process
    still running when the block ends (an error or Ctrl-C in another step) is stopped."""

    def __init__(self, args: argparse.Namespace, argv: list[str]) -> None:
        self.args, self.argv, self.proc, self.pipe = args, argv, None, None

    def __enter__(self) -> _Ahead:
        if sys.platform.startswith("linux") and (os.cpu_count() or 1) > 1:
            import multiprocessing
            import warnings

            ctx = multiprocessing.get_context("fork")
            sys.stdout.flush()  # what is buffered now would be written again by the child
            sys.stderr.flush()
            self.pipe, child = ctx.Pipe(duplex=False)
            with warnings.catch_warnings():  # Python ≥ 3.12 warns about fork with threads (BLAS)
                warnings.simplefilter("ignore", DeprecationWarning)
                self.proc = ctx.Process(target=self._child, args=(child,), daemon=True)
                self.proc.start()
            child.close()
        return self

    def _child(self, conn) -> None:
        import io
        import signal

        signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's: it stops this process
        out, err = io.StringIO(), io.StringIO()
        ok = False
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                step = self.args.command_parser.parse_args(self.argv)
                step.command_function(step)
            ok = True
        except BaseException:  # noqa: BLE001 - the step is run again in turn, where its error is raised
            pass
        conn.send((ok, out.getvalue(), err.getvalue()))
        conn.close()

    def done(self) -> bool:
        """Wait for the step; True (its output printed) when it succeeded."""
        if self.proc is None:
            return False
        try:
            ok, out, err = self.pipe.recv()
        except EOFError:  # the process died
            ok = False
        self.proc.join()
        self.proc = None
        if ok:
            sys.stdout.write(out)
            sys.stdout.flush()
            sys.stderr.write(err)
        return ok

    def __exit__(self, *exc) -> None:
        if self.proc is not None:
            self.proc.terminate()
            self.proc.join()
        if self.pipe is not None:
            self.pipe.close()


def summary_text(out: str) -> str:
    """Where the demo put what: one row per output, descriptions (and their continuation lines) aligned."""
    rows = [
        ("excitation.json, excitation.png", ["the designed excitation"]),
        ("train.csv, validate.csv", ["the twin's recordings (+ .truth.json)"]),
        ("identification/report.html", ["identification report (also report.md), figures,", "identified URDFs"]),
        ("track/tracking.json", ["closed-loop tracking, figures"]),
    ]
    width = max(len(f"{out}/{path}") for path, _ in rows) + 3
    lines = []
    for path, text in rows:
        lines.append(f"  {f'{out}/{path}':<{width}}{text[0]}")
        lines += [" " * (2 + width) + more for more in text[1:]]
    return "\n".join(lines)


#: What the demo writes in its folder (with --force, an earlier run's copies are replaced as one set).
OUTPUTS = (
    "excitation.json",
    "excitation.png",
    "excitation.csv",
    "train.csv",
    "train.truth.json",
    "validate.csv",
    "validate.truth.json",
    "identification",
    "track",
)


@contextlib.contextmanager
def all_or_nothing(out: Path, *, replace: bool) -> Iterator[None]:
    """The demo's folder all or nothing: after an error or an interrupt (SIGINT, SIGTERM) inside the block,
    ``out`` is as it was before — no new file, no empty folder, and with ``replace`` (--force) the earlier
    run's outputs back in place.  On success, files of ``out`` that are not demo outputs are kept."""
    existed = out.is_dir()
    backup = None
    if replace and existed:  # the earlier run's folder is set aside whole, and put back on failure
        backup = Path(tempfile.mkdtemp(prefix=".pinid-demo-", dir=out.parent))
        os.replace(out, backup / "old")
        out.mkdir()
    before = set(out.rglob("*")) if out.is_dir() else set()
    try:
        yield
    except BaseException:
        if backup is not None or not existed:
            shutil.rmtree(out, ignore_errors=True)
        else:
            for p in sorted(set(out.rglob("*")) - before, key=lambda p: len(p.parts), reverse=True):
                with contextlib.suppress(OSError):
                    p.rmdir() if p.is_dir() else p.unlink()
        if backup is not None:
            os.replace(backup / "old", out)
            shutil.rmtree(backup, ignore_errors=True)
        raise
    if backup is not None:  # keep what the user had there that is not a demo output
        for p in (backup / "old").iterdir():
            if p.name not in OUTPUTS and not (out / p.name).exists():
                os.replace(p, out / p.name)
        shutil.rmtree(backup, ignore_errors=True)
