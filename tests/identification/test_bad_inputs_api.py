"""Issue 14 (public API, identify and outputs): wrong inputs to pinid's public functions and commands give a
PinidError subclass (from Python) or one line and exit status 2 (from the CLI), and no file is left or replaced.

The property-style test at the end drives the public API with generated wrong inputs (wrong shapes, NaN,
infinities, lists, strings, None, empty) from a seeded generator and asserts that only PinidError
subclasses come out."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import assert_clean_error, load, run_cli
from pinid import (
    Identification,
    IdentifiedModel,
    TermSelection,
    PinidError,
    base_parameters,
    identify,
    joint_torque,
    parameter_names,
    regressor,
    standard_parameters,
)
from pinid.identification.study import Study
from pinid.data.dataset import Dataset
from pinid.data.preprocess import prepare
from pinid.errors import DataError, SpecError


# ------------------------------------------------------------------ case 8: tampered model JSON


@pytest.fixture(scope="module")
def model_json(tmp_path_factory):
    leg = load("exo_leg")
    path = tmp_path_factory.mktemp("model") / "model_sdp.json"
    IdentifiedModel(leg, None, standard_parameters(leg)).save(path)
    return json.loads(path.read_text())


def _tampered(tmp_path, d, change):
    d = json.loads(json.dumps(d))
    change(d)
    path = tmp_path / "model.json"
    path.write_text(json.dumps(d))
    return path


def _set(key, value):
    def change(d):
        d[key] = value

    return change


def _param(value):
    def change(d):
        d["standard_parameters"]["knee.m"] = value

    return change


@pytest.mark.parametrize(
    "change, fragment",
    [
        (lambda d: d.pop("robot"), "'robot'"),
        (_set("robot", [1, 2]), "'robot' is list"),
        (_set("meta", [1]), "'meta' is list"),
        (lambda d: d["robot"].__setitem__("terms", "fc,fv"), "'terms' is str"),
        (lambda d: d["robot"].pop("terms"), "'terms'"),
        (lambda d: d["robot"].__setitem__("joints", "hip"), "'joints' is str"),
        (_param("abc"), "knee.m is 'abc'"),
        (_param(None), "knee.m is None"),
        (_param(True), "knee.m is True"),
        (_set("standard_parameters", [1.0]), "'standard_parameters' is list"),
        (_set("physically_consistent", "no"), "'physically_consistent' is 'no'"),
    ],
)
def test_tampered_model_json(tmp_path, model_json, change, fragment):
    with pytest.raises(SpecError) as info:
        IdentifiedModel.load(_tampered(tmp_path, model_json, change))
    assert fragment in str(info.value)


def test_model_json_not_an_object(tmp_path):
    path = tmp_path / "m.json"
    path.write_text("[1, 2]")
    with pytest.raises(SpecError, match="expected a JSON object"):
        IdentifiedModel.load(path)
    with pytest.raises(SpecError, match="expected a JSON object"):
        IdentifiedModel.from_dict([1, 2])


def test_identification_json_points_to_identification_load(tmp_path, model_json):
    """Case 26: the message names Identification.load."""
    path = tmp_path / "identification.json"
    path.write_text(json.dumps({"robot": model_json["robot"], "methods": {}}))
    with pytest.raises(SpecError, match=r"Identification\.load"):
        IdentifiedModel.load(path)


# ------------------------------------------------------------------ case 9: consistency checked on load


def test_stored_consistency_flag_not_trusted(tmp_path, model_json):
    """Case 9: a knee mass of −50 with the flag true loads as NOT consistent; a true model stays true."""
    assert IdentifiedModel.from_dict(model_json).physically_consistent
    path = _tampered(tmp_path, model_json, _param(-50.0))
    assert json.loads(path.read_text())["physically_consistent"] is True
    assert not IdentifiedModel.load(path).physically_consistent
    stored_false = _tampered(tmp_path, model_json, _set("physically_consistent", False))
    assert not IdentifiedModel.load(stored_false).physically_consistent


def test_track_refuses_inconsistent_model(tmp_path, model_json):
    """Case 9: track refuses a model with a negative mass (its closed loop errs by 15-25 rad otherwise)."""
    path = _tampered(tmp_path, model_json, _param(-50.0))
    out = tmp_path / "track"
    proc = run_cli("track", "--model", str(path), "--seconds", "3", "-o", str(out))
    assert_clean_error(proc, "not physically consistent")
    assert not out.exists()


# ------------------------------------------------------------------ case 8: the API's named cases


@pytest.fixture(scope="module")
def leg():
    return load("exo_leg")


@pytest.fixture(scope="module")
def identified(leg):
    return IdentifiedModel(leg, None, standard_parameters(leg))


def test_named_api_cases(leg, identified):
    z2 = np.zeros(2)
    cases = {
        "regressor with strings": lambda: regressor(leg, ["a", "b"], z2, z2),
        "joint_torque with a short theta": lambda: joint_torque(leg, z2, z2, z2, np.zeros(3)),
        "rnea(zeros(3))": lambda: leg.rnea(np.zeros(3), z2, z2),
        "with_inertial_parameters(zeros(3))": lambda: leg.with_inertial_parameters(np.zeros(3)),
        "with_inertial_parameters(NaN)": lambda: leg.with_inertial_parameters(np.full(20, np.nan)),
        "tol=-1": lambda: base_parameters(leg, tol=-1),
        "tol=nan": lambda: base_parameters(leg, tol=float("nan")),
        "TermSelection.from_names('foo')": lambda: TermSelection.from_names("foo"),
        "prepare([1, 2, 3])": lambda: prepare([1, 2, 3]),
        "IdentifiedModel.mass_matrix(zeros(3))": lambda: identified.mass_matrix(np.zeros(3)),
        "identify(leg, [ndarray])": lambda: identify(Study(leg, [np.zeros((10, 5))])),
        "configuration(zeros(5))": lambda: leg.configuration(np.zeros(5)),
    }
    cases.update({f"base_parameters(samples={n})": (lambda n=n: base_parameters(leg, samples=n)) for n in range(0, 6)})
    for name, call in cases.items():
        with pytest.raises(PinidError):
            call()
            pytest.fail(f"{name} was accepted")


def test_base_parameters_few_samples_message(leg):
    with pytest.raises(SpecError, match="expected at least 12 samples"):
        base_parameters(leg, samples=5)
    assert base_parameters(leg, samples=12).count == base_parameters(leg).count  # the minimum still works


# ------------------------------------------------------------------ property-style: generated wrong inputs


def _wrong_values(rng: np.random.Generator, nv: int) -> list:
    """Wrong inputs for an argument that expects ``nv`` joint values: shapes, NaN, inf, lists, strings …"""
    bad_len = int(rng.choice([0, 1, nv + 1, nv + 3]))
    nan_at = np.zeros(nv)
    nan_at[int(rng.integers(nv))] = rng.choice([np.nan, np.inf, -np.inf])
    return [
        np.zeros(bad_len),
        rng.normal(size=(bad_len, nv + 1)),
        rng.normal(size=(2, 3, nv)),
        nan_at,
        np.tile(nan_at, (3, 1)),
        ["a"] * nv,
        "q",
        None,
        [],
        {},
        [[1.0] * nv, [1.0]],
        object(),
        b"\x00",
        np.array(["1"] * nv, dtype=object) if rng.random() < 0.5 else [None] * nv,
        np.zeros((0, nv)),
    ]


def _wrong_numbers(rng: np.random.Generator) -> list:
    """Wrong values for a number that must be finite and positive."""
    return [float("nan"), float("inf"), -float("inf"), -1.0, -float(rng.integers(1, 100)), "3", [3], True, b"1"]


def _only_pinid_errors(calls: dict) -> list[str]:
    """Run every call; return the names of those that raised anything but a PinidError (or nothing)."""
    bad = []
    for name, call in calls.items():
        try:
            call()
        except PinidError:
            continue
        except Exception as exc:  # noqa: BLE001 - that is what the test looks for
            bad.append(f"{name}: {type(exc).__name__}: {str(exc).splitlines()[0][:120] if str(exc) else ''}")
        else:
            bad.append(f"{name}: accepted")
    return bad


@pytest.mark.parametrize("seed", range(3))
def test_generated_wrong_inputs_give_pinid_errors(leg, identified, seed):
    rng = np.random.default_rng(seed)
    nv = leg.nv
    good = np.zeros(nv)
    p = len(standard_parameters(leg))
    ds = Dataset(t=np.arange(200) / 100.0, q=np.zeros((200, nv)), joints=leg.joint_names, tau=np.ones((200, nv)))
    calls = {}
    for k, w in enumerate(_wrong_values(rng, nv)):
        calls.update(
            {
                f"regressor q #{k}": lambda w=w: regressor(leg, w, good, good),
                f"regressor ddq #{k}": lambda w=w: regressor(leg, good, good, w),
                f"joint_torque theta #{k}": lambda w=w: joint_torque(leg, good, good, good, w),
                f"rnea dq #{k}": lambda w=w: leg.rnea(good, w, good),
                f"configuration #{k}": lambda w=w: leg.configuration(w),
                f"with_inertial_parameters #{k}": lambda w=w: leg.with_inertial_parameters(w),
                f"with_inertial_parameters coulomb #{k}": lambda w=w: leg.with_inertial_parameters(
                    leg.inertial_parameters(), coulomb=w if w is not None else "x"
                ),
                f"from_standard #{k}": lambda w=w: base_parameters(leg).from_standard(w),
                f"TermSelection.from_names #{k}": lambda w=w: (
                    TermSelection.from_names(w) if not (isinstance(w, list) and not w) else TermSelection.from_names(3)
                ),
                f"prepare #{k}": lambda w=w: prepare(w),
                f"identify #{k}": lambda w=w: (
                    identify(Study(leg, [w])) if not isinstance(w, str) else identify(Study(leg, [3]))
                ),
                f"IdentifiedModel(theta) #{k}": lambda w=w: IdentifiedModel(leg, None, w),
                f"mass_matrix #{k}": lambda w=w: identified.mass_matrix(w),
                f"gravity #{k}": lambda w=w: identified.gravity(w),
                f"coriolis dq #{k}": lambda w=w: identified.coriolis(good, w),
                f"inverse_dynamics ddq #{k}": lambda w=w: identified.inverse_dynamics(good, good, w),
                f"forward_dynamics tau #{k}": lambda w=w: identified.forward_dynamics(good, good, w),
                f"friction #{k}": lambda w=w: identified.friction(w),
            }
        )
        holds_nan = isinstance(w, np.ndarray) and w.dtype.kind == "f" and not np.all(np.isfinite(w))
        if not holds_nan:  # a Dataset holds NaN as given (the readers and check_dataset refuse them)
            calls[f"Dataset q #{k}"] = lambda w=w: Dataset(t=np.arange(3.0), q=w, joints=leg.joint_names)
    for k, s in enumerate(_wrong_numbers(rng)):
        calls.update(
            {
                f"base_parameters tol #{k}": lambda s=s: base_parameters(leg, tol=s),
                f"prepare cutoff #{k}": lambda s=s: prepare(ds, {"cutoff": s}),
                f"prepare trim #{k}": lambda s=s: prepare(ds, {"trim": s}),
            }
        )
    for k, s in enumerate(_wrong_numbers(rng) + [2.5]):  # counts
        calls.update(
            {
                f"base_parameters samples #{k}": lambda s=s: base_parameters(leg, samples=s),
                f"base_parameters seed #{k}": lambda s=s: base_parameters(leg, seed=s),
                f"random_states n #{k}": lambda s=s: leg.random_states(s, rng),
            }
        )
    for k, w in enumerate(["exo_leg", None, 3, [leg], {"model": leg}]):  # not a RobotModel
        calls.update(
            {
                f"regressor model #{k}": lambda w=w: regressor(w, good, good, good),
                f"parameter_names model #{k}": lambda w=w: parameter_names(w),
                f"base_parameters model #{k}": lambda w=w: base_parameters(w),
                f"IdentifiedModel model #{k}": lambda w=w: IdentifiedModel(w, None, np.zeros(p)),
            }
        )
    for k, w in enumerate([3, 2.5, {"fc": 1}, object(), ["fc", 3], "foo", ("fc", "nope")]):  # not joint terms
        calls.update(
            {
                f"regressor terms #{k}": lambda w=w: regressor(leg, good, good, good, w),
                f"standard_parameters terms #{k}": lambda w=w: standard_parameters(leg, w),
                f"identify terms #{k}": lambda w=w: identify(Study(leg, "missing.csv", terms=w)),
            }
        )
    for k, w in enumerate([3, object(), [3], "nope", ""]):
        calls[f"identify methods #{k}"] = lambda w=w: identify(Study(leg, "missing.csv"), methods=w)
    for k, w in enumerate([[1], "ols", {"ols": 3}, {"ols": [1]}, 3]):
        calls[f"identify options #{k}"] = lambda w=w: identify(Study(leg, "missing.csv"), methods="ols", options=w)
    for k, w in enumerate([3, None, 2.5, ["a.json"], b"\x00", "missing.json"]):
        calls[f"IdentifiedModel.load #{k}"] = lambda w=w: IdentifiedModel.load(w)
        calls[f"Identification.load #{k}"] = lambda w=w: Identification.load(w)
        calls[f"RobotModel.from_urdf #{k}"] = lambda w=w: type(leg).from_urdf(w)
    for _ in range(5):  # random wrong sizes
        n = int(rng.integers(1, 3 * p))
        if n != p:
            calls[f"joint_torque theta size {n}"] = lambda n=n: joint_torque(leg, good, good, good, np.ones(n))
    assert len(calls) > 250
    bad = _only_pinid_errors(calls)
    assert not bad, "\n".join(bad)


# ------------------------------------------------------------------ the CLI: numbers, options, outputs


@pytest.mark.parametrize(
    "argv",
    [
        ["flex", "twin", "-o", "t.csv", "--seed", "-1"],
        ["flex", "fit", "-o", "f.json", "--seed", "-1"],
        ["flex", "compare", "-o", "c.json", "--seed", "-1"],
    ],
)
def test_flex_seed_checked_at_parse(tmp_path, argv):
    """Case 5: --seed -1 on every command, flex included."""
    assert_clean_error(run_cli(*argv, cwd=tmp_path), "--seed")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("value", ["abc", "nan", "inf", "true"])
def test_excite_option_value_checked(tmp_path, value):
    """Case 6: --option w_min=abc|nan is one line naming the option, before any work."""
    proc = run_cli(
        "excite", "--urdf", "exo_leg", "--optimizer", "pso", "--option", f"w_min={value}", "-o", "e.json", cwd=tmp_path
    )
    assert_clean_error(proc, "w_min")
    assert list(tmp_path.iterdir()) == []


def test_excite_unknown_option_names_only_unknown(tmp_path):
    """Case 20: --starts 2 --option foo=bar names foo as unknown, not starts."""
    proc = run_cli("excite", "--urdf", "exo_leg", "--starts", "2", "--option", "foo=bar", "-o", "e.json", cwd=tmp_path)
    assert_clean_error(proc, "unknown option(s) foo (")
    assert "starts, foo" not in proc.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "extra",
    [["--optimizer", "pso"], ["--optimizer", "slsqp"], ["--starts", "3"], ["--seed", "2"], ["--option", "polish=1"]],
)
def test_excite_evaluate_refuses_optimizer_options(tmp_path, extra):
    """Case 25: an optimiser option has no effect with --evaluate: refused, not silently ignored."""
    from pinid.resources import EXCITATION_DIR

    traj = EXCITATION_DIR / "seed001_table3.json"
    proc = run_cli("excite", "--urdf", "exo_leg", "--evaluate", str(traj), *extra, cwd=tmp_path)
    assert_clean_error(proc, extra[0], "no effect with --evaluate")


def test_estimator_settings_checked_when_made(tmp_path):
    """Case 6: a bad setting is a SpecError naming it when the estimator is made, before any data is read."""
    from pinid.estimators import make_estimator

    for method, setting in (
        ("wls", {"iterations": 0}),
        ("wls", {"iterations": -1}),
        ("sdp", {"regularization": -1}),
        ("sdp", {"regularization": float("nan")}),
        ("pso", {"population": "many"}),
    ):
        key = next(iter(setting))
        with pytest.raises(SpecError, match=f"setting {key}="):
            make_estimator(method, **setting)
        with pytest.raises(SpecError, match=f"setting {key}="):  # identify: before the (missing) recording
            identify(Study(load("exo_leg"), tmp_path / "missing.csv"), methods=method, options={method: setting})


def test_duplicate_training_data_refused(tmp_path, recording):
    """Case 14: --data X --data X is an error (the std would shrink by √2 without a word)."""
    out = tmp_path / "run"
    proc = run_cli("identify", "--urdf", "exo_leg", "--data", str(recording), "--data", str(recording), "-o", str(out))
    assert_clean_error(proc, "given twice as training data")
    assert not out.exists()
    with pytest.raises(DataError, match="given twice"):  # the same through another spelling of the path
        identify(Study(load("exo_leg"), [recording, recording.parent / "." / recording.name]))


def test_validation_equal_to_training_warns(recording):
    """Case 14: --validate equal to a --data file: a clear warning (its error is a training error)."""
    from pinid.errors import DataWarning
    from pinid.identification.run import check_distinct

    with pytest.warns(DataWarning, match="also a training recording"):
        check_distinct([recording], [str(recording)])
    with pytest.warns(DataWarning, match="also a training recording"):
        check_distinct([recording], {"validation": [recording]})


def test_validation_equal_to_training_warns_in_one_line(tmp_path, recording):
    """Case 14 through the CLI: the run goes on, the warning is one line naming the file."""
    proc = run_cli(
        "identify",
        "--urdf",
        "exo_leg",
        "--data",
        str(recording),
        "--validate",
        str(recording),
        "--methods",
        "ols",
        "--no-report",
        "-o",
        str(tmp_path / "run"),
    )
    assert proc.returncode == 0, proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if "also a training recording" in ln]
    assert len(lines) == 1 and lines[0].startswith("pinid identify: warning: ") and recording.name in lines[0]


def test_zero_torques_refused(tmp_path, recording):
    """Case 11: a recording without torque signal is refused, nothing is written."""
    text = recording.read_text().splitlines()
    zero = [text[0]] + [",".join(line.split(",")[:3] + ["0", "0"]) for line in text[1:]]
    path = tmp_path / "zero.csv"
    path.write_text("\n".join(zero) + "\n")
    out = tmp_path / "run"
    proc = run_cli("identify", "--urdf", "exo_leg", "--data", str(path), "--methods", "ols", "-o", str(out))
    assert_clean_error(proc, "zero.csv", "no torque signal")
    assert not out.exists()


def test_export_refuses_urdf_pinid_cannot_read(leg):
    """Case 11: a parameter set that passes the consistency tolerance but gives a URDF pinid refuses
    (mass −1e-12 kg) is not exported."""
    from pinid.errors import ModelError
    from pinid.model.export import identified_urdf
    from pinid.model.physical import check_consistency

    theta = standard_parameters(leg).copy()
    theta[10:20] = [-1e-12, 0, 0, 0, 0.01, 0, 0.01, 0, 0, 0.01]  # knee mass −1e-12 kg as OLS gave on zero torques
    assert check_consistency(theta, leg.joint_names, ["fc", "fv"]).consistent  # within the tolerance
    with pytest.raises(ModelError, match="would not load back"):
        identified_urdf(leg, theta, TermSelection())


def _flex_spec(tmp_path, f_max: str):
    from pinid.model.bundled import BUNDLED_URDF_DIR

    src = BUNDLED_URDF_DIR.parent / "excitation" / "tracker_flex_spec.toml"
    text = src.read_text().replace("f_max = 12.0", f"f_max = {f_max}")
    assert f"f_max = {f_max}" in text
    path = tmp_path / "spec.toml"
    path.write_text(text.replace('urdf = "', f'urdf = "{src.parent}/') if 'urdf = "../' in text else text)
    return path


def test_flex_f_max_above_nyquist_refused(tmp_path):
    """Case 25: f_max at or above half the input rate (500 Hz) is refused."""
    for f_max in ("1e9", "250.0"):
        spec = _flex_spec(tmp_path, f_max)
        proc = run_cli("flex", "check", "--spec", str(spec), cwd=tmp_path)
        assert_clean_error(proc, "f_max", "Nyquist")


@pytest.mark.parametrize(
    "argv, folder",
    [
        (["simulate", "--urdf", "exo_leg", "--excitation", "missing.json", "-o", "new/run.csv"], "new"),
        (["compare", "--urdf", "exo_leg", "--data", "missing.csv", "-o", "new"], "new"),
        (["track", "--model", "missing.json", "-o", "new"], "new"),
        (
            ["wearer", "--urdf", "exo_leg", "--mass", "10", "--height", "1.8", "--sex", "male", "-o", "new/w.urdf"],
            "new",
        ),
        (["flex", "twin", "--spec", "missing.toml", "-o", "new/t.csv"], "new"),
        (["flex", "fit", "--spec", "missing.toml", "-o", "new/f.json"], "new"),
        (["flex", "compare", "--spec", "missing.toml", "-o", "new/c.json"], "new"),
        (["flex", "check", "--spec", "missing.toml", "--json", "new/c.json"], "new"),
    ],
)
def test_failed_runs_leave_no_folder(tmp_path, argv, folder):
    """Case 24: a failed run of any command that writes leaves no (empty) output folder."""
    proc = run_cli(*argv, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert not (tmp_path / folder).exists()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "--urdf", "exo_leg", "--excitation", "zha2019-1", "-o", "x.csv", "--truth", "x.csv"],
        ["simulate", "--urdf", "exo_leg", "--excitation", "zha2019-1", "-o", "x.csv", "--true-signals", "./x.csv"],
        ["flex", "fit", "-o", "x.png", "--plot", "x.png"],
        ["flex", "compare", "-o", "x.png", "--plot", "x.png"],
    ],
)
def test_outputs_on_one_path_refused(tmp_path, argv):
    """Case 18 for the other commands: two outputs on one path are refused before the work."""
    assert_clean_error(run_cli(*argv, cwd=tmp_path), "same file")
    assert list(tmp_path.iterdir()) == []


def test_flex_output_option_and_out_alias(tmp_path):
    """flex uses -o/--output like every command; --out still works; the recording and its truth are one set."""
    for flag, name in (("-o", "a.csv"), ("--output", "b.csv"), ("--out", "c.csv")):
        proc = run_cli("flex", "twin", flag, name, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        assert (tmp_path / name).is_file() and (tmp_path / f"{name}.json").is_file()
    before = (tmp_path / "a.csv.json").read_bytes()
    (tmp_path / "a.csv").unlink()  # the truth alone is in the way: refused, kept
    assert_clean_error(run_cli("flex", "twin", "-o", "a.csv", cwd=tmp_path), "already exists")
    assert not (tmp_path / "a.csv").exists() and (tmp_path / "a.csv.json").read_bytes() == before


@pytest.mark.slow
def test_demo_interrupted_leaves_nothing(tmp_path):
    """Cases 5 and 17: Ctrl-C during the demo's second step leaves no excitation file, no folder."""
    import os
    import signal
    import subprocess
    import sys

    out = tmp_path / "demo"
    proc = subprocess.Popen(
        # --no-progress: under load a step can outlast the 5 s between progress lines, and those lines on
        # stderr are not what this test is about (it checks the one "interrupted" line exactly)
        [sys.executable, "-m", "pinid.cli", "demo", "-o", str(out), "--methods", "ols", "--no-progress"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    for line in proc.stdout:
        if line.startswith("[2/5]"):
            break
    assert (out / "excitation.json").is_file()  # the first step's outputs exist now
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 2, err
    assert "interrupted" in err and len(err.strip().splitlines()) == 1, err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_demo_force_failure_restores_earlier_run(tmp_path):
    """The demo's folder is all or nothing: a --force run stopped by Ctrl-C puts the earlier files back."""
    import os
    import signal
    import subprocess
    import sys

    out = tmp_path / "demo"
    out.mkdir()
    (out / "excitation.json").write_text("earlier run")
    (out / "notes.txt").write_text("mine")
    proc = subprocess.Popen(
        [sys.executable, "-m", "pinid.cli", "demo", "-o", str(out), "--methods", "ols", "--force", "--no-progress"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    for line in proc.stdout:
        if line.startswith("[2/5]"):
            break
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=120)
    assert proc.returncode == 2
    assert sorted(p.name for p in out.iterdir()) == ["excitation.json", "notes.txt"]
    assert (out / "excitation.json").read_text() == "earlier run"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo"]  # no staging folder left


def test_tampered_identification_json(tmp_path, model_json):
    """Identification.load on a tampered file: a SpecError naming the file, never a bare KeyError/TypeError."""
    from pinid import Identification

    path = tmp_path / "identification.json"
    for methods in (
        {"ols": {"method": "ols"}},
        {"ols": {"method": "ols", "physically_consistent": True}},
        {"ols": {"physically_consistent": True, "base_parameters": {"a": "abc"}}},
        [1],
        "x",
        {},
    ):
        path.write_text(json.dumps({"robot": model_json["robot"], "methods": methods}))
        with pytest.raises(SpecError, match="identification.json"):
            Identification.load(path)
    with pytest.raises(SpecError, match="not a valid identification"):
        Identification.from_dict({"robot": model_json["robot"], "methods": {"ols": 3}})


def _round4_cases():
    """Issue 33 (12): public calls that raised raw numpy/Python errors (or took a short vector silently)."""
    from pinid import RobotModel, TermSelection, standard_parameters
    from pinid.data import preprocess as pp
    from pinid.model import mjcf
    from pinid.model import terms as tm
    from pinid.model.base import base_parameters_of
    from pinid.model.regressor import parameter_names, regressor
    from pinid.simulation import plant_checks, twin

    leg, terms = RobotModel.from_urdf("exo_leg"), TermSelection(coulomb=True, viscous=True)
    th = standard_parameters(leg, terms)
    rng = np.random.default_rng(0)
    q = np.column_stack([rng.uniform(0, 1, 50), rng.uniform(-1.5, -0.2, 50)])
    dq = rng.normal(size=(50, 2))
    W, names = regressor(leg, q, dq, dq, terms), parameter_names(leg, terms)
    return {
        "q: shape (50, 3), expected (N, 2)": lambda: tm.columns(leg, terms, np.hstack([q, q[:, :1]]), dq, dq),
        "dq: shape (49, 2), expected (N, 2)": lambda: tm.columns(leg, terms, q, dq[:-1], dq),
        "dq: shape (50, 2), expected (N, 2) for joints ['hip', 'knee'], the shape of q (49, 2)": lambda: tm.torque(
            leg, terms, th[20:], q[:-1], dq, dq
        ),
        "theta_terms: shape (3,), expected (4,) values of the terms": lambda: tm.values(leg, terms, th[20:23]),
        "theta_terms: shape (), expected (4,)": lambda: tm.values(leg, terms, np.float64(1.0)),
        "theta: shape (0,), expected (24,) standard parameters": lambda: mjcf.joint_fields(leg, np.zeros(0), terms),
        "theta: shape (), expected (24,)": lambda: mjcf.joint_fields(leg, np.float64(1.0), terms),
        "fs=0.0, expected a finite number > 0": lambda: pp.lowpass(q, 0.0, 5.0),
        "cutoff=-1.0, expected a finite number > 0": lambda: pp.lowpass(q, 100.0, -1.0),
        "cutoff=60 Hz, expected below the Nyquist frequency": lambda: pp.lowpass(q, 100.0, 60.0),
        "x: 0 samples, expected more than 15 to filter": lambda: pp.lowpass(np.zeros((0, 2)), 100.0, 5.0),
        "cutoff=0.0, expected a finite number > 0": lambda: pp.default_trim(100.0, 0.0, 4),
        "order=0, expected an integer ≥ 1": lambda: pp.default_trim(100.0, 5.0, 0),
        "cutoff=nan, expected a finite number": lambda: pp.savgol_half_window(100.0, float("nan")),
        "coulomb: shape (3,), expected (2,) per joint": lambda: twin.friction_torque(dq, np.ones(3), np.ones(2)),
        "t: shape (), rms: shape (2,)": lambda: twin.wearer_disturbance(np.float64(1.0), np.ones(2), rng),
        "q has 49 samples and q_desired 50": lambda: plant_checks.check_tracking(leg, q[:-1], q),
        "W: shape (100, 24), expected (rows, 23)": lambda: base_parameters_of(W, names[:-1]),
        "W: shape (24, 100), expected (rows, 24)": lambda: base_parameters_of(W.T, names),
    }


def test_round4_api_calls_raise_one_line_pinid_errors():
    from pinid.errors import PinidError

    for fragment, call in _round4_cases().items():
        with pytest.raises(PinidError) as info:
            call()
        assert fragment in str(info.value) and "\n" not in str(info.value), (fragment, str(info.value))
