"""Stage 2 from the command line: pinid identify --stage wearer on the twin with a wearer."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli
from pinid.identification.identified import IdentifiedModel
from pinid.model.base import base_parameters
from pinid.model.regressor import standard_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.wearer.attach import wearer_urdf

EXCITATION = str(Path(__file__).resolve().parents[2] / "excitation" / "exo_leg.json")


@pytest.fixture(scope="module")
def twin(tmp_path_factory):
    """Exo model (stage 1: the truth's exo, viscous friction only), exo + wearer URDF without Coulomb friction, a noise-free twin run
    with a drawn wearer and its exact signals."""
    d = tmp_path_factory.mktemp("s2")
    text = wearer_urdf("exo_leg", "hip:thigh,knee:shank,knee:foot", mass=75, height=1.78, sex="male")
    (d / "eww.urdf").write_text(re.sub(r'friction="[^"]*"', 'friction="0"', text))  # the plant: no Coulomb friction
    exo = RobotModel.from_urdf("exo_leg")
    terms = TermSelection.from_names("fv")
    IdentifiedModel(exo, terms, standard_parameters(exo, terms)).save(d / "exo.json")
    p = run_cli(
        "simulate",
        "--urdf",
        str(d / "eww.urdf"),
        "--excitation",
        EXCITATION,
        "--seconds",
        "5",
        "--seed",
        "4",
        "--wearer-draw",
        "--torque-noise",
        "0",
        "--true-signals",
        str(d / "true.npz"),
        "-o",
        str(d / "rec.csv"),
    )
    assert p.returncode == 0, p.stderr
    return d


def stage2(d: Path, *extra: str, data: str = "true.npz", exo: bool = True, urdf: str | None = None) -> tuple:
    """``pinid identify --stage wearer`` arguments on the twin's files (stage-1 model, exo + wearer URDF,
    recording ``data``), then ``extra``."""
    head = ("identify", "--stage", "wearer") + (("--exo", str(d / "exo.json")) if exo else ())
    return (*head, "--urdf", urdf or str(d / "eww.urdf"), "--data", str(d / data), *extra)


@pytest.mark.slow
def test_noise_free_stage2_recovers_wearer_base_parameters(twin):
    d = twin
    p = run_cli(*stage2(d, "--preprocess", "never", "-o", str(d / "out")))
    assert p.returncode == 0, p.stderr
    res = json.loads((d / "out" / "identification.json").read_text())
    whole = res
    drawn = json.loads((d / "rec.truth.json").read_text())["wearer"]["drawn"]["wearer_standard"]
    robot = RobotModel.from_urdf(d / "eww.urdf")
    truth = np.zeros(22)
    for j, w in drawn.items():
        truth[10 * robot.joint_index(j) : 10 * robot.joint_index(j) + 10] = w
    truth[20:] = 1.0  # passive scale factors of the twin
    bp = base_parameters(robot, TermSelection.from_names("passive"))
    expected = dict(zip(bp.names, bp.from_standard(truth)))
    got = res["base"]
    scale = max(abs(v) for v in expected.values())
    for n, v in expected.items():
        assert abs(got[n] - v) <= 1e-6 * max(abs(v), 1e-2 * scale), (n, got[n], v)
    assert abs(res["parameters"]["knee.kp"] - 1) < 1e-6 and abs(res["parameters"]["hip.kp"] - 1) < 1e-6
    assert sorted(p.name for p in (d / "out").iterdir()) == [
        "attachment_wearer.png",
        "identification.json",
        "model_table.json",
        "model_wearer.json",
        "report.html",
        "report.md",
        "segments_wearer.png",
        "torque_wearer.png",
    ]
    _check_report(d / "out", whole)
    # the command's file reads back as the stage (one result protocol): what it printed, the same models
    from pinid.wearer.stage import WearerStage

    back = WearerStage.load(d / "out" / "identification.json")
    assert back.text() in p.stdout and back.to_dict() == res
    np.testing.assert_allclose(back.fit.base, [got[n] for n in back.fit.base_names], rtol=0, atol=0)
    assert (
        back.fit.model().to_dict()["standard_parameters"]
        == json.loads((d / "out" / "model_wearer.json").read_text())["standard_parameters"]
    )
    m = IdentifiedModel.load(d / "out" / "model_wearer.json")
    assert "passive" in m.terms
    # closed loop on the same true wearer (--wearer-draw, same seed): identified vs table-based model
    p = run_cli(
        "track",
        "--urdf-true",
        str(d / "eww.urdf"),
        "--wearer-draw",
        "--seed",
        "4",
        "--seconds",
        "3",
        "--after",
        "1",
        "--model",
        str(d / "out" / "model_wearer.json"),
        "--model",
        str(d / "out" / "model_table.json"),
        "-o",
        str(d / "track"),
    )
    assert p.returncode == 0, p.stderr
    res = json.loads((d / "track" / "tracking.json").read_text())["results"]
    for c, by in res.items():
        ident, table = (by[str(d / "out" / f)] for f in ("model_wearer.json", "model_table.json"))
        for j in ("hip", "knee"):
            assert ident[j]["rms"] <= 0.5 * table[j]["rms"], (c, j, ident[j], table[j])


def _check_report(out: Path, res: dict) -> None:
    """report.md holds identification.json's figures; report.html is the same text with the figure embedded."""
    md = (out / "report.md").read_text()
    for w, label in (("identified", "exo + identified wearer"), ("table", "exo + table wearer"), ("exo", "exo alone")):
        r = res["train_rms"][w]
        assert f"| {label} | {r['hip']:.4g} | {r['knee']:.4g} |" in md, (label, r)
    for n, v in res["base"].items():
        assert f"| `{n}` | {v:.6g} | {res['base_table'][n]:.6g} |" in md, n
    assert "](torque_wearer.png)" in md and "Validation:" not in md  # no --validate: training figures only
    standard = md.split("## The wearer's standard parameters", 1)[1].split("\n## ", 1)[0]
    rows = {line.split("|")[1].strip(" `"): line for line in standard.splitlines() if line.startswith("| `")}
    assert rows and all(line.endswith(f"| {res['marks'][n]} |") for n, line in rows.items()), rows  # issue 33
    page = (out / "report.html").read_text()
    assert "data:image/png;base64," in page and "exo + identified wearer" in page
    for name in ("torque_wearer.png", "attachment_wearer.png", "segments_wearer.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and f"]({name})" in md, name


