"""Benchmark: same results before and after a change (issue 17) — the identification JSON, number by number.

    python tests/benchmarks/bench_same_results.py --before /tmp/before     # /tmp/before: an older checkout

Simulates the exo_leg twin once with this tree (preset zha2019-1, 60 s training; zha2019-2, 30 s
validation), runs the same ``pinid identify --methods ols,wls,sdp --no-figures`` with both trees, and
compares what the user reads and what the JSON holds:

* **printed digits** — the terminal output and ``report.md``, line by line, with the time column, the
  date and the output folder masked: the issue's "same results to the last printed digit";
* **identification.json** — every number (recursively, lists and dicts) printed with ``--digits``
  significant digits (default 12), and every text; timings (``seconds``), paths and versions skipped.

Both runs get ``PYTHONHASHSEED=0``, so a difference is the code's, not the hash seed's.  Prints how many
lines and numbers were compared, the largest relative difference, and each difference; exit status 1 if
a printed line differs, or a JSON number at ``--digits`` digits.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_startup import twin_recordings  # the script's own folder is on the path

HERE = Path(__file__).resolve().parents[2]
SKIP = {"seconds", "version", "pinid_version", "created", "path", "urdf", "data", "validate", "output", "files"}


def run(tree: Path, args: list[str], cwd: Path) -> str:
    """``pinid ARGS`` with ``tree`` on the path; its standard output."""
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1", PYTHONHASHSEED="0")
    cmd = [sys.executable, "-m", "pinid.cli", *args]
    return subprocess.run(cmd, cwd=cwd, env=env, check=True, stdout=subprocess.PIPE, text=True).stdout


def printed_lines(text: str, folder: str, tree: Path) -> list[str]:
    """``text``'s lines with what legitimately changes masked: the time column of each table (terminal and
    Markdown) and the per-method times, the report's date and total time, the output folder and the tree."""
    out, time_col, md_time_col = [], None, None
    for line in text.replace(str(tree), "TREE").replace(folder, "OUT").splitlines():
        line = re.sub(r"; [0-9.e+-]+ s; status", "; … s; status", line)
        line = re.sub(r"; [0-9.e+-]+ s</summary>", "; … s</summary>", line)  # the report's folded method detail
        if line.startswith("pinid ") and "total time" in line:
            line = "pinid (date, total time masked)"
        elif line.startswith("|"):
            cells = re.split(r"(?<!\\)\|", line)  # not at an escaped \|
            if "time [s]" in [c.strip() for c in cells]:
                md_time_col = [c.strip() for c in cells].index("time [s]")
            elif md_time_col is not None and len(cells) > md_time_col and not set(cells[md_time_col]) <= set("-"):
                cells[md_time_col] = " … "
            line = "|".join(cells)
        else:
            md_time_col = None
            words = re.split(r"(\s{2,})", line)
            if "time [s]" in line and "status" in line:
                time_col = [w.strip() for w in words].index("time [s]")
            elif time_col is not None and len(words) > time_col and words[time_col].strip():
                words[time_col] = "…"
            if not line.strip():
                time_col = None
            line = " ".join("".join(words).split())  # the columns' widths may follow the masked times
        out.append(line)
    return out


def compare(a, b, where: str, out: dict) -> None:
    """Walk two JSON values; count numbers, record the largest relative difference and every mismatch."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if key in SKIP or any(key.endswith(s) for s in ("_seconds", "_path")):
                continue
            if key not in a or key not in b:
                out["diff"].append(f"{where}.{key}: only in {'after' if key not in a else 'before'}")
                continue
            compare(a[key], b[key], f"{where}.{key}", out)
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out["diff"].append(f"{where}: {len(a)} vs {len(b)} items")
            return
        for i, (x, y) in enumerate(zip(a, b)):
            compare(x, y, f"{where}[{i}]", out)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        out["numbers"] += 1
        if f"{a:.{out['digits']}g}" != f"{b:.{out['digits']}g}":
            out["numdiff"] += 1
            out["diff"].append(f"{where}: {a!r} vs {b!r}")
        if a != b:
            rel = abs(a - b) / max(abs(a), abs(b))
            out["max_rel"] = max(out["max_rel"], rel)
    elif a != b:
        out["diff"].append(f"{where}: {a!r} vs {b!r}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", type=Path, required=True, help="an older checkout to compare with")
    ap.add_argument("--methods", default="ols,wls,sdp")
    ap.add_argument("--digits", type=int, default=12, help="significant digits of the JSON comparison")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        twin_recordings(d)
        result, printed = {}, {}
        for name, tree in (("before", a.before.resolve()), ("this", HERE)):
            folder = f"identified_by_{name}_tree"
            stdout = run(
                tree,
                [
                    "identify",
                    "--urdf",
                    "exo_leg",
                    "--data",
                    "train.csv",
                    "--validate",
                    "val.csv",
                    "--methods",
                    a.methods,
                    "--no-figures",
                    "-o",
                    folder,
                ],
                d,
            )
            result[name] = json.loads((d / folder / "identification.json").read_text())
            report = (d / folder / "report.md").read_text()
            printed[name] = printed_lines(stdout, folder, tree) + printed_lines(report, folder, tree)
    lines = [(x, y) for x, y in zip(printed["before"], printed["this"]) if x != y]
    if len(printed["before"]) != len(printed["this"]):
        lines.append((f"{len(printed['before'])} lines", f"{len(printed['this'])} lines"))
    print(f"printed (terminal + report.md): {len(printed['this'])} lines compared, {len(lines)} differ")
    for x, y in lines[:20]:
        print(f"  before: {x}\n  this:   {y}")
    out = {"numbers": 0, "numdiff": 0, "max_rel": 0.0, "diff": [], "digits": a.digits}
    compare(result["before"], result["this"], "identification", out)
    print(
        f"identification.json ({a.methods}): {out['numbers']} numbers compared, "
        f"{out['numdiff']} differ at {a.digits} significant digits, largest relative difference {out['max_rel']:.3g}; "
        f"{len(out['diff']) - out['numdiff']} other differences (text, keys, lengths)"
    )
    for line in out["diff"][:40]:
        print("  " + line)
    sys.exit(1 if out["diff"] or lines else 0)


if __name__ == "__main__":
    main()
