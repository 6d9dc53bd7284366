"""`pinid compare` and pinid.identification.compare: the same data for every method, several seeds, honest measures."""

from __future__ import annotations

import json

import numpy as np
import pytest

from pinid.identification.compare import DETERMINISTIC, Comparison, compare, lad
from pinid.identification.study import Study
from pinid.errors import SpecError
from pinid.estimators.metaheuristic import training_costs
from pinid.problem.problem import IdentificationProblem
from pinid.model.regressor import standard_parameters
from pinid.model.terms import TermSelection
from pinid.simulation.cad import perturb

from conftest import assert_clean_error, run_cli
from test_identification import true_base, truth_model, twin
from test_segmental import hip_fixed

SMALL = {"population": 20, "iterations": 25}


@pytest.fixture(scope="module")
def setting():
    truth = truth_model("exo_leg")
    cad = perturb(truth, 20, np.random.default_rng(3))  # the nominal model: not the truth
    train = twin(truth, seconds=20, rate=100, seed=1, noise=0.5)
    valid = twin(truth, seconds=10, rate=100, seed=2, noise=0.5)
    return truth, cad, train, valid


@pytest.fixture(scope="module")
def comparison(setting):
    truth, cad, train, valid = setting
    _, xt = true_base(truth)
    return compare(
        Study(cad, train, valid),
        methods=["ols", "sdp", "rls", "pso", "rls-pso", "woa", "ewoa", "de"],
        seeds=2,
        truth=xt,
        metaheuristic=SMALL,
    )


def test_runs_deterministic_methods_once_and_metaheuristics_per_seed(comparison):
    assert comparison.seeds == [0, 1]
    for m, runs in comparison.runs.items():
        if m in DETERMINISTIC:
            assert [r.seed for r in runs] == [None]
        else:
            assert [r.seed for r in runs] == [0, 1]
            assert not np.array_equal(runs[0].base, runs[1].base)
            assert len(runs[0].history) == SMALL["iterations"] + 1
    s = comparison.summary()
    assert s["pso"]["runs"] == 2 and s["ols"]["seconds"][1] == 0.0


def test_least_squares_wins_the_training_cost_it_minimises(comparison):
    ref = comparison.reference["main"]
    ols = comparison.runs["ols"][0].costs["sse"]
    assert ols == pytest.approx(ref["sse"], rel=1e-9)
    for m, runs in comparison.runs.items():
        for r in runs:
            assert r.costs["sse"] >= ref["sse"] * (1 - 1e-9), m
            assert r.costs["sae"] >= ref["sae"] * (1 - 1e-9), m  # nothing below the LAD minimum either


def test_validation_truth_errors_and_tables(comparison, setting):
    truth, *_ = setting
    r = comparison.runs["ols"][0]
    assert set(r.validation) == {"validation"}
    v = r.validation["validation"]
    assert set(v["per_joint"]) == {"hip", "knee"} and v["all"]["mean_abs"] > 0
    assert set(r.parameter_error) == set(comparison.base_names)
    assert max(r.parameter_error.values()) < 50  # LS on a well-excited twin
    np.testing.assert_allclose(comparison.truth, true_base(truth)[1])
    assert not np.allclose(comparison.nominal, comparison.truth)  # the box is built around the CAD model
    table = comparison.table()
    for m in comparison.runs:
        assert f"\n{m} " in table
    assert "above min %" in table and "max err % (truth≠0)" in table and "(truth=0)" not in table
    values = comparison.values_table()
    assert "truth" in values and "hip.mzR" in values
    assert max(len(line) for line in (table + "\n" + values).splitlines()) <= 120


def test_zero_truth_gets_an_absolute_error(setting):
    """A relative error where the truth is 0 is meaningless (it was 7.77e+03 % there): such a parameter gets
    the absolute error |x| instead, in its own column, and the relative columns leave it out."""
    truth, cad, train, valid = setting
    _, xt = true_base(truth)
    xt = xt.copy()
    xt[0] = 0.0
    comp = compare(Study(cad, train, valid), methods=["ols"], seeds=1, truth=xt)
    r = comp.runs["ols"][0]
    name = comp.base_names[0]
    assert comp.zero_truth() == [name] and name not in r.parameter_error
    assert r.parameter_error_abs[name] == pytest.approx(abs(r.base[0]))
    assert max(r.parameter_error.values()) < 50
    s = comp.summary()["ols"]
    assert s["parameter_error_abs_max_zero_truth"][0] == pytest.approx(abs(r.base[0]))
    table = comp.table()
    assert "max |err| (truth=0)" in table and f"({name})" in table
    assert max(len(line) for line in table.splitlines()) <= 120
    again = Comparison.from_dict(json.loads(json.dumps(comp.to_dict())))
    assert again.runs["ols"][0].parameter_error_abs == r.parameter_error_abs