@pytest.mark.slow  # 4.4 s of CPU (docs/benchmarks.md, Test suite)
def test_stage2_report_options(twin, tmp_path):
    d = twin
    base = stage2(d, "--preprocess", "never")
    p = run_cli(*base, "--validate", str(d / "true.npz"), "--no-figures", "-o", str(tmp_path / "a"))
    assert p.returncode == 0, p.stderr
    assert sorted(f.name for f in (tmp_path / "a").iterdir()) == [
        "identification.json",
        "model_table.json",
        "model_wearer.json",
        "report.html",
        "report.md",
    ]
    md = (tmp_path / "a" / "report.md").read_text()
    res = json.loads((tmp_path / "a" / "identification.json").read_text())
    r = res["validation_rms"]["identified"]
    assert "Validation:" in md and f"| exo + identified wearer | {r['hip']:.4g} | {r['knee']:.4g} |" in md
    assert ".png" not in md
    # with figures: where the segments attach and stage 2 against the tables, in the report and listed
    p = run_cli(*base, "-o", str(tmp_path / "f"))
    assert p.returncode == 0, p.stderr
    md = (tmp_path / "f" / "report.md").read_text()
    for name in ("attachment_wearer.png", "segments_wearer.png", "torque_wearer.png"):
        assert (tmp_path / "f" / name).stat().st_size > 10_000 and name in p.stdout and f"]({name})" in md, name
    # --no-report into the same folder (--force): the earlier report goes, nothing stale stays
    p = run_cli(*base, "--no-report", "--force", "-o", str(tmp_path / "a"))
    assert p.returncode == 0, p.stderr
    assert sorted(f.name for f in (tmp_path / "a").iterdir()) == [
        "identification.json",
        "model_table.json",
        "model_wearer.json",
    ]


