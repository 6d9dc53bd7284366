"""Benchmark: ``pinid identify``'s defaults against other option sets on the shared real recordings (issue 44).

    python tests/benchmarks/bench_defaults.py                       # every case, every option set
    python tests/benchmarks/bench_defaults.py --cases kuka-70/30 --sets "default;--terms fc,fv"

Each case is run through the command line (``python -m pinid.cli identify … --no-report``), once per option set,
and scored as the terminal does: the best method's validation error, pooled relative RMS against the torque as
recorded; beside it the model-class floor (the same terms fitted by least squares on the validation recording
itself) and the CPU time of the whole command (user + system, the load of other processes left out).

Cases (skipped when ``../shared/data`` is absent): the KUKA LBR Med 7 (first 70 % of ``mext.csv`` → last 30 %;
all of ``mext.csv`` → ``js.csv``, another day) and the DFKI double pendulum (trajectory 02 → 03; 02 and 00 → 03;
``docs/examples/double_pendulum.toml``).  Option sets: ``--terms fc,fv`` (the default before issue 44), no
option (the default), ``--terms fc,fv,offset``, ``--terms auto``, ripple with its periods chosen, ``--cutoff auto``.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

from conftest import shared_data  # noqa: E402

SETS = (
    "--terms fc,fv",
    "default",
    "--terms fc,fv,offset",
    "--terms auto",
    "--terms fc,fv,offset,ripple --ripple-periods auto",
    "--cutoff auto",
)


def cases(folder: Path) -> dict[str, list[str]]:
    """``{name: identify's arguments}`` of the cases whose recordings are here."""
    k, dp = shared_data() / "kuka_med7", shared_data() / "double_pendulum"
    out = {}
    if k.is_dir():
        study = folder / "kuka70.toml"
        study.write_text(
            f'[[recording]]\nfile = "{k}/mext.csv"\nrole = "train"\nrows = [0, 7004]\n'
            f'[[recording]]\nfile = "{k}/mext.csv"\nrole = "validate"\nrows = [7004]\n'
        )
        out["kuka-70/30"] = ["--urdf", f"{k}/robot.urdf", "--manifest", str(study)]
        out["kuka-mext→js"] = ["--urdf", f"{k}/robot.urdf", "--data", f"{k}/mext.csv", "--validate", f"{k}/js.csv"]
    if dp.is_dir():
        common = ["--urdf", f"{dp}/double_pendulum.urdf", "--mapping", str(ROOT / "docs/examples/double_pendulum.toml")]
        out["dp-02→03"] = [*common, "--data", f"{dp}/trajectory_02.csv", "--validate", f"{dp}/trajectory_03.csv"]
        out["dp-02,00→03"] = [
            *common,
            *("--data", f"{dp}/trajectory_02.csv", "--data", f"{dp}/trajectory_00.csv"),
            *("--validate", f"{dp}/trajectory_03.csv"),
        ]
    return out


def run(args: list[str], folder: Path) -> dict:
    """One identify: the best method, every method's validation %, the floor %, CPU seconds, the terms."""
    out = tempfile.mkdtemp(dir=folder)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run(
        [sys.executable, "-m", "pinid.cli", "identify", *args, "--no-report", "-o", out], capture_output=True, text=True
    )
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if p.returncode:
        return {"error": p.stderr.strip().splitlines()[-1] if p.stderr.strip() else f"exit {p.returncode}"}
    d = json.loads((Path(out) / "identification.json").read_text())
    valid = {m: r["validation"]["all"]["rel_rms_percent"] for m, r in d["methods"].items()}
    floor = (d.get("floor") or {}).get("all", {}).get("rel_rms_percent")
    cut = (d["data"].get("cutoff") or {}).get("cutoff_hz")
    return {"best": d["best"], "valid": valid, "floor": floor, "cpu": cpu, "terms": d["robot"]["terms"], "cutoff": cut}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", default=None, help="comma-separated case names (default all)")
    ap.add_argument("--sets", default=";".join(SETS), help="option sets separated by ';' ('default': none)")
    args = ap.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="bench_defaults_"))
    found = cases(folder)
    wanted = list(found) if args.cases is None else args.cases.split(",")
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print("| case | options | best: valid. % | ols / wls / sdp valid. % | floor % | terms | CPU [s] |")
    print("|---|---|---|---|---|---|---|")
    for name in wanted:
        for spec in args.sets.split(";"):
            extra = [] if spec.strip() == "default" else spec.split()
            r = run(found[name] + extra, folder)
            if "error" in r:
                print(f"| {name} | {spec} | failed: {r['error']} | | | | |", flush=True)
                continue
            each = " / ".join(f"{v:.2f}" for v in r["valid"].values())
            cut = f" (cut-off {r['cutoff']:g} Hz)" if r["cutoff"] else ""
            floor = "—" if r["floor"] is None else f"{r['floor']:.2f}"
            print(
                f"| {name} | {spec} | {r['valid'][r['best']]:.2f} ({r['best']}) | {each} | {floor} | "
                f"{','.join(r['terms'])}{cut} | {r['cpu']:.1f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
