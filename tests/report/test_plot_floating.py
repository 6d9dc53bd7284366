"""The figures of a floating base (issue 46), for two legs and for a whole-body robot: the base wrench measured
against predicted per axis, the contact phases, the base trajectory, the determined parameters, the errors of the
rows used (no empty joint panels); and the iCub walking recording read from the lab's MATLAB file by the shipped
manifest (skipped without the shared data)."""

from __future__ import annotations

import json
import os
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import run_cli, shared_data
from pinid import RobotModel
from pinid.identification.floating import joint_chains
from pinid.identification.outputs import identification_text
from pinid.identification.run import identify
from pinid.identification.study import Study
from pinid.report.markdown import figure_recipes, floor_line, report_markdown
from pinid.simulation.floating_twin import simulate_gait

ROOT = Path(__file__).resolve().parents[2]
ICUB_JOINTS = (
    "l_hip_pitch,l_hip_roll,l_hip_yaw,l_knee,l_ankle_pitch,l_ankle_roll,r_hip_pitch,r_hip_roll,r_hip_yaw,r_knee,"
    "r_ankle_pitch,r_ankle_roll,torso_pitch,torso_roll,torso_yaw,l_shoulder_pitch,l_shoulder_roll,l_shoulder_yaw,"
    "l_elbow,neck_pitch,neck_roll,neck_yaw,r_shoulder_pitch,r_shoulder_roll,r_shoulder_yaw,r_elbow"
)


@pytest.fixture(scope="module")
def walks(floating_exo):
    return simulate_gait(floating_exo, seconds=3, rate=100), simulate_gait(floating_exo, seconds=3, rate=100, seed=1)


@pytest.fixture(scope="module")
def hanging(floating_exo):
    """The suspended twin (its base rows alone excite every inertial base parameter; the walk's do not)."""
    from conftest import floating_excitation
    from pinid.simulation.floating_twin import simulate_suspended

    return tuple(
        simulate_suspended(floating_exo, floating_excitation(floating_exo, s), seconds=4, rate=200, seed=s)
        for s in (0, 1)
    )


def _identify(model, walks, rows):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        train, val = walks
        study = Study(model, [train.exact], validate=[val.exact], terms="fc,fv", floating={"rows": rows})
        return identify(study, ("ols",))


def _draw(recipe):
    f, args, kwargs = recipe
    return f(*args, **kwargs)


@pytest.mark.parametrize("rows", ["all", "base"])
def test_floating_figures_of_the_rows_used(floating_exo, walks, hanging, rows):
    """On the exact walk (no noise) the predicted base wrench is the measured one (per axis, to 1e-6 of its RMS);
    the wrench figure has forces [N] and moments [N·m] in panels of their own; the errors figure has a joint panel
    only with joint rows; the floor line names only the rows used; the contact figure's share of time in contact is
    the twin's (60 % of the stride per sole)."""
    ident = _identify(floating_exo, walks if rows == "all" else hanging, rows)
    axes = ident.results["ols"].info["base_axes"]
    assert axes["on"] == "validation"
    measured = ident.curves["wrench"]["measured"]  # the one validation recording: the rows base_axes scores
    for k, a in enumerate(("fx", "fy", "fz", "tx", "ty", "tz")):
        assert axes[a]["rms"] <= 1e-6 * np.sqrt(np.mean(measured[:, k] ** 2)), (a, axes[a])
    figs = figure_recipes(ident)
    assert {"wrench", "contacts", "base_motion", "parameters", "errors", "motion"} <= set(figs)
    import matplotlib.pyplot as plt

    fig = _draw(figs["wrench"])
    assert sorted(ax.get_ylabel() for ax in fig.axes) == [
        "fx [N]",
        "fy [N]",
        "fz [N]",
        "tx [N·m]",
        "ty [N·m]",
        "tz [N·m]",
    ]
    np.testing.assert_allclose(ident.curves["wrench"]["predicted"]["ols"], measured, atol=1e-6 * np.abs(measured).max())
    plt.close(fig)
    fig = _draw(figs["errors"])
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(visible) == (3 if rows == "all" else 2)
    assert all(len(ax.patches) for ax in visible)  # no empty panel
    assert "forces [N]" in visible[0].get_ylabel() and "moments [N·m]" in visible[1].get_ylabel()
    plt.close(fig)
    line = floor_line(ident)
    assert line is not None and "base" in line and ("l_knee" in line) == (rows == "all")
    fig = _draw(figs["contacts"])
    shares = [float(ax.get_title().split("in contact ")[1].split(" %")[0]) for ax in fig.axes]
    if rows == "all":  # the walk's soles
        assert len(shares) == 2 and all(50 <= s <= 70 for s in shares), shares
    plt.close(fig)
    for key in ("base_motion", "parameters", "motion"):
        plt.close(_draw(figs[key]))
    text = identification_text(ident)
    assert "base wrench, validation RMS per axis (ols): fx" in text and "total mass [kg]: ols 21.8" in text, text
    report = report_markdown(ident, {"wrench": "base_wrench.png", "parameters": "parameters.png"})
    assert "![base wrench: measured and predicted](base_wrench.png)" in report


