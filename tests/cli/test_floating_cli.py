"""The floating-base loop from the command line (issue 27): excite → simulate → identify → MJCF (written by
identify and by pinid export) → MuJoCo, and bad inputs."""

from __future__ import annotations

import json

import pytest

from conftest import assert_clean_error, run_cli

from pinid import RobotModel

EXO = ["--urdf", "exo_lower_body", "--base", "floating"]


@pytest.mark.slow
def test_excite_simulate_identify_floating(tmp_path):
    steps = [
        ["excite", *EXO, "--starts", "1", "--harmonics", "2", "--samples", "40", "--quiet", "-o", "exc.json"],
        [
            "simulate",
            *EXO,
            "--excitation",
            "exc.json",
            "--seconds",
            "6",
            "--control-rate",
            "200",
            "--imu",
            "imu",
            "-o",
            "s.csv",
        ],
        [
            "simulate",
            *EXO,
            "--excitation",
            "exc.json",
            "--seconds",
            "4",
            "--control-rate",
            "200",
            "--seed",
            "1",
            "-o",
            "v.csv",
        ],
        ["simulate", *EXO, "--excitation", "gait", "--seconds", "4", "--control-rate", "200", "-o", "g.csv"],
        ["simulate", *EXO, "--excitation", "gait", "--seconds", "1", "--no-figures", "-o", "n.csv"],
        ["identify", *EXO, "--data", "s.csv", "--validate", "v.csv", "--methods", "ols,sdp", "--no-report", "-o", "r"],
        ["identify", *EXO, "--data", "s.csv", "--rows", "base", "--methods", "ols", "--no-report", "-o", "rb"],
        ["identify", *EXO, "--data", "g.csv", "--methods", "ols", "--no-report", "-o", "rg"],
        ["export", "--model", "r/identification.json", "-o", "exo.xml"],
        ["export", "--model", "r/model_sdp.json", "-o", "exo_sdp.xml"],  # issue 47: "missing parameter(s) base.m…"
    ]
    for args in steps:
        proc = run_cli(*args, cwd=tmp_path, figures=True)
        assert proc.returncode == 0, (args, proc.stderr)
    # the joints drawn beside each recording (prescribed, recorded, torque), none with --no-figures
    assert all((tmp_path / f).stat().st_size > 10_000 for f in ("s.png", "v.png", "g.png"))
    assert not (tmp_path / "n.png").exists()
    clear = json.loads((tmp_path / "exc.json").read_text())["self_collision"]
    assert clear["pairs"] == 16 and clear["distance"] >= clear["margin"] == 0.02
    truth = json.loads((tmp_path / "s.truth.json").read_text())
    assert truth["base"] == "floating" and truth["standard_names"][0] == "base.m"
    for folder in ("r", "rb", "rg"):
        d = json.loads((tmp_path / folder / "identification.json").read_text())
        assert d["base"]["names"][0] == "base.mR" and d["data"]["base"] == "floating"
        for r in d["methods"].values():
            assert r["base_parameters"]["base.mR"] == pytest.approx(21.8, rel=0.01)  # the total mass
            assert r["condition_number"] > 1 and set(r["std_percent"]) == set(d["base"]["names"])
    d = json.loads((tmp_path / "r" / "identification.json").read_text())
    assert all(r["validation"]["all"]["rms"] < 1.0 for r in d["methods"].values())
    assert "base" in d["methods"]["sdp"]["validation"]["per_joint"]  # the 6 wrench rows, then each joint
    assert d["methods"]["sdp"]["physically_consistent"] and (tmp_path / "r" / "model_sdp.json").exists()
    back = RobotModel.from_urdf(tmp_path / "r" / "identified_sdp.urdf", base="floating")
    assert sum(i.mass for i in back.ff_model.inertias) == pytest.approx(
        d["methods"]["sdp"]["base_parameters"]["base.mR"]
    )
    # the MJCF written by identify (and again by pinid export) loads in MuJoCo: a free joint, the same mass
    assert (tmp_path / "exo.xml").read_text() == (tmp_path / "r" / f"identified_{d['best']}.xml").read_text()
    assert (tmp_path / "exo_sdp.xml").read_text() == (tmp_path / "r" / "identified_sdp.xml").read_text()
    mujoco = pytest.importorskip("mujoco")
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "exo.xml"))
    assert (m.nq, m.nv, m.nu) == (7 + back.nv, 6 + back.nv, back.nv) and m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert m.body_mass.sum() == pytest.approx(d["methods"][d["best"]]["base_parameters"]["base.mR"], rel=1e-9)


