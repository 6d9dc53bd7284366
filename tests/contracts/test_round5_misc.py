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
