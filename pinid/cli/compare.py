"""``pinid compare``: run several estimators on the same recordings with several seeds and compare them."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from pinid.cli.common import (
    add_floating_arguments,
    names_text,
    estimators_text,
    add_mapping_arguments,
    add_method_arguments,
    add_preprocessing_arguments,
    add_recording_arguments,
    add_robot_arguments,
    add_stribeck_arguments,
    add_terms_argument,
    methods_from_args,
    options_from_args,
    preprocess_from_args,
    recording_options,
    study_from_args,
    rest_velocity_from_args,
    mapping_from_args,
    robot_from_args,
    terms_from_args,
)
from pinid.errors import SpecError
from pinid.estimators import ESTIMATORS, quick_methods
from pinid.io import check_outputs
from pinid.parallel import check_scheduler, default_workers

HELP = f"compare estimators ({', '.join(ESTIMATORS)}) on the same data, several seeds"
DESCRIPTION = f"""\
Reads a URDF and training recordings (CSV; --mapping names their columns; missing velocities and
accelerations are filled as in pinid identify), runs the chosen methods (default: those of the
estimator registry that do not simulate the robot and are not left out of the defaults: {", ".join(quick_methods())}; all: every one) on the same rows — deterministic methods once, the metaheuristics once
per seed — validates every run on the held-out --validate recordings and writes into the output folder
(-o, default results/):

  comparison.json      every run: identified base parameters, training costs (½Σr² and Σ|r|) next to
                       their global minima, validation error per joint (mean ± std of |e|, RMS,
                       relative RMS), error against --truth, convergence curve, time; and a summary
                       over the seeds
  comparison.md        the tables below and the command
  compare_*.png        convergence curves, validation errors, parameter errors (with --truth)

methods of the estimator registry (--methods):
{estimators_text()}

