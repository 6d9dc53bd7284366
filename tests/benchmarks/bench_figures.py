"""Benchmark: the drawing time of each figure of ``pinid identify``'s report (issue 35), in one process.

    cd /tmp/su && python /path/to/bench_figures.py --urdf ur5 --data ur5_train.csv --validate ur5_val.csv \\
        --before /work/main --out /tmp/figs

Runs ``pinid identify --methods ols,sdp`` once with this tree, keeping the figure recipes the report would
hand to :func:`pinid.report.figures.render_pngs` (grouped as for 2 workers), and pickles them.  Then, in
fresh interpreters (``PYTHONPATH`` this tree and, with ``--before DIR``, that tree, interleaved
``--repeat`` times), draws every recipe in-process after ``import matplotlib.pyplot`` and times it:
CPU time (``time.process_time``, robust to the load of a shared machine) and wall time; best of the
repeats.  The PNGs of the last repeat are written to ``--out``/{after,before}/ to look at.
Prints a Markdown table with the machine's load.
"""

from __future__ import annotations

import argparse
import os
import pickle
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[2]


def capture(argv: list[str], path: Path) -> None:
    """Run ``pinid identify argv`` here, pickling the grouped recipes instead of drawing them."""
    import pinid.report.figures as F
    import pinid.report.markdown as M

    def keep(recipes, *, workers=None):
        path.write_bytes(pickle.dumps(dict(recipes)))
        names = [n for key in recipes for n in (key if isinstance(key, tuple) else (key,))]
        return {n: b"" for n in names}  # empty PNGs: the report is written, the figures are drawn below

    F.render_pngs = keep
    F.start_figure_workers = lambda workers=None: None
    grouped = M.grouped_recipes
    M.grouped_recipes = lambda recipes, workers: grouped(recipes, 2)
    from pinid.cli.main import main

    try:
        main(["identify", *argv])
    except SystemExit:
        pass


def draw(path: Path, out: Path) -> None:
    """Draw each pickled recipe; print ``name cpu wall`` per recipe."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401

    from pinid.report.figures import render_pngs

    recipes = pickle.loads(path.read_bytes())
    out.mkdir(parents=True, exist_ok=True)
    for key, recipe in recipes.items():
        c, w = time.process_time(), time.perf_counter()
        drawn = render_pngs({key: recipe}, workers=1)
        c, w = time.process_time() - c, time.perf_counter() - w
        names = list(key) if isinstance(key, tuple) else [key]
        for name, png in drawn.items():
            (out / f"{name}.png").write_bytes(png)
        print(f"{'+'.join(names)} {c:.4f} {w:.4f}")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--before", type=Path)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", type=Path, default=Path("bench_figures_out"))
    p.add_argument("--keep", type=Path, help="also copy the pickled recipes here")
    p.add_argument("--capture", type=Path, help=argparse.SUPPRESS)
    p.add_argument("--draw", nargs=2, type=Path, help=argparse.SUPPRESS)
    args, rest = p.parse_known_args()
    if args.capture:
        return capture(rest, args.capture)
    if args.draw:
        return draw(*args.draw)
    env = dict(os.environ, MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    with tempfile.TemporaryDirectory() as tmp:
        pkl = Path(tmp) / "recipes.pkl"
        cmd = [sys.executable, __file__, "--capture", str(pkl), *rest, "--methods", "ols,sdp", "--force"]
        subprocess.run([*cmd, "-o", str(Path(tmp) / "run")], env=dict(env, PYTHONPATH=str(HERE)), check=True)
        if args.keep:
            args.keep.write_bytes(pkl.read_bytes())
        trees = {"after": HERE} | ({"before": args.before} if args.before else {})
        best: dict[str, dict[str, tuple[float, float]]] = {k: {} for k in trees}
        for _ in range(args.repeat):
            for label, tree in trees.items():
                res = subprocess.run(
                    [sys.executable, __file__, "--draw", str(pkl), str(args.out / label)],
                    env=dict(env, PYTHONPATH=str(tree)),
                    check=True,
                    capture_output=True,
                    text=True,
                )
                for line in res.stdout.split("\n"):
                    if line.strip():
                        name, c, w = line.split()
                        old = best[label].get(name, (1e9, 1e9))
                        best[label][name] = (min(old[0], float(c)), min(old[1], float(w)))
    print(f"load {os.getloadavg()[0]:.2f}, nproc {os.cpu_count()}, best of {args.repeat}\n")
    print(
        "| figure | after CPU [s] | after wall [s] |"
        + (" before CPU [s] | before wall [s] | CPU ratio |" if args.before else "")
    )
    print("|---|---|---|" + ("---|---|---|" if args.before else ""))
    tot = {k: [0.0, 0.0] for k in trees}
    for name, (c, w) in best["after"].items():
        row = f"| {name} | {c:.3f} | {w:.3f} |"
        tot["after"][0] += c
        tot["after"][1] += w
        if args.before and name in best["before"]:
            bc, bw = best["before"][name]
            tot["before"][0] += bc
            tot["before"][1] += bw
            row += f" {bc:.3f} | {bw:.3f} | {c / bc:.2f} |"
        print(row)
    row = f"| total | {tot['after'][0]:.3f} | {tot['after'][1]:.3f} |"
    if args.before:
        row += f" {tot['before'][0]:.3f} | {tot['before'][1]:.3f} | {tot['after'][0] / tot['before'][0]:.2f} |"
    print(row)


if __name__ == "__main__":
    main()
