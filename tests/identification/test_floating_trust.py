"""Numbers you can trust on a floating base (issue 33): σ and cond(W_b) of every method, and the checks of
the recordings against a known truth, the floating twin (:mod:`pinid.simulation.floating_twin`)."""

from __future__ import annotations

import dataclasses

import warnings

import numpy as np
import pytest

from conftest import floating_excitation
from pinid import RobotModel
from pinid.identification.study import Study
from pinid.data.preprocess import prepare
from pinid.identification.run import identify
from pinid.model.terms import TermSelection
from pinid.simulation.floating_twin import Noise, simulate_suspended

TERMS = TermSelection.from_names("fc,fv")
NOISE = Noise(torque=0.5, force=2.0, moment=0.2)


def identified(model, runs, validate=None, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        methods = kw.pop("methods", ("ols", "wls", "sdp"))
        study = Study(
            model,
            [prepare(r.recording) for r in runs],
            validate=None if validate is None else [prepare(r.recording) for r in validate],
            terms=TERMS,
            **kw,
        )
        return identify(study, methods)


@pytest.mark.slow  # 11 s of CPU (docs/benchmarks.md, Test suite)
def test_true_base_parameters_lie_within_two_sigma_at_about_the_nominal_rate(floating_exo):
    """4 suspended twins (10 s at 200 Hz, torque, force and moment noise, default preprocessing) without
    Coulomb friction (the filtered Coulomb step is a model error no σ covers: docs/floating-base.md): the share
    of the 82 true base parameters within ±2σ is near 95 % (measured 87.8 / 90.2 / 95.5 % for ols / wls /
    sdp over seeds 0–3), far from the 30–50 % a white-noise σ gives."""
    twin = RobotModel.from_urdf("exo_lower_body", base="floating")
    twin.coulomb = np.zeros(twin.nv)
    hits = {m: [0, 0] for m in ("ols", "wls", "sdp")}
    for seed in range(4):
        run = simulate_suspended(
            twin, floating_excitation(floating_exo, seed), seconds=10, rate=200, noise=NOISE, seed=seed
        )
        ident = identified(floating_exo, [run])
        truth = np.array([0.0 if n.endswith(".fc") else v for n, v in zip(ident.base["names"], ident.base["nominal"])])
        for m, r in ident.results.items():
            std = r.std
            assert r.condition_number > 1 and len(std) == len(ident.base["names"]) == len(r.std_percent)
            ok = np.isfinite(std)
            hits[m][0] += int(np.sum(np.abs(r.base - truth)[ok] <= 2 * std[ok]))
            hits[m][1] += int(ok.sum())
    share = {m: h / n for m, (h, n) in hits.items()}
    assert share["ols"] >= 0.8 and share["wls"] >= 0.8 and share["sdp"] >= 0.85, share


@pytest.fixture(scope="module")
def suspended(floating_exo):
    return simulate_suspended(
        floating_exo, floating_excitation(floating_exo, 7), seconds=6, rate=200, noise=NOISE, seed=7
    )


def test_a_flipped_joint_torque_is_named(floating_exo, suspended):
    """The fixed base's "check the sign of tau_<joint>" (r < −0.5 against the URDF's torque for the motion and
    the measured wrenches) on the floating path: the knee's torque flipped is named, nothing else."""
    rec = suspended.recording
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        identify(Study(floating_exo, [prepare(rec)], terms=TERMS), methods=("ols",))
    assert not [w for w in caught if "check the sign" in str(w.message)]
    j = floating_exo.joint_names.index("l_knee")
    tau = rec.tau.copy()
    tau[:, j] *= -1
    flipped = dataclasses.replace(rec, tau=tau, source="flipped")
    with pytest.warns(UserWarning, match="check the sign of tau_l_knee") as caught:
        ident = identify(Study(floating_exo, [prepare(flipped)], terms=TERMS), methods=("ols",))
    assert ident.data["flipped_torque_signs"] == ["l_knee"]
    assert sum("check the sign" in str(w.message) for w in caught) == 1


def test_whole_body_centre_of_mass_against_the_urdf(floating_exo):
    """The whole-body CoM (identified first moments / mass, base frame, mean posture) equals Pinocchio's for the
    URDF's parameters, comes back within 2 mm on the noisy walk (measured 0.5 mm), and force plates whose
    centre-of-pressure x and y are negated (a plate's axes turned by 180°) move it by metres: warned, naming
    the wrench's axes, frame and moments."""
    import pinocchio as pin

    from pinid.identification.floating_checks import whole_body_com
    from pinid.model.base import base_parameters
    from pinid.model.regressor import standard_parameters
    from pinid.simulation.floating_twin import simulate_gait

    base = base_parameters(floating_exo, TERMS)
    q = 0.5 * (floating_exo.lower + floating_exo.upper) + 0.1
    com = whole_body_com(floating_exo, TERMS, base, q, base.P @ standard_parameters(floating_exo, TERMS))[0]
    d = floating_exo.ff_model.createData()
    assert np.allclose(
        com, pin.centerOfMass(floating_exo.ff_model, d, np.r_[0, 0, 0, 0, 0, 0, 1.0, floating_exo.configuration(q)])
    )

    rec = simulate_gait(floating_exo, seconds=6, rate=200, noise=NOISE, seed=3).recording
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ident = identify(Study(floating_exo, [prepare(rec)], terms=TERMS), methods=("ols",))
    assert not [w for w in caught if "centre of mass" in str(w.message)]
    assert np.linalg.norm(np.subtract(ident.results["ols"].info["com"], ident.data["com_urdf"])) < 2e-3
    rec.floating.plates = {k: v * np.r_[1, 1, 1, -1, -1, 1, 1] for k, v in rec.floating.plates.items()}
    with pytest.warns(UserWarning, match="whole-body centre of mass .* ols .* the wrench's axes and frame"):
        identify(Study(floating_exo, [prepare(rec)], terms=TERMS), methods=("ols",))


def test_model_class_floor_on_floating_validation(floating_exo, suspended):
    """The floor (OLS fitted on the validation rows themselves) is at most every method's validation RMS, about
    the RMS of the true parameters on the same prepared rows (the noise floor), and given per body (the base's
    6 wrench rows as ``base``) and printed."""
    from pinid.problem.floating import floating_problem

    held_out = simulate_suspended(
        floating_exo, floating_excitation(floating_exo, 8), seconds=6, rate=200, noise=NOISE, seed=8
    )
    ident = identified(floating_exo, [suspended], [held_out], methods=("ols", "sdp"))
    floor = ident.floor
    assert all(floor.all["rms"] <= r.validation.all["rms"] for r in ident.results.values())
    val = floating_problem(floating_exo, prepare(held_out.recording), terms=TERMS)
    r = val.tau - val.predict(val.nominal_base)
    truth = float(np.sqrt(np.mean(r * r)))
    assert 0.8 * truth <= floor.all["rms"] <= truth, (floor.all["rms"], truth)
    assert set(floor.per_joint) == {"base", *floating_exo.joint_names}
    from pinid.identification.outputs import identification_text

    text = identification_text(ident)
    assert "model-class floor" in text and "base " in text[text.index("model-class floor") :]


def test_barely_excited_parameters_are_named(floating_exo):
    """The noisy 10 s walk barely excites the hip abductions (issue 33): their inertias are named in one
    warning line, and it names nearly every inertial base parameter whose true error exceeds 10 % of its
    natural scale (measured 62 of 63; the suspended excitation: 37 of 37)."""
    from pinid.problem.floating import floating_problem
    from pinid.simulation.floating_twin import simulate_gait

    run = simulate_gait(floating_exo, seconds=10, rate=200, noise=NOISE, seed=7)
    with pytest.warns(UserWarning, match="barely excited") as caught:
        ident = identify(Study(floating_exo, [prepare(run.recording)], terms=TERMS), methods=("ols",))
    assert sum("barely excited" in str(w.message) for w in caught) == 1
    flagged = set(ident.results["ols"].info["barely_excited"])
    assert {f"{s}_hip_abduction.{p}" for s in "lr" for p in ("IxxR", "IyyR")} <= flagged
    scale = floating_problem(floating_exo, run.exact, terms=TERMS).natural_scale
    err = np.abs(np.asarray(ident.results["ols"].base) - np.asarray(ident.base["nominal"])) / scale
    big = [n for n, e in zip(ident.base["names"], err) if e > 0.1 and not n.endswith((".fc", ".fv"))]
    assert sum(n in flagged for n in big) >= 0.9 * len(big)


#: pinid excite --urdf exo_lower_body --base floating's default design (docs/floating-base.md, the suspended
#: exoskeleton; shrunk by 0.409 for self-collision), to 4 significant digits: a motion that tilts the pelvis so
#: little that the base rows leave the height of the whole-body centre of mass poorly determined.
SUSPENDED_Q0 = [0.085, 0.785, 1.045, -0.085, 0.085, 0.785, 1.045, -0.085]
SUSPENDED_A = [
    [-0.0441, -0.02696, 0.1164, -0.06282],
    [-0.1895, 0.1681, -0.1837, 0.1011],
    [0.1844, -0.07708, 0.02227, -0.02426],
    [0.02109, 0.06574, -0.0948, 0.03296],
    [0.02735, 0.05688, 0.09984, -0.1102],
    [0.05767, -0.1094, -0.007421, 0.04587],
    [-0.1356, 0.002665, 0.07269, -0.02195],
    [0.01855, -0.08132, -0.01286, 0.04567],
]
SUSPENDED_B = [
    [0.001499, 0.0011, -0.01165, 0.006182],
    [-0.2738, -0.3586, 0.003944, 0.1045],
    [0.3507, 0.1104, 0.0123, -0.05644],
    [-0.03463, -0.05379, 0.02414, 0.002032],
    [-0.001207, 0.002463, -0.003016, 0.001156],
    [-0.5446, -0.02136, 0.03276, 0.02095],
    [0.453, 0.02046, -0.04442, -0.008438],
    [-0.09211, -0.06266, -0.07653, 0.06447],
]


def test_clean_suspended_twin_on_the_base_rows_gets_no_centre_of_mass_warning(floating_exo, tmp_path):
    """Issue 47: the clean suspended twin identified from its base rows alone (``--rows base``, IMU, the docs'
    excitation, here 10 s at 200 Hz) has a whole-body centre of mass 0.27 m off the URDF's (its height: the
    pelvis barely tilts), which warned "check the wrench's axes"; that offset is within 3 σ of the CoM
    (σ 0.10 m along it, from the base parameters' σ), so it is the data's indeterminacy, not the wrench: no
    warning, and the σ is kept (``info["com_offset_std"]``)."""
    import contextlib
    import io

    from pinid.cli.main import main
    from pinid.excitation.trajectory import FourierTrajectory
    from pinid.identification.floating import FloatingOptions
    from pinid.identification.floating_checks import COM_SIGMAS

    traj = FourierTrajectory(floating_exo.joint_names, 0.2 * np.pi, SUSPENDED_Q0, SUSPENDED_A, SUSPENDED_B)
    traj.save(tmp_path / "exc.json")
    exo = ["--urdf", "exo_lower_body", "--base", "floating"]
    sim = ["simulate", *exo, "--excitation", str(tmp_path / "exc.json"), "--seconds", "10", "--control-rate", "200"]
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        assert main([*sim, "--imu", "imu", "--no-figures", "-o", str(tmp_path / "s.csv")]) == 0
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        study = Study(floating_exo, [tmp_path / "s.csv"], terms=TERMS, floating=FloatingOptions(rows="base"))
        ident = identify(study, methods=("ols",))
    said = [str(w.message) for w in caught]
    assert not [s for s in said if "centre of mass" in s or "wrench's axes" in s], said
    r = ident.results["ols"]
    off = float(np.linalg.norm(np.subtract(r.info["com"], ident.data["com_urdf"])))
    sigma = r.info["com_offset_std"]
    assert off > 0.1 and off < COM_SIGMAS * sigma, (off, sigma)  # the old check (>= 0.094 m here) warned