@pytest.mark.slow
def test_stage2_passive_exponents_from_the_command_line(twin):
    import dataclasses

    from pinid.data.formats import read_recording, write_recording
    from pinid.wearer.exponents import perturbed
    from pinid.wearer import passive

    d = twin
    robot = RobotModel.from_urdf(d / "eww.urdf")
    true_robot = robot.with_passive_exponents(perturbed(robot, 0.2))
    ds = read_recording(d / "true.npz")  # kp = 1: the twin's passive moments at the published exponents
    tau = ds.tau + passive.column(ds.q, true_robot) - passive.column(ds.q, robot)
    write_recording(d / "true_exp.npz", dataclasses.replace(ds, tau=tau))
    outs = {}
    for flag in ([], ["--passive-exponents"]):
        out = d / ("exp" if flag else "scale")
        p = run_cli(*stage2(d, "--preprocess", "never", *flag, "-o", str(out), data="true_exp.npz"))
        assert p.returncode == 0, p.stderr
        outs[bool(flag)] = json.loads((out / "identification.json").read_text())
    assert "passive_exponents" not in outs[False] and max(outs[False]["train_rms"]["identified"].values()) > 0.05
    exp = outs[True]["passive_exponents"]
    assert exp["rms_fitted"] < 1e-6 < 0.05 < exp["rms_published"]
    for kind, rows in true_robot.passive_exponents.items():
        np.testing.assert_allclose(exp["fitted"][kind], rows, rtol=1e-4)
    assert max(outs[True]["train_rms"]["identified"].values()) < 1e-6
    md = (d / "exp" / "report.md").read_text()
    assert (
        "## Passive-moment exponents" in md
        and "## Passive-moment exponents" not in (d / "scale" / "report.md").read_text()
    )
    fitted = exp["fitted"]["knee"][2][2]
    assert f"| `knee[2].cK` | {exp['published']['knee'][2][2]:.6g} | {fitted:.6g} |" in md
    model = IdentifiedModel.load(d / "exp" / "model_wearer.json")
    np.testing.assert_allclose(model.robot.passive_exponents["knee"], true_robot.passive_exponents["knee"], rtol=1e-4)


def test_stage2_bad_input_writes_nothing(twin, tmp_path):
    d = twin
    p = run_cli(*stage2(d, "-o", str(tmp_path / "a"), exo=False))
    assert_clean_error(p, "--stage wearer", "--exo")
    p = run_cli(*stage2(d, "-o", str(tmp_path / "b"), urdf="exo_leg"))
    assert_clean_error(p, "no wearer segment")
    p = run_cli(*stage2(d, "--no-passive", "--passive-exponents", "-o", str(tmp_path / "c")))
    assert_clean_error(p, "passive_exponents", "passive")
    assert not list(tmp_path.iterdir())


def test_stage2_takes_rest_velocity_when_given(twin, tmp_path):
    """--rest-velocity was ignored by stage 2; now it leaves out the slow rows when given (a different
    fit), keeps every row when not, and a bad value is a one-line error that writes nothing."""
    d = twin
    runs = {}
    for name, extra in (("all", ()), ("rest", ("--rest-velocity", "0.5"))):
        p = run_cli(*stage2(d, *extra, "--no-report", "-o", str(tmp_path / name)))
        assert p.returncode == 0, p.stderr
        runs[name] = json.loads((tmp_path / name / "identification.json").read_text())["base"]
    assert runs["all"] != runs["rest"]
    p = run_cli(*stage2(d, "--rest-velocity", "fast", "-o", str(tmp_path / "bad")))
    assert_clean_error(p, "--rest-velocity")
    assert not (tmp_path / "bad").exists()