def test_simulate_floating_refuses_flip(tmp_path):
    """--flip negates a preset's joints for a fixed-base twin; the floating twin takes the trajectory as it is,
    so --base floating refuses it in one line (it was silently ignored) and writes nothing."""
    walk = ["simulate", *EXO, "--excitation", "gait", "--seconds", "0.3", "--control-rate", "100", "-o", "w.csv"]
    proc = run_cli(*walk, "--flip", "l_knee", cwd=tmp_path)
    assert_clean_error(proc, "--flip: not available with --base floating")
    assert not list(tmp_path.iterdir())
    assert run_cli(*walk, cwd=tmp_path).returncode == 0  # the same run without --flip
    assert (tmp_path / "w.csv").exists()


@pytest.mark.slow
def test_bad_floating_inputs_are_one_line_and_write_nothing(tmp_path):
    (tmp_path / "bad.csv").write_text(
        "t,q_l_hip_abduction,q_l_hip_flexion,q_l_knee,q_l_ankle,q_r_hip_abduction,q_r_hip_flexion,q_r_knee,q_r_ankle,"
        "imu_nowhere_qx,imu_nowhere_qy,imu_nowhere_qz,imu_nowhere_qw,imu_nowhere_wx,imu_nowhere_wy,imu_nowhere_wz,"
        "imu_nowhere_ax,imu_nowhere_ay,imu_nowhere_az\n"
        + "".join(f"{0.01 * k},0,0,0.5,0,0,0,0.5,0,0,0,0,1,0,0,0,0,0,9.81\n" for k in range(50))
    )
    proc = run_cli("identify", *EXO, "--data", "bad.csv", "--no-report", "-o", "out", cwd=tmp_path)
    assert_clean_error(proc, "'nowhere' is not a link")
    assert not (tmp_path / "out").exists()
    proc = run_cli("simulate", *EXO, "--excitation", "gait", "--perturb", "10", "-o", "x.csv", cwd=tmp_path)
    assert_clean_error(proc, "--perturb: not available with --base floating")
    assert not (tmp_path / "x.csv").exists()
    proc = run_cli(
        "identify", *EXO, "--data", "bad.csv", "--payload", "p.toml", "--no-report", "-o", "out", cwd=tmp_path
    )
    assert_clean_error(proc, "payload (--payload): not available with a floating base")
    (tmp_path / "manifest.toml").write_text('[[recording]]\nfile = "bad.csv"\nrole = "train"\n')
    for extra, option in (
        (["--data", "bad.csv", "--fit-joints", "l_knee"], "--fit-joints"),
        (["--data", "bad.csv", "--delay", "tau=0.05"], "--delay"),
        (["--data", "bad.csv", "--truth", "t.json"], "--truth"),
    ):
        proc = run_cli("identify", *EXO, *extra, "--no-report", "-o", "out", cwd=tmp_path)
        assert_clean_error(proc, f"{option}): not available with a floating base (docs/floating-base.md)")
        assert not (tmp_path / "out").exists()
    # a manifest's recordings are read as floating ones (issue 46): the same check as --data
    proc = run_cli("identify", *EXO, "--manifest", "manifest.toml", "--no-report", "-o", "out", cwd=tmp_path)
    assert_clean_error(proc, "'nowhere' is not a link")
    assert not (tmp_path / "out").exists()
    proc = run_cli(
        "identify", *EXO, "--data", "bad.csv", "--mapping", "m.toml", "--no-report", "-o", "out", cwd=tmp_path
    )
    assert_clean_error(proc, "m.toml: mapping spec not found")
    assert not (tmp_path / "out").exists()
    proc = run_cli("info", "--urdf", "exo_leg", "--base", "flying", cwd=tmp_path)
    assert proc.returncode == 2 and "invalid choice" in proc.stderr