def test_save_load_roundtrip(comparison, tmp_path):
    path = comparison.save(tmp_path / "c.json")
    back = Comparison.load(path)
    assert back.to_dict() == comparison.to_dict()
    assert back.table() == comparison.table()
    d = json.loads(path.read_text())
    assert d["summary"]["pso"]["runs"] == 2 and "urdf_text" in d["robot"]
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(SpecError, match="not a comparison file"):
        Comparison.load(tmp_path / "bad.json")


def test_figures(comparison):
    from pinid.report.plot_compare import comparison_figures

    figs = comparison_figures(comparison)
    assert set(figs) == {"compare_convergence.png", "compare_errors_validation.png", "compare_parameters.png"}
    import matplotlib.pyplot as plt

    for f in figs.values():
        plt.close(f)


def test_lad_is_the_minimum_of_the_absolute_error(setting):
    truth, cad, train, _ = setting
    p = IdentificationProblem.from_datasets(cad, train)
    x = lad(p)
    best = training_costs(p, x)["sae"]
    rng = np.random.default_rng(0)
    for _ in range(20):
        assert training_costs(p, x + rng.normal(size=x.size) * 1e-3 * np.abs(x))["sae"] >= best


def test_segmental_comparison_and_truth_from_a_truth_dict(setting):
    truth, cad, train, valid = setting
    bp, xt = true_base(truth)
    c = compare(
        Study(
            cad,
            train,
            {"both": valid, "knee only": hip_fixed(truth, seed=4)},
            segmental={"first": hip_fixed(truth, seed=3, noise=0.2)},
        ),
        methods=["ols", "sdp", "pso"],
        seeds=[7],
        truth={"base": {"names": bp.names, "values": xt.tolist()}},
        metaheuristic=SMALL,
    )
    assert c.segmental["first_joints"] == ["knee"] and set(c.validation_sources) == {"both", "knee only"}
    assert c.runs["pso"][0].seed == 7 and c.runs["pso"][0].history_first
    assert c.runs["sdp"][0].physically_consistent
    assert "first" in c.reference
    from pinid.report.plot_compare import comparison_figures

    assert "compare_convergence_first.png" in comparison_figures(c)


def test_errors(setting):
    truth, cad, train, valid = setting
    with pytest.raises(SpecError, match="unknown method"):
        compare(Study(cad, train), methods="ols,magic")
    with pytest.raises(SpecError, match="not run"):
        compare(Study(cad, train), methods="ols", options={"pso": {}})
    with pytest.raises(SpecError, match="truth"):
        compare(Study(cad, train), methods="ols", truth=[1.0, 2.0])
    with pytest.raises(SpecError, match="seeds"):
        compare(Study(cad, train), methods="pso", seeds=[])


@pytest.mark.slow
def test_cli_compare(tmp_path, setting):
    from pinid.data.formats import write_recording

    truth, cad, train, valid = setting
    write_recording(tmp_path / "train.csv", train)
    write_recording(tmp_path / "valid.csv", valid)
    out = tmp_path / "out"
    head = ("compare", "--urdf", "exo_leg", "--data", str(tmp_path / "train.csv"))
    proc = run_cli(
        *head,
        "--validate",
        str(tmp_path / "valid.csv"),
        "--methods",
        "ols,pso,ewoa",
        "--seeds",
        "2",
        "--population",
        "15",
        "--iterations",
        "10",
        "--fitness",
        "sae",
        "-o",
        str(out),
        "--preprocess",
        "never",
    )
    assert proc.returncode == 0, proc.stderr
    assert "above min %" in proc.stdout
    d = json.loads((out / "comparison.json").read_text())
    assert d["methods"] == ["ols", "pso", "ewoa"] and len(d["runs"]["pso"]) == 2
    assert d["runs"]["pso"][0]["info"]["fitness"] == "sae"
    for name in ("comparison.md", "compare_convergence.png", "compare_errors_validation.png"):
        assert (out / name).is_file(), name
    proc = run_cli(
        *head,
        "--methods",
        "ols,magic",
        "-o",
        str(tmp_path / "o2"),
    )
    assert_clean_error(proc, "magic")
    proc = run_cli(
        *head,
        "--first-validate",
        str(tmp_path / "valid.csv"),
        "-o",
        str(tmp_path / "o3"),
    )
    assert_clean_error(proc, "--first-data")
    assert not (tmp_path / "o2").exists() or not any((tmp_path / "o2").iterdir())


