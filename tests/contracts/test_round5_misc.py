"""Issue 47 (round 5): the reproducers 02, 09, 10 and 11 of ../shared/reproducers/round5/ kept as tests, and the
unclear messages and docs of that round that are not findings 1-8 (each case named after the issue's line)."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

import pinid
from conftest import run_cli


@pytest.fixture(scope="module")
def run_csv(tmp_path_factory) -> Path:
    """A 10 s twin recording of exo_leg (seed 1), as the reproducers make it."""
    folder = tmp_path_factory.mktemp("round5")
    r = run_cli(
        "simulate", "--urdf", "exo_leg", "--excitation", "exo_leg", "--seconds", "10", "--seed", "1",
        "-o", str(folder / "run.csv"), "--no-progress",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    return folder / "run.csv"


# ------------------------------------------------------------------ 02: compare --scheduler notanaddress
def test_02_compare_scheduler_without_port_is_a_one_line_error(run_csv, tmp_path):
    r = run_cli(
        "compare", "--urdf", "exo_leg", "--data", str(run_csv), "--methods", "ols", "--seeds", "1",
        "--scheduler", "notanaddress", "-o", str(tmp_path / "c"), "--no-plots", "--no-progress",
    )  # fmt: skip
    assert r.returncode == 2, r.stderr
    assert "scheduler 'notanaddress': expected an address tcp://host:port" in r.stderr
    assert "internal error" not in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "c").exists()  # refused before any work


def test_check_scheduler_accepts_addresses_and_refuses_the_rest():
    from pinid.parallel import check_scheduler

    pytest.importorskip("distributed")
    for good in (None, "tcp://127.0.0.1:8786", "127.0.0.1:8786", "tls://host:8786", "inproc://10.0.0.1/1/1"):
        assert check_scheduler(good) == good
    for bad in ("notanaddress", "tcp://host", "", "tcp://host:port", "a b:1"):
        with pytest.raises(pinid.SpecError, match="expected an address tcp://host:port"):
            check_scheduler(bad)


def test_compare_no_figures_is_the_option_and_no_plots_its_alias():
    from pinid.cli.main import build_parser

    parser = build_parser()
    for flag in ("--no-figures", "--no-plots"):
        args = parser.parse_args(["compare", "--urdf", "exo_leg", "--data", "x.csv", flag])
        assert args.no_figures is True
    assert "--no-figures" in run_cli("compare", "--help").stdout


# ------------------------------------------------------------------ 09: fsig / fl exports agree on friction
def _dynamics(urdf: str) -> list[tuple[float, float]]:
    return [(float(d), float(f)) for d, f in re.findall(r'<dynamics damping="([^"]+)" friction="([^"]+)"', urdf)]


def _mjcf_friction(xml: str) -> list[tuple[float, float]]:
    out = []
    for line in re.findall(r"<joint name=[^>]*>", xml):
        d = re.search(r'damping="([^"]+)"', line)
        f = re.search(r'frictionloss="([^"]+)"', line)
        out.append((float(d.group(1)) if d else 0.0, float(f.group(1)) if f else 0.0))
    return out


@pytest.mark.parametrize("terms", ["fsig", "fl"])
def test_09_urdf_and_mjcf_of_one_result_carry_the_same_friction(run_csv, tmp_path, terms):
    r = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(run_csv), "--terms", terms, "--methods", "sdp",
        "-o", str(tmp_path / "r"), "--no-progress", "--no-report", "--no-figures",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    urdf = (tmp_path / "r" / "identified_sdp.urdf").read_text()
    xml = (tmp_path / "r" / "identified_sdp.xml").read_text()
    # the source URDF's values (hip 0.8/1.2, knee 0.6/0.9), in both files
    assert _dynamics(urdf) == [(0.8, 1.2), (0.6, 0.9)]
    assert _mjcf_friction(xml) == _dynamics(urdf)
    # marked as the URDF's, in both files, and the headers say so (not "joint friction replaced")
    assert urdf.count("not identified (URDF value kept") == 2
    assert xml.count("not identified (URDF value kept") == 2
    head_urdf, head_xml = urdf.splitlines()[2], xml.splitlines()[1]
    assert "joint friction replaced" not in head_urdf and "the URDF's values kept, not identified" in head_urdf
    assert "the URDF's values kept, not identified" in head_xml
    # the identified term that has no field is said so in both
    assert f"identified terms with no URDF field (a comment in each joint): {terms}" in head_urdf
    assert f"not exported: hip.{terms} =" in head_xml


def test_09_identified_friction_replaces_the_urdf_values_in_both(run_csv, tmp_path):
    r = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(run_csv), "--terms", "fc,fv", "--methods", "sdp",
        "-o", str(tmp_path / "r"), "--no-progress", "--no-report", "--no-figures",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    urdf = (tmp_path / "r" / "identified_sdp.urdf").read_text()
    xml = (tmp_path / "r" / "identified_sdp.xml").read_text()
    model = json.loads((tmp_path / "r" / "model_sdp.json").read_text())
    assert "URDF value kept" not in urdf and "URDF value kept" not in xml
    np.testing.assert_allclose(_dynamics(urdf), _mjcf_friction(xml), rtol=1e-12)
    assert _dynamics(urdf) != [(0.8, 1.2), (0.6, 0.9)]  # the identified values, not the URDF's
    assert "joint friction, damping replaced" in urdf.splitlines()[2]
    assert model  # the model JSON is written beside them


def test_kept_friction_lists_the_urdf_values_of_terms_not_identified(exo):
    from pinid.model.terms import kept_friction

    assert kept_friction(exo, pinid.TermSelection.from_names("fc,fv")) == {}
    assert kept_friction(exo, pinid.TermSelection.from_names("fc")) == {"hip": {"fv": 0.8}, "knee": {"fv": 0.6}}
    assert kept_friction(exo, pinid.TermSelection.from_names("none")) == {
        "hip": {"fc": 1.2, "fv": 0.8},
        "knee": {"fc": 0.9, "fv": 0.6},
    }


# ------------------------------------------------------------------ 10: raw exceptions of the Python API
@pytest.mark.parametrize(
    "text, error",
    [
        ("not json", pinid.PinidError),
        ("{}", pinid.DataError),
        ("[1, 2]", pinid.PinidError),
        ('{"standard_names": ["a"], "independent": [0], "P": "x"}', pinid.DataError),
        ('{"standard_names": ["a"], "independent": ["a"], "P": "x", "names": ["a"]}', pinid.DataError),
        ('{"standard_names": ["a"], "independent": ["a"], "P": [[1, 2]], "names": ["a"]}', pinid.DataError),
        ('{"standard_names": ["a"], "independent": ["b"], "P": [[1]], "names": ["a"]}', pinid.DataError),
    ],
)
def test_10_base_parameters_load_raises_pinid_errors_naming_the_file(tmp_path, text, error):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(error) as info:
        pinid.BaseParameters.load(path)
    assert "bad.json" in str(info.value) and "\n" not in str(info.value)
    with pytest.raises(pinid.PinidError):
        pinid.IdentifiedModel.load(path)


def test_10_base_parameters_round_trip_still_loads(exo, tmp_path):
    base = pinid.base_parameters(exo)
    base.save(tmp_path / "base.json")
    again = pinid.BaseParameters.load(tmp_path / "base.json")
    assert again.names == base.names and np.array_equal(again.P, base.P)
    np.testing.assert_array_equal(again.independent, base.independent)


def test_10_floating_robot_model_of_none_is_a_model_error(exo):
    with pytest.raises(pinid.ModelError, match="expected a RobotModel"):
        pinid.FloatingRobotModel(None, None, None)
    with pytest.raises(pinid.ModelError, match="expected a pinocchio.Model"):
        pinid.FloatingRobotModel(exo, None, "base")


# ------------------------------------------------------------------ 11: export overwrites its input
def test_11_export_refuses_its_input_as_output_even_with_force(run_csv, tmp_path):
    out = tmp_path / "r"
    r = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(run_csv), "--methods", "ols", "-o", str(out),
        "--no-progress", "--no-report", "--no-figures",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    model = out / "model_ols.json"
    before = model.read_bytes()
    os.symlink(model, tmp_path / "link.json")
    os.link(model, tmp_path / "hard.json")
    for target in (model, tmp_path / "link.json", tmp_path / "hard.json"):
        r = run_cli("export", "--model", str(model), "-o", str(target), "--force")
        assert r.returncode == 2, r.stderr
        assert "is the input file" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert model.read_bytes() == before
    r = run_cli("export", "--model", str(model), "-o", str(tmp_path / "again.xml"))
    assert r.returncode == 0, r.stderr


def test_check_writable_refuses_an_input_only_when_it_is_the_same_file(tmp_path):
    from pinid.io import check_writable

    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text("{}")
    assert check_writable(b, inputs=(a,)) == b  # another path
    with pytest.raises(pinid.OutputError, match="is the input file"):
        check_writable(a, overwrite=True, inputs=(a,))


# ------------------------------------------------------------------ unclear messages
def test_sigmoid_shape_starting_with_a_minus_reaches_pinid_and_names_the_steepness(run_csv, tmp_path):
    for argv in (["--sigmoid-shape", "-1,0"], ["--sigmoid-shape=-1,0"]):
        r = run_cli(
            "identify", "--urdf", "exo_leg", "--data", str(run_csv), "--terms", "fc,fv,fsig", *argv,
            "--methods", "ols", "-o", str(tmp_path / "r"), "--no-progress", "--no-report",
        )  # fmt: skip
        assert r.returncode == 2 and "expected one argument" not in r.stderr, r.stderr
        assert "steepness φ2 = -1 [s/rad], expected > 0" in r.stderr and "may be negative: 40,-0.01" in r.stderr
    assert not (tmp_path / "r").exists()


def test_negative_values_are_option_values_for_every_command():
    from pinid.cli.main import build_parser

    args = build_parser().parse_args(["identify", "--urdf", "exo_leg", "--data", "x.csv", "--sigmoid-shape", "-1,0"])
    assert args.sigmoid_shape == "-1,0"
    args = build_parser().parse_args(["identify", "--data", "x.csv", "--sigmoid-shape", "-1e-3:2"])
    assert args.sigmoid_shape == "-1e-3:2"
    with pytest.raises(SystemExit):  # an unknown option is still one
        build_parser().parse_args(["identify", "--data", "x.csv", "--sigmoid-shape", "-x"])


@pytest.mark.parametrize(
    "terms, option, term",
    [("fc,fv", ["--ripple-periods", "100"], "ripple"), ("fc,fv", ["--sigmoid-shape", "40,0"], "fsig")],
)
def test_a_term_setting_without_its_term_is_refused(run_csv, tmp_path, terms, option, term):
    r = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(run_csv), "--terms", terms, *option, "--methods", "ols",
        "-o", str(tmp_path / "r"), "--no-progress", "--no-report",
    )  # fmt: skip
    assert r.returncode == 2, r.stderr
    assert f"{option[0]} {option[1]}: --terms {terms} has no {term} term, so it would be ignored" in r.stderr
    r = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(run_csv), "--terms", "auto", "--ripple-periods", "auto",
        "--methods", "ols", "-o", str(tmp_path / "r"), "--no-progress", "--no-report",
    )  # fmt: skip
    assert r.returncode == 2 and "has no ripple term" in r.stderr, r.stderr


def test_ripple_periods_auto_on_a_short_recording_names_the_ripple(tmp_path):
    """0.8 s: fc,fv identify, and some ripple periods are rank-deficient there; before, the choice ended in a rank
    error naming hip.mx.  Now the periods the recording cannot tell apart get no score, and the choice is made
    among the others (or, when none is left, the error names the ripple terms)."""
    from pinid.data.formats import read_recording
    from pinid.data.preprocess import prepare
    from pinid.identification.ripple_choice import choose_ripple_periods

    csv = tmp_path / "short.csv"
    r = run_cli(
        "simulate", "--urdf", "exo_leg", "--excitation", "exo_leg", "--seconds", "0.8", "--seed", "1",
        "-o", str(csv), "--no-progress",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    r = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(csv), "--terms", "fc,fv,ripple", "--ripple-periods", "auto",
        "--methods", "ols", "-o", str(tmp_path / "r"), "--no-progress", "--no-report",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    choice = json.loads((tmp_path / "r" / "identification.json").read_text())["data"]["ripple_periods"]
    scores = choice["cv_rel_rms_percent"]
    assert None in scores and any(s is not None for s in scores)  # some periods refused, the choice among the rest
    assert scores[choice["candidates"].index(choice["periods"])] is not None
    # only rank-deficient periods: the error names the ripple terms and what to do
    exo = pinid.RobotModel.from_urdf("exo_leg").with_setting("ripple_periods", "auto")
    ds = prepare(read_recording(csv))
    terms = pinid.TermSelection.from_names("fc,fv,ripple")
    bad = [c for c, s in zip(choice["candidates"], scores) if s is None]
    with pytest.raises(
        pinid.DataError, match=r"--ripple-periods auto: .*ripple_s1, ripple_c1.*give --ripple-periods R"
    ):
        choose_ripple_periods(exo, [ds], terms, candidates=bad)


def test_wearer_height_in_centimetres_is_suggested():
    from pinid.wearer.anthropometry import check_person

    with pytest.raises(pinid.SpecError, match=r"height 175 m: .*in centimetres\? 175 cm is 1.75 m"):
        check_person(75, 175, "male")
    with pytest.raises(pinid.SpecError, match=r"in millimetres\? 1780 mm is 1.78 m"):
        check_person(75, 1780, "male")
    with pytest.raises(pinid.SpecError) as info:
        check_person(75, 3.0, "male")
    assert "centimetres" not in str(info.value)
    r = run_cli("wearer", "--urdf", "exo_leg", "--mass", "75", "--height", "175", "--sex", "male", "-o", "x.urdf")
    assert r.returncode == 2 and "175 cm is 1.75 m" in r.stderr


def test_simulate_gait_with_an_imu_is_refused_as_identify_would(tmp_path):
    r = run_cli(
        "simulate", "--urdf", "exo_lower_body", "--base", "floating", "--excitation", "gait", "--imu", "pelvis",
        "--seconds", "1", "-o", str(tmp_path / "g.csv"), "--no-progress",
    )  # fmt: skip
    assert r.returncode == 2, r.stderr
    assert "force plates need the base position in the world" in r.stderr
    assert not list(tmp_path.iterdir())


def test_wearer_worse_than_the_tables_is_said():
    from pinid.errors import DataWarning
    from pinid.wearer.stage import warn_if_worse_than_table

    rms = {"identified": {"hip": 5.09, "knee": 1.0}, "table": {"hip": 3.57, "knee": 1.0}, "exo": {"hip": 9, "knee": 9}}
    with pytest.warns(DataWarning, match=r"worse than the anthropometric tables at hip \(5.09 vs 3.57 N·m RMS\)"):
        assert warn_if_worse_than_table(rms) == ["hip"]
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert warn_if_worse_than_table({"identified": {"hip": 3.6}, "table": {"hip": 3.57}}) == []


def test_floating_mjcf_root_body_keeps_the_root_link_name(tmp_path):
    """The root link was counted twice in _unique_body_names: the floating MJCF named its root body "pelvis_1"."""
    from pinid.model.mjcf import identified_mjcf

    for name, root in (("exo_leg", "trunk"), ("exo_lower_body", "pelvis")):
        robot = pinid.RobotModel.from_urdf(name)
        theta = pinid.standard_parameters(robot)
        xml = identified_mjcf(robot, theta, pinid.TermSelection(), floating=True)
        bodies = re.findall(r'<body name="([^"]+)"', xml)
        assert bodies[0] == root and not any(b.endswith("_1") for b in bodies), bodies
        fixed = re.findall(r'<body name="([^"]+)"', identified_mjcf(robot, theta, pinid.TermSelection()))
        assert fixed == bodies


# ------------------------------------------------------------------ docs, as a new user found them
def test_report_html_renders_emphasis_and_spans_that_wrap(leg_identification, tmp_path):
    from pinid.identification.outputs import write_identification
    from pinid.report.html import markdown_to_html

    page = markdown_to_html("a **bold\nwraps** and *em\nwraps*, *From these data*: 2 * 3, a*b*c, `x*y*`")
    body = page.split("<body>")[1]
    assert "<strong>bold wraps</strong>" in body and "<em>em wraps</em>" in body and "<em>From these data</em>" in body
    assert "2 * 3, a*b*c, <code>x*y*</code>" in body
    write_identification(leg_identification, tmp_path, report=True, figures=False)
    text = re.sub(r"<code>.*?</code>|<pre>.*?</pre>", "", (tmp_path / "report.html").read_text(), flags=re.S)
    assert "*" not in text.split("<body>")[1]  # no Markdown asterisk left for a reader to see


def test_no_doc_names_a_missing_page():
    """docs/estimators.md was linked from --option's help (docs/cli.md); every docs/X.md named in the code and in
    the docs exists."""
    root = Path(__file__).resolve().parents[2]
    texts = [p.read_text() for p in [*root.joinpath("pinid").rglob("*.py"), *root.joinpath("docs").glob("*.md")]]
    named = {m for t in texts for m in re.findall(r"docs/([\w.-]+\.md)", t)}
    missing = sorted(n for n in named if not (root / "docs" / n).exists())
    assert not missing, missing


@pytest.mark.parametrize(
    "page, line, needle",
    [
        ("wearer.md", 97, "--excitation exo_leg "),
        ("simulate.md", 151, "--excitation exo_leg "),
        ("simulate.md", 152, "--excitation seed001_table3 "),
        ("metaheuristics.md", 201, "--excitation seed001_table3 "),
    ],
)
def test_doc_commands_name_bundled_files_not_repository_paths(page, line, needle):
    """docs/getting-started.md says every command works in any folder: the bundled names, not excitation/…"""
    root = Path(__file__).resolve().parents[2]
    lines = (root / "docs" / page).read_text().splitlines()
    near = "\n".join(lines[line - 3 : line + 2])
    assert needle in near and "excitation/" not in near, near


def test_bundled_names_of_the_doc_commands_resolve_outside_the_repository(tmp_path):
    from pinid.simulation.trajectories import load_trajectory

    leg = pinid.RobotModel.from_urdf("exo_leg")
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path)
        for name in ("exo_leg", "seed001_table3"):
            assert list(load_trajectory(name, leg).joints) == leg.joint_names
    finally:
        os.chdir(cwd)
