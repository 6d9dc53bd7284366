"""Issue 14 and 33 (12): wrong values given to pinid's public functions (wrong shapes, NaN, infinities, lists,
strings, None, empty) give a PinidError subclass, never a bare numpy or Python error.

The property-style test drives the public API with generated wrong inputs from a seeded generator and asserts
that only PinidError subclasses come out; the named cases pin down the ones found by hand."""

from __future__ import annotations

import numpy as np
import pytest

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
