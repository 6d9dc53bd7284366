"""Every public function of docs/api.md refuses wrong argument types with a PinidError naming the argument
(seeded draws), and the named cases of issue 25 item 23."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import load

from pinid.data.dataset import Dataset
from pinid.data.formats import read_recording, write_recording
from pinid.errors import DataError, ModelError, SpecError
from pinid.identification.study import Study


def test_named_api_cases(tmp_path, recording):
    from pinid import RobotModel, identify
    from pinid.excitation.evaluation import condition_number
    from pinid.identification.gains import Payload
    from pinid.simulation.trajectories import zha2019_trajectory
    from pinid.simulation.twin import simulate
    from pinid.wearer.anthropometry import segment

    leg = load("exo_leg")
    ds = read_recording(recording)
    traj = zha2019_trajectory(1)
    loaded = Dataset(ds.t, ds.q, ds.joints, tau=2 * ds.tau)
    cases = [
        (lambda: segment("thigh", mass="75", height=1.78, sex="male"), SpecError, "mass='75'"),
        (lambda: Payload.from_dict(None), SpecError, "got NoneType"),
        (
            lambda: identify(
                Study(leg, ds, payload={"mass": 2.5, "com": [1e6, 0, 0]}, payload_data=loaded), methods="ols"
            ),
            SpecError,
            "com",
        ),
        (
            lambda: identify(Study(leg, ds, payload=3, payload_data=loaded), methods="ols"),
            SpecError,
            "payload: got int",
        ),
        (
            lambda: identify(Study(leg, ds, preprocess={"cutof": 5}), methods="ols"),
            SpecError,
            "unknown option(s) ['cutof']",
        ),
        (lambda: identify(Study(leg, ds, preprocess=[5]), methods="ols"), SpecError, "preprocess: got list"),
        (lambda: condition_number(leg, traj, samples=0), SpecError, "samples=0"),
        (lambda: condition_number(leg, "traj"), SpecError, "trajectory: got str"),
        (lambda: simulate(leg, traj, seconds=1, seed=-1), SpecError, "seed=-1"),
        (lambda: simulate(leg, traj, seconds=1, seed=1.5), SpecError, "seed=1.5"),
        (lambda: simulate(leg, traj, seconds="1"), SpecError, "seconds='1'"),
        (lambda: write_recording(tmp_path / "x.csv", ds, digits=0), SpecError, "digits=0"),
        (lambda: write_recording(tmp_path / "x.csv", ds, digits=2.5), SpecError, "digits=2.5"),
        (lambda: write_recording(None, ds), DataError, "path: got NoneType"),
        (lambda: Dataset(ds.t, ds.q, ["hip", "hip"]), DataError, "'hip' appears twice"),
        (lambda: Dataset(ds.t, ds.q, 3), DataError, "expected a list of joint names"),
        (lambda: read_recording(recording, model=3), ModelError, "model: got int"),
        (lambda: read_recording(None), DataError, "path: got None"),
    ]
    for call, error, fragment in cases:
        with pytest.raises(error) as info:
            call()
        assert fragment in str(info.value), (fragment, str(info.value))
    assert not (tmp_path / "x.csv").exists()
    # what is right still works: a model given by name, a payload given as a table, preprocess=True
    assert read_recording(recording, model="exo_leg").joints == RobotModel.from_urdf("exo_leg").joint_names
    assert list(identify(Study(leg, ds, preprocess=True), methods="ols").results) == ["ols"]


#: Public functions of docs/api.md that do not yet refuse a wrong-type argument with a PinidError (they
#: raise AttributeError/TypeError): none since issue 25 item 23's guards.  test_known_gaps_are_still_gaps
#: fails when a listed one is fixed (take it off the list); the seeded test fails when any other public
#: function regresses.
KNOWN_GAPS: set[str] = set()


def _api_functions() -> dict[str, object]:
    """Every public function of the modules docs/api.md lists (pinid.docgen.API_MODULES), by name."""
    import importlib
    import inspect

    from pinid.docgen import API_MODULES, _public

    out = {}
    for modname, _ in API_MODULES:
        module = importlib.import_module(modname)
        for name in _public(module):
            obj = getattr(module, name)
            if inspect.isfunction(obj):
                out[f"{modname.removeprefix('pinid.')}.{name}"] = obj
    return out


def _wrong(rng: np.random.Generator, annotation) -> object:
    """A wrong-type value for an argument: an object, None (unless the annotation allows it), bytes, a
    complex number, a set, a function, Ellipsis."""
    kinds = [object(), b"\x00x", 3 + 4j, {1, 2}, lambda: 0, Ellipsis]
    if "None" not in str(annotation):
        kinds.append(None)
    return kinds[int(rng.integers(len(kinds)))]


@pytest.mark.parametrize("seed", range(3))
def test_every_public_function_refuses_wrong_types(seed):
    """Every public function of docs/api.md, its required arguments all of wrong types (seeded draws),
    raises a PinidError subclass (a ValueError/TypeError/OSError too) naming an argument — except the
    listed gaps, which must still be gaps (so that the list only shrinks)."""
    import inspect
    import warnings

    from pinid.errors import PinidError

    rng = np.random.default_rng(seed)
    functions = _api_functions()
    assert len(functions) > 150
    assert KNOWN_GAPS <= set(functions), sorted(KNOWN_GAPS - set(functions))
    bad = []
    for name, f in functions.items():
        params = inspect.signature(f).parameters.values()
        required = [
            p
            for p in params
            if p.default is inspect.Parameter.empty and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
        ]
        if not required:
            continue
        args = {p.name: _wrong(rng, p.annotation) for p in required}
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                f(**args)
            outcome = "accepted"
        except PinidError as exc:
            outcome = None
            if not any(p.name in str(exc) or p.name.replace("_", " ") in str(exc) for p in params) and not any(
                k in str(exc) for k in ("got ", "expected")
            ):
                outcome = f"PinidError without the argument's name: {exc}"
        except Exception as exc:  # noqa: BLE001 - what the test looks for
            outcome = f"{type(exc).__name__}: {str(exc)[:100]}"
        if name not in KNOWN_GAPS and outcome is not None:
            bad.append(f"{name}: {outcome}")
    assert not bad, "\n".join(bad)


def test_known_gaps_are_still_gaps():
    """KNOWN_GAPS stays current: a listed function that now refuses object() arguments with a PinidError
    is taken off the list."""
    import inspect
    import warnings

    from pinid.errors import PinidError

    functions = _api_functions()
    fixed = []
    for name in sorted(KNOWN_GAPS):
        f = functions[name]
        params = inspect.signature(f).parameters.values()
        required = [
            p
            for p in params
            if p.default is inspect.Parameter.empty and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
        ]
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                f(**{p.name: object() for p in required})
        except PinidError:
            fixed.append(name)
        except Exception:  # noqa: BLE001, S110 - still a gap
            pass
    assert not fixed, f"now refused with a PinidError, take them off KNOWN_GAPS: {fixed}"
