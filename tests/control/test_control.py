"""Controllers on a model: exact models track to the noise level; backstepping's Lyapunov function decreases;
`pinid track --model` refuses a model of other joints or one that is not physically consistent."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import assert_clean_error, knee_mass as _param, run_cli, tampered_json as _tampered

from pinid.control.controllers import Backstepping, ComputedTorque, Tracking, nominal_model, track
from pinid.errors import SpecError
from pinid.excitation.trajectory import FourierTrajectory

ROOT = Path(__file__).resolve().parents[2]


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


REF = FourierTrajectory(["hip", "knee"], 0.5 * np.pi, [0.61, -0.87], [[0.5], [0.5]], [[0.0], [0.0]])


@pytest.mark.parametrize("controller", [Backstepping, ComputedTorque])
def test_exact_model_tracks_to_noise_level(exo, controller):
    noise = 1e-4  # rad
    r = track(exo, controller(nominal_model(exo)), REF, Tracking(3, position_noise=noise, seed=1))
    for name, m in r.metrics(after=1.0).items():
        assert m["rms"] < 3 * noise, (name, m)
    # inside Table 2 all along
    assert np.all(r.q >= exo.lower - 0.02) and np.all(r.q <= exo.upper + 0.02)


def test_backstepping_lyapunov_decreases_noise_free(exo):
    """Seed 001 Eq. (30): with the exact model, V̇ = −δ1ᵀK1δ1 − δ2ᵀK2δ2 < 0 along the run.

    Coulomb friction is left out of this check: under a zero-order hold its sign can flip inside a
    control period, which no sampled controller can cancel (V then rises by ~1e-5·V0 at reversals)."""
    plant = exo.with_inertial_parameters(exo.inertial_parameters(), coulomb=np.zeros(2))
    ctrl = Backstepping(nominal_model(plant), K1=5.0, K2=10.0, friction_from="measured")
    r = track(plant, ctrl, REF, Tracking(1.5, rate=1000, substeps=4), lyapunov=True)
    V = r.lyapunov
    assert V[0] > 0.1
    assert np.all(np.diff(V) < 1e-8 * V[0]), np.diff(V).max()  # zero-order-hold rounding only
    assert V[-1] < 1e-3 * V[0]


def test_wrong_model_tracks_worse(exo):
    rng = np.random.default_rng(0)
    theta = exo.inertial_parameters() * (1 + 0.3 * rng.choice([-1, 1], size=20))
    wrong = nominal_model(exo.with_inertial_parameters(theta), friction=False)
    good = track(exo, ComputedTorque(nominal_model(exo)), REF, Tracking(3)).metrics(after=1.0)
    bad = track(exo, ComputedTorque(wrong), REF, Tracking(3)).metrics(after=1.0)
    for j in ("hip", "knee"):
        assert bad[j]["rms"] > 10 * good[j]["rms"]


def test_gains_must_be_positive_definite(exo):
    with pytest.raises(SpecError, match="positive definite"):
        Backstepping(nominal_model(exo), K1=-1.0)
    with pytest.raises(SpecError, match="expected a number"):
        ComputedTorque(nominal_model(exo), Kp=np.ones(3))
    with pytest.raises(SpecError, match="friction_from"):
        ComputedTorque(nominal_model(exo), friction_from="sometimes")


EXCITATION = FourierTrajectory(
    ["hip", "knee"],
    0.2 * np.pi,
    [0.61, -0.87],
    [[0.3, 0.15, 0.05], [-0.25, 0.12, -0.06]],
    [[0.1, -0.08, 0.04], [0.1, 0.06, -0.03]],
)


@pytest.mark.slow
def test_identified_model_halves_tracking_error_of_both_controllers(exo):
    """Issue 7: CAD model 30 % off without friction vs the model identified from twin recordings."""
    from pinid.control.tracking import sine_reference
    from pinid.control.controllers import identified_vs_cad

    r = identified_vs_cad(exo, EXCITATION, sine_reference(exo), record_seconds=20, track_seconds=5)
    for controller, per_model in r["table"].items():
        cad, ident = per_model.values()
        for joint in ("hip", "knee"):
            assert ident["metrics"][joint]["rms"] <= 0.5 * cad["metrics"][joint]["rms"], (controller, joint)


def test_cli_track_writes_json_and_plots(tmp_path):
    from conftest import run_cli

    proc = run_cli("track", "--seconds", "2", "--after", "0.5", "--controller", "computed-torque", "-o", str(tmp_path))
    assert proc.returncode == 0, proc.stderr
    assert "computed-torque" in proc.stdout and (tmp_path / "tracking_computed-torque.png").is_file()
    import json

    d = json.loads((tmp_path / "tracking.json").read_text())
    assert d["results"]["computed-torque"]["nominal"]["hip"]["rms"] < 1e-3
    # the comparison across models: written, a PNG, listed; --no-figures writes the JSON alone
    png = tmp_path / "tracking_models.png"
    assert png.read_bytes()[:4] == b"\x89PNG" and png.stat().st_size > 5_000 and "tracking_models.png" in proc.stdout
    args = ("track", "--seconds", "1", "--after", "0.5", "--controller", "computed-torque", "--no-figures")
    proc = run_cli(*args, "-o", str(tmp_path / "n"))
    assert proc.returncode == 0, proc.stderr
    assert [f.name for f in (tmp_path / "n").iterdir()] == ["tracking.json"] and ".png" not in proc.stdout


def test_tracking_models_figure_bars_every_model_and_controller():
    """One bar per model × controller and joint, its height the RMS [mrad]; a log axis when the bars span
    more than 100×, a linear one otherwise."""
    import matplotlib.pyplot as plt

    from pinid.report.plot_control import tracking_models_figure

    rms = {
        "backstepping": {"nominal": {"hip": 1e-5, "knee": 2e-5}, "cad:30": {"hip": 0.02, "knee": 0.01}},
        "computed-torque": {"nominal": {"hip": 3e-5, "knee": 1e-5}, "cad:30": {"hip": 0.01, "knee": 0.04}},
    }
    fig = tracking_models_figure(rms)
    ax = fig.axes[0]
    assert ax.get_yscale() == "log"
    heights = [p.get_height() for c in ax.containers for p in c.patches]
    assert heights == pytest.approx([0.01, 0.02, 0.03, 0.01, 20.0, 10.0, 10.0, 40.0])
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "nominal, backstepping",
        "nominal, computed-torque",
        "cad:30, backstepping",
        "cad:30, computed-torque",
    ]
    one = {"computed-torque": {"nominal": {"hip": 1e-3, "knee": 2e-3}, "a.json": {"hip": 5e-3, "knee": 4e-3}}}
    assert tracking_models_figure(one).axes[0].get_yscale() == "linear"
    plt.close("all")


def test_cli_track_bad_input(tmp_path):
    from conftest import assert_clean_error, run_cli

    assert_clean_error(run_cli("track", "--model", str(tmp_path / "none.json")), "no such file")
    assert_clean_error(run_cli("track", "--controller", "pid-magic", "-o", str(tmp_path / "o")), "controller")
    assert not (tmp_path / "o" / "tracking.json").exists()
    assert_clean_error(run_cli("track", "--seconds", "1", "--after", "2"), "expected seconds > after")


def test_compare_models_in_worker_processes_gives_the_serial_results(exo, monkeypatch):
    """Issue 35: the runs of compare_models are independent and seeded; in forked workers (one per core)
    they give the same numbers as one after the other."""
    import pinid.control.controllers as controllers
    import pinid.parallel

    models = {"exact": nominal_model(exo), "no friction": nominal_model(exo, friction=False)}
    kwargs = dict(seconds=1.0, after=0.5, seed=3)
    monkeypatch.setattr(pinid.parallel, "default_workers", lambda: 2)
    parallel = controllers.compare_models(exo, models, REF, **kwargs)
    monkeypatch.setattr(pinid.parallel, "default_workers", lambda: 1)
    serial = controllers.compare_models(exo, models, REF, **kwargs)
    for c in serial:
        for name in models:
            np.testing.assert_equal(parallel[c][name]["metrics"], serial[c][name]["metrics"])  # NaN: never settled
            np.testing.assert_array_equal(parallel[c][name]["result"].q, serial[c][name]["result"].q)


EXO = (ROOT / "urdf" / "exo_leg.urdf").read_text()


def _exo_with(old: str, new: str) -> str:
    assert old in EXO, old
    return EXO.replace(old, new, 1)


_KNEE_JOINT = '<joint name="knee" type="revolute">'


def test_track_model_with_other_joint_types(tmp_path):
    p = tmp_path / "prismatic_knee.urdf"
    p.write_text(_exo_with(_KNEE_JOINT, '<joint name="knee" type="prismatic">'))
    proc = run_cli("track", "--model", str(p), "--seconds", "1", "--after", "0.5", "-o", str(tmp_path / "t"))
    assert_clean_error(proc, "joint 'knee' is prismatic in the model but revolute in the plant")
    assert _files(tmp_path) == ["prismatic_knee.urdf"]


def test_track_model_with_other_joint_names(tmp_path):
    p = tmp_path / "renamed.urdf"
    p.write_text(EXO.replace('"knee"', '"shin"'))
    proc = run_cli("track", "--model", str(p), "--seconds", "1", "--after", "0.5", "-o", str(tmp_path / "t"))
    assert_clean_error(proc, "knee")
    assert _files(tmp_path) == ["renamed.urdf"]


def test_track_refuses_inconsistent_model(tmp_path, model_json):
    """Case 9: track refuses a model with a negative mass (its closed loop errs by 15-25 rad otherwise)."""
    path = _tampered(tmp_path, model_json, _param(-50.0))
    out = tmp_path / "track"
    proc = run_cli("track", "--model", str(path), "--seconds", "3", "-o", str(out))
    assert_clean_error(proc, "not physically consistent")
    assert not out.exists()