def test_joint_chains_of_two_legs(floating_exo):
    assert joint_chains(floating_exo) == [
        ["l_hip_abduction", "l_hip_flexion", "l_knee", "l_ankle"],
        ["r_hip_abduction", "r_hip_flexion", "r_knee", "r_ankle"],
    ]


def _icub_layout(tmp_path) -> Path:
    """A clone with the shared data beside it, as CI has it: ``tmp/clone/docs/examples/icub_walking`` (the
    manifest and its mapping spec) and ``tmp/shared`` (a link to the shared data's parent)."""
    data = shared_data()
    if not (data / "icub_walking" / "walking.mat").is_file():
        pytest.skip("no shared iCub walking recording")
    pytest.importorskip("h5py")
    clone = tmp_path / "clone"
    shutil.copytree(ROOT / "docs" / "examples" / "icub_walking", clone / "docs" / "examples" / "icub_walking")
    os.symlink(data.parent, tmp_path / "shared")
    return clone


def test_icub_joint_chains(tmp_path):
    data = shared_data() / "icub_walking" / "iCubGenova04.urdf"
    if not data.is_file():
        pytest.skip("no shared iCub walking recording")
    model = RobotModel.from_urdf(data, base="floating", joints=ICUB_JOINTS.split(","))
    chains = joint_chains(model)
    assert sorted(len(c) for c in chains) == [3, 3, 4, 4, 6, 6]
    assert ["torso_pitch", "torso_roll", "torso_yaw"] in chains


@pytest.mark.slow  # the command on 89 s of a 26-joint robot: about 15 s of CPU
def test_icub_walking_manifest_from_the_project_root(tmp_path):
    """The command of issue 46 from the project's root: the lab's v7.3 file through the shipped manifest and
    mapping spec (first 70 % to train, last 30 % to validate), the base rows; the total mass within 3 % of 33.3 kg
    (the URDF's 33.08), physically consistent SDP, every axis's validation error, the floating figures."""
    clone = _icub_layout(tmp_path)
    proc = run_cli("identify", "--urdf", "../shared/data/icub_walking/iCubGenova04.urdf", "--base", "floating",
                   "--joints", ICUB_JOINTS, "--rows", "base", "--manifest", "docs/examples/icub_walking/study.toml",
                   "--methods", "ols,sdp", "-o", "out", cwd=clone)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    d = json.loads((clone / "out" / "identification.json").read_text())
    sdp = d["methods"]["sdp"]
    assert sdp["physically_consistent"]
    assert sdp["info"]["total_mass"]["value"] == pytest.approx(33.3, rel=0.03)
    assert set(sdp["info"]["base_axes"]) == {"on", "fx", "fy", "fz", "tx", "ty", "tz"}
    assert d["data"]["samples"] > 6000 and len(d["validation_sources"]) == 1
    for name in ("base_wrench.png", "contacts.png", "base_trajectory.png", "parameters.png", "errors.png"):
        assert (clone / "out" / name).is_file(), name
    assert "total mass [kg]: ols" in proc.stdout and "base wrench, validation RMS per axis (sdp)" in proc.stdout
    assert "l_knee –" not in proc.stdout  # the floor line: the rows used only


def test_every_figure_a_force_rerun_removes(floating_exo, walks):
    """Every figure file of a floating report is one `pinid identify --force` removes of an earlier run's."""
    import fnmatch

    from pinid.report.markdown import REPORT_FILES, report_file_names

    ident = _identify(floating_exo, walks, "all")
    for name in report_file_names(ident):
        assert any(fnmatch.fnmatch(name, p) for p in REPORT_FILES), name
