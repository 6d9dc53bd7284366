"""Benchmark: same results before and after a change (issue 17) — the identification JSON, number by number.

    python tests/benchmarks/bench_same_results.py --before /tmp/before     # /tmp/before: an older checkout

Simulates the exo_leg twin once with this tree (preset zha2019-1, 60 s training; zha2019-2, 30 s
validation), runs the same ``pinid identify --methods ols,wls,sdp --no-figures`` with both trees, and
compares the two ``identification.json`` files: every number (recursively, lists and dicts) must print
the same with 12 significant digits, and every text the same; timings (``seconds``), paths and versions are
skipped.  Both runs get ``PYTHONHASHSEED=0``, so a difference is the code's, not the hash seed's.  Prints how
many numbers were compared, the largest relative difference, and each key that differs; exit status 1
if any does.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_startup import twin_recordings  # the script's own folder is on the path

HERE = Path(__file__).resolve().parents[2]
SKIP = {"seconds", "version", "pinid_version", "created", "path", "urdf", "data", "validate", "output", "files"}


def run(tree: Path, args: list[str], cwd: Path) -> None:
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1", PYTHONHASHSEED="0")
    subprocess.run([sys.executable, "-m", "pinid.cli", *args], cwd=cwd, env=env, check=True, stdout=subprocess.DEVNULL)


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
        if f"{a:.12g}" != f"{b:.12g}":
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
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        twin_recordings(d)
        result = {}
        for name, tree in (("before", a.before.resolve()), ("this", HERE)):
            run(
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
                    name,
                ],
                d,
            )
            result[name] = json.loads((d / name / "identification.json").read_text())
    out = {"numbers": 0, "numdiff": 0, "max_rel": 0.0, "diff": []}
    compare(result["before"], result["this"], "identification", out)
    print(
        f"identification.json ({a.methods}): {out['numbers']} numbers compared, "
        f"{out['numdiff']} differ at 12 significant digits, largest relative difference {out['max_rel']:.3g}; "
        f"{len(out['diff']) - out['numdiff']} other differences (text, keys, lengths)"
    )
    for line in out["diff"][:40]:
        print("  " + line)
    sys.exit(1 if out["diff"] else 0)


if __name__ == "__main__":
    main()