Least squares minimises ½Σr² globally on its training data, so no method can fit the training data
better on that cost; the comparison that means something is on held-out data, against the truth
(twin), over several seeds.  The metaheuristics search a box around the URDF's base parameters
(±max(100 %, half the parameter's natural magnitude); --box rls: the range of a recursive
least-squares run, seed 000's RLS-PSO).  With --first-data the methods run in seed 000's segmental
strategy: the --first-joints (default knee) from recordings where only they move, then the others
from --data with the first joints' contribution subtracted.

With --base floating (docs/floating-base.md) the recordings hold base motion and contact wrenches; every
method fits the same floating problem (--rows, --base-weight, --swing-rows as in pinid identify), and
comparison.json / comparison.md give per run the training and validation RMS over the rows used [N, N·m]
and, with --truth (the twin's .truth.json), the largest base-parameter error relative to its natural scale.

examples:
  pinid compare --urdf cad.urdf --data run1.csv --validate run2.csv --truth run1.truth.json --seeds 5
  pinid compare --urdf apal_leg --first-data traj1.csv --first-validate traj2.csv \\
      --data traj3.csv --validate traj4.csv --methods ols,sdp,pso,rls-pso --fitness sae
  pinid compare --urdf exo_lower_body --base floating --data susp.csv --validate susp_val.csv \\
      --truth susp.truth.json --methods ols,wls,sdp
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_robot_arguments(p, base=True)
    add_terms_argument(p)
    add_stribeck_arguments(p)
    add_recording_arguments(p)
    add_method_arguments(p, ",".join(quick_methods()))
    p.add_argument("--seeds", type=int, default=5, help="seeds per metaheuristic (0 … N−1); default 5")
    p.add_argument(
        "--truth",
        default=None,
        metavar="FILE",
        help="truth JSON of pinid simulate: report the error against the true base parameters",
    )
    add_mapping_arguments(p)
    p.add_argument("-o", "--output", default="results", metavar="FOLDER", help="output folder; default results/")
    p.add_argument(
        "--no-figures",
        "--no-plots",
        dest="no_figures",
        action="store_true",
        help="do not write the figures (--no-plots: the former name, still accepted)",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="local processes running the methods and seeds in parallel; default: every core "
        f"({default_workers()} here); the numbers do not depend on it",
    )
    p.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run the methods and seeds on this Dask cluster instead (tcp://host:8786; "
        'pip install "pinid[dask]"; docs/identification.md#studies-on-a-cluster)',
    )
    g = p.add_argument_group(f"metaheuristics ({', '.join(m for m, c in ESTIMATORS.items() if not c.deterministic)})")
    g.add_argument("--population", type=int, default=None, help="population size (default 100)")
    g.add_argument("--iterations", type=int, default=None, help="iterations (default 200)")
    g.add_argument(
        "--fitness", choices=("sse", "sae"), default=None, help="sse: ½Σr² (seed 001, default); sae: Σ|r| (seed 000)"
    )
    g.add_argument(
        "--box",
        choices=("nominal", "rls", "ls"),
        default=None,
        help=f"search box of {', '.join(_with_box('nominal'))} ({names_text(_with_box('rls'), 'and')} always "
        "searches its RLS box): nominal (default; "
        "around the URDF's values), rls (range of an RLS run), ls (around least squares — circular, "
        "for experiments)",
    )
    g.add_argument("--box-width", type=float, default=None, help="nominal box: ± this fraction of |value| (default 1)")
    g.add_argument(
        "--box-floor",
        type=float,
        default=None,
        help="nominal box: at least ± this fraction of the natural magnitude (default 0.5)",
    )
    g.add_argument(
        "--forgetting",
        type=float,
        default=None,
        help=f"{names_text(['rls', *_with_box('rls')], 'and')}: forgetting factor λ in (0, 1] (default 1)",
    )
    g = p.add_argument_group("segmental strategy (seed 000 §3.1)")
    g.add_argument(
        "--first-data",
        action="append",
        default=[],
        metavar="FILE",
        help="recording with only the first joints moving (seed 000: hip fixed); repeatable",
    )
    g.add_argument("--first-joints", default="knee", help="joints identified first, comma-separated; default knee")
    g.add_argument(
        "--first-validate",
        action="append",
        default=[],
        metavar="FILE",
        help="validation recording of the first stage (reported as 'first-stage validation')",
    )
    add_floating_arguments(p)
    add_preprocessing_arguments(p)


def _with_box(box: str) -> list[str]:
    """The metaheuristics of the registry that search ``box`` by default ("nominal", "rls")."""
    return [name for name, cls in ESTIMATORS.items() if getattr(cls, "default_box", None) == box]


def _arguments(args: argparse.Namespace, model) -> tuple:
    """``(study, methods, seeds, run keywords)`` of :func:`pinid.identification.compare.compare` the options
    describe: the :class:`~pinid.identification.study.Study` and the runs' settings."""
    from pinid.identification.floating import FloatingOptions  # deferred: pinid --help does not load it

    if args.seeds < 1:
        raise SpecError(f"--seeds {args.seeds}: expected at least 1")
    check_scheduler(args.scheduler)  # a malformed address fails here, before any work
    methods = methods_from_args(args)
    if args.first_validate and not args.first_data:
        raise SpecError("--first-validate needs --first-data (the segmental strategy)")
    meta = {
        key: getattr(args, key)
        for key in ("population", "iterations", "fitness", "box", "box_width", "box_floor")
        if getattr(args, key) is not None
    }
    options: dict = {}
    if args.forgetting is not None:
        options["rls"] = {"forgetting": args.forgetting}
        if "rls-pso" in methods or args.box == "rls":  # the RLS settings matter only where an RLS box is built
            meta["rls"] = {"forgetting": args.forgetting}
    validate = {}
    if args.validate:
        validate["validation"] = args.validate
    if args.first_validate:
        validate["first-stage validation"] = args.first_validate
    segmental, floating = None, args.base == "floating"
    if args.first_data:
        segmental = {
            "first": args.first_data,
            "joints": tuple(j.strip() for j in args.first_joints.split(",") if j.strip()),
        }
    fields = dict(
        validate=validate or None,
        terms=terms_from_args(args),
        segmental=segmental,
        mapping=mapping_from_args(args),
        preprocess=preprocess_from_args(args),
        rest_velocity=rest_velocity_from_args(args.rest_velocity),
        stribeck_velocity=args.stribeck_velocity,
        stribeck_shape=args.stribeck_shape,
        **recording_options(args),
        **(
            {"floating": FloatingOptions(args.rows, args.base_weight, args.swing_rows, args.calibration)}
            if floating
            else {}
        ),
    )
    run = dict(
        truth=args.truth,
        options=options_from_args(args, {k: v for k, v in options.items() if k in methods}),
        metaheuristic=meta,
        show_progress=None,
        workers=args.workers,
        scheduler=args.scheduler,
    )
    return study_from_args(args, model, fields), methods, args.seeds, run


def run(args: argparse.Namespace) -> int:
    # deferred: pinid --help does not load these (~7 ms)
    from pinid.identification.compare import compare
    from pinid.identification.outputs import COMPARISON_FILES, write_comparison

    out = Path(args.output)
    check_outputs(*(out / name for name in COMPARISON_FILES[:2]))  # before the work, creating nothing
    model = robot_from_args(args)
    study, methods, seeds, kwargs = _arguments(args, model)
    floating = f", floating base ({args.rows} rows)" if args.base == "floating" else ""
    print(
        f"comparing on {model.name}{floating} ({', '.join(model.joint_names)}): {args.methods}; seeds {args.seeds}"
        + ("; segmental" if study.segmental else "")
    )
    comp = compare(study, methods, seeds, **kwargs)
    print(comp.table())
    print()
    print(comp.values_table())
    written = write_comparison(comp, out, command="pinid " + shlex.join(sys.argv[1:]), figures=not args.no_figures)
    print(f"\nwrote {len(written)} files to {out}/: " + ", ".join(Path(p).name for p in written))
    return 0
