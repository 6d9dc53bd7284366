"""MJCF of a floating identification (issue 27): a free joint carrying the identified base link, the same
dynamics in MuJoCo as Pinocchio's on the identified floating model."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli

from pinid import RobotModel
from pinid.identification.study import Study
from pinid.identification.outputs import write_identification
from pinid.identification.result import load_identified
from pinid.identification.run import identify
from pinid.model.terms import TermSelection
from pinid.simulation.floating_twin import simulate_suspended
from conftest import floating_excitation as excitation
from test_mjcf import free_joint_errors

mujoco = pytest.importorskip("mujoco")

TERMS = TermSelection.from_names("fc,fv")


@pytest.fixture(scope="module")
def identified(tmp_path_factory):
    """The noise-free suspended twin of exo_lower_body identified by SDP, written to a folder."""
    exo = RobotModel.from_urdf("exo_lower_body", base="floating")
    twin = simulate_suspended(exo, excitation(exo), seconds=3, rate=100, imu_frame="imu")
    ident = identify(Study(exo, twin.exact, terms=TERMS), methods=("sdp",))
    folder = tmp_path_factory.mktemp("floating_mjcf")
    write_identification(ident, folder, report=False)
    return exo, folder


def test_identify_writes_a_free_joint_mjcf_with_the_identified_dynamics(identified):
    """M(q) and qacc of the written MJCF equal Pinocchio's on the identified floating model at 20 random states:
    MuJoCo's free joint has the root's linear velocity in the WORLD frame (Pinocchio: base frame), so with
    v_pin = T·v_mj, T = diag(Rᵀ, 1, 1): M_mj = Tᵀ·M_pin·T and the root's linear qacc = R·(a + ω × v)."""
    exo, folder = identified
    identified = load_identified(folder / "identification.json")
    model, terms, theta = identified.nominal_robot, identified.terms, identified.theta
    assert identified.meta["method"] == "sdp" and terms.names == TERMS.names and model.base_link == exo.base_link
    n = exo.nv
    total = sum(i.mass for i in exo.ff_model.inertias)
    assert theta[: 10 * (n + 1) : 10].sum() == pytest.approx(total, rel=1e-6)  # noise-free: the total mass
    pm = exo.with_floating_parameters(theta[: 10 * (n + 1)]).ff_model
    pd = pm.createData()
    fv = theta[10 * (n + 1) :].reshape(n + 1, 2)[1:, 1]  # per body: fc, fv (the base's first)
    m = mujoco.MjModel.from_xml_path(str(folder / "identified_sdp.xml"))
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS | mujoco.mjtDisableBit.mjDSBL_CONTACT
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    d = mujoco.MjData(m)
    assert (m.nq, m.nv, m.nu) == (pm.nq, pm.nv, n) and m.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert m.body_mass[1:].sum() == pytest.approx(sum(i.mass for i in pm.inertias), rel=1e-12)
    np.testing.assert_allclose(m.dof_damping[6:], fv, rtol=1e-12)
    rng = np.random.default_rng(4)
    for _ in range(20):
        m_err, a_err = free_joint_errors(m, d, pm, pd, rng, rng.uniform(exo.lower, exo.upper), 20.0, fv)
        assert m_err < 1e-8 and a_err < 1e-8


def test_export_reads_the_floating_identification(identified, tmp_path):
    """pinid export recognises the floating identification (no flag) and writes the same MJCF as identify."""
    exo, folder = identified
    proc = run_cli("export", "--model", str(folder / "identification.json"), "-o", "exo.xml", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "exo.xml").read_text() == (folder / "identified_sdp.xml").read_text()
    proc = run_cli(
        "export", "--model", str(folder / "identification.json"), "--format", "urdf", "-o", "e.urdf", cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    back = RobotModel.from_urdf(tmp_path / "e.urdf", base="floating")
    m = mujoco.MjModel.from_xml_path(str(tmp_path / "exo.xml"))
    assert m.body_mass.sum() == pytest.approx(sum(i.mass for i in back.ff_model.inertias), rel=1e-9)
    # which standard parameters the data determined, beside each body (issue 33): the base link and the 8 bodies
    urdf, xml = (tmp_path / "e.urdf").read_text(), (tmp_path / "exo.xml").read_text()
    assert urdf.count("<!-- pinid, from these data (standard parameters m, m·c, I about the base frame)") == 1
    assert urdf.count("<!-- pinid, from these data (standard parameters m, m·c, I about the joint)") == 8
    assert xml.count("<!-- pinid, from these data (standard parameters") == 9


def test_bad_floating_exports_are_one_line_and_write_nothing(identified, tmp_path):
    """The fixed base's loader reads a floating identification: an unknown method, a tampered parameter list or an
    inconsistent set is one line (exit 2), nothing written."""
    _, folder = identified
    d = json.loads((folder / "identification.json").read_text())
    sdp = d["methods"]["sdp"]
    short = dict(list(sdp["standard_parameters"].items())[:-1])
    cases = {
        "no method": (d, "nope", "no method 'nope'"),
        "short": ({**d, "methods": {"sdp": {**sdp, "standard_parameters": short}}}, None, "result 'sdp'"),
        "inconsistent": (
            {**d, "methods": {"sdp": {**sdp, "standard_parameters": {**sdp["standard_parameters"], "base.m": -1.0}}}},
            None,
            "physically inconsistent",
        ),
    }
    for content, method, fragment in cases.values():
        (tmp_path / "i.json").write_text(json.dumps(content))
        extra = ["--method", method] if method else []
        proc = run_cli("export", "--model", "i.json", *extra, "-o", "x.xml", cwd=tmp_path)
        assert_clean_error(proc, fragment)
        assert not (tmp_path / "x.xml").exists()