@pytest.mark.slow
def test_cli_compare_does_not_replace_files_without_force(tmp_path, setting):
    from pinid.data.formats import write_recording

    truth, cad, train, valid = setting
    write_recording(tmp_path / "train.csv", train)
    out = tmp_path / "out"
    out.mkdir()
    (out / "compare_convergence.png").write_text("old")
    args = [
        "compare",
        "--urdf",
        "exo_leg",
        "--data",
        str(tmp_path / "train.csv"),
        "--methods",
        "ols,pso",
        "--seeds",
        "1",
        "--population",
        "10",
        "--iterations",
        "5",
        "-o",
        str(out),
    ]
    proc = run_cli(*args)
    assert_clean_error(proc, "compare_convergence.png", "--force")
    assert sorted(p.name for p in out.iterdir()) == ["compare_convergence.png"]
    proc = run_cli(*args, "--force")
    assert proc.returncode == 0, proc.stderr
    assert (out / "comparison.json").is_file() and (out / "compare_convergence.png").read_bytes()[:4] == b"\x89PNG"


def test_box_choice_leaves_rls_pso_in_its_rls_box_and_keeps_forgetting(setting):
    """--box applies to pso/woa/ewoa/de only; the RLS settings reach an RLS box whoever asks for it."""
    truth, cad, train, valid = setting
    c = compare(
        Study(cad, train),
        methods=["pso", "rls-pso"],
        seeds=1,
        metaheuristic={**SMALL, "box": "ls", "rls": {"forgetting": 0.999}},
    )
    assert c.runs["pso"][0].info["box"]["kind"] == "ls"
    assert c.runs["rls-pso"][0].info["box"]["kind"] == "rls"
    assert c.runs["rls-pso"][0].info["box"]["rls"]["forgetting"] == 0.999
    c = compare(
        Study(cad, train), methods=["pso"], seeds=1, metaheuristic={**SMALL, "box": "rls", "rls": {"forgetting": 0.99}}
    )
    assert c.runs["pso"][0].info["box"]["rls"]["forgetting"] == 0.99


def test_bad_truth_file_and_rest_velocity_are_clean_errors(tmp_path, setting):
    truth, cad, train, valid = setting
    bad = tmp_path / "truth.json"
    bad.write_text(json.dumps({"base": {"values": [1.0]}}))
    with pytest.raises(SpecError, match="names"):
        compare(Study(cad, train), methods="ols", truth=str(bad))
    with pytest.raises(SpecError, match="one per joint"):
        compare(Study(cad, train, rest_velocity=[0.1, 0.2, 0.3]), methods="ols")


def test_a_truth_of_other_joint_terms_is_mapped_through_the_runs_base_map(setting):
    """A truth JSON of ``pinid simulate`` (fc, fv) compared with the terms fc, fv, armature: the truth's own
    base names lack knee.armature, so its standard parameters go through the run's base map (armature was
    not simulated: truly 0), as ``pinid identify --truth`` does — it used to be refused."""
    truth, cad, train, valid = setting
    bp, xt = true_base(truth)
    doc = {
        "joints": truth.joint_names,
        "terms": ["fc", "fv"],
        "standard": {"names": bp.standard_names, "values": standard_parameters(truth, TermSelection()).tolist()},
        "base": {"names": bp.names, "values": xt.tolist()},
    }
    c = compare(Study(cad, train, valid, terms="fc,fv,armature"), methods=["ols"], seeds=1, truth=doc)
    expected = dict(zip(bp.names, xt))
    got = dict(zip(c.base_names, c.truth))
    assert set(got) - set(expected) == {"knee.armature"} and got["knee.armature"] == 0.0
    for name in expected:
        np.testing.assert_allclose(got[name], expected[name], rtol=1e-9, atol=1e-12)


def test_fit_joints_validation_is_the_one_identify_reports():
    """Issue 33 (16): with --fit-joints knee the hip is predicted through the completed standard set, as
    identify does (before: from the fitted base parameters alone, hip RMS 11.6 N·m against 0.476)."""
    from pinid.identification.run import identify

    m = truth_model("exo_leg")
    train, valid = twin(m, seconds=12, rate=200, seed=1, noise=0.05), twin(m, seconds=6, rate=200, seed=2)
    ident = identify(Study(m, train, validate=valid, fit_joints="knee"), methods="ols")["ols"].validation
    got = (
        compare(Study(m, train, valid, fit_joints="knee"), methods=["ols"], seeds=1)
        .runs["ols"][0]
        .validation["validation"]
    )
    for j in ("hip", "knee"):
        assert got["per_joint"][j]["rms"] == pytest.approx(ident.per_joint[j]["rms"], rel=1e-9)
