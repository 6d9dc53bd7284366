"""The wearer: anthropometric table, wearer URDF."""

from __future__ import annotations

import numpy as np
import pytest

from pinid.errors import SpecError
from pinid.wearer import anthropometry as anth
from pinid.wearer.attach import wearer_urdf


@pytest.mark.parametrize("sex", anth.SEXES)
def test_table_masses_sum_to_body_mass(sex):
    rows = anth.table()[sex]
    total = sum(r["count"] * r["mass_fraction"] for r in rows.values())
    assert total == pytest.approx(1.0, abs=2e-4)  # the table is rounded to 0.01 % of body mass
    assert all(r["source"].startswith("de Leva 1996") for r in rows.values())


def test_male_75kg_178m_plausible():
    thigh = anth.segment("thigh", mass=75, height=1.78, sex="male")
    shank = anth.segment("shank", mass=75, height=1.78, sex="male")
    foot = anth.segment("foot", mass=75, height=1.78, sex="male")
    assert thigh.mass == pytest.approx(10.62) and shank.mass == pytest.approx(3.2475)
    assert 0.40 < thigh.length < 0.46 and 0.41 < shank.length < 0.47 and 0.24 < foot.length < 0.28
    assert 0.16 < thigh.com < 0.19 and 0.18 < shank.com < 0.21
    # sagittal-plane moment of inertia about the CoM: ~0.2 kg m² thigh, ~0.05 kg m² shank (textbook values)
    assert 0.15 < thigh.inertia[1] < 0.25 and 0.035 < shank.inertia[1] < 0.07


@pytest.mark.parametrize(
    "kw, what",
    [
        (dict(mass=20, height=1.78, sex="male"), "body mass 20 kg"),
        (dict(mass=75, height=2.5, sex="male"), "height 2.5 m"),
        (dict(mass=75, height=1.78, sex="x"), "sex 'x'"),
    ],
)
def test_person_out_of_range(kw, what):
    with pytest.raises(SpecError, match=what):
        anth.segment("thigh", **kw)


def test_wearer_urdf_adds_segment_inertia_to_exo_bodies(tmp_path):
    from pinid.model.robot import RobotModel
    from pinid.wearer.attach import wearer_links, wearer_urdf

    out = tmp_path / "w.urdf"
    text = wearer_urdf("exo_leg", "hip:thigh,knee:shank", mass=75, height=1.78, sex="male", path=out)
    exo, both = RobotModel.from_urdf("exo_leg"), RobotModel.from_urdf(out)
    seg = wearer_links(text)
    for i, name in enumerate(("thigh", "shank")):
        link, m, c, Ic = seg[name]
        assert link == name
        extra = (
            both.pin_model.inertias[i + 1].toDynamicParameters() - exo.pin_model.inertias[i + 1].toDynamicParameters()
        )
        assert extra[0] == pytest.approx(m)
        np.testing.assert_allclose(extra[1:4], m * c, atol=1e-9)
        # segment axis along the exo link (-z here), proximal end at the joint: CoM straight below it
        assert c[0] == pytest.approx(0) and c[2] == pytest.approx(
            -anth.segment(name, mass=75, height=1.78, sex="male").com
        )
        # the transverse (joint-axis) radius of gyration is the one about y
        s = anth.segment(name, mass=75, height=1.78, sex="male")
        assert Ic[1, 1] == pytest.approx(s.inertia[1]) and Ic[2, 2] == pytest.approx(s.inertia[2])


def test_foot_on_shank_link_starts_at_the_ankle():
    from pinid.wearer.attach import wearer_links, wearer_urdf

    seg = wearer_links(wearer_urdf("exo_leg", "hip:thigh,knee:shank,shank:foot", mass=60, height=1.65, sex="female"))
    shank, foot = (anth.segment(n, mass=60, height=1.65, sex="female") for n in ("shank", "foot"))
    np.testing.assert_allclose(seg["foot"][2], [foot.com, 0, -shank.length], atol=1e-9)


def _cli(*argv):
    from pinid.cli.main import main

    return main(list(argv))


def test_cli_wearer_writes_urdf(tmp_path, capsys):
    out = tmp_path / "exo_with_wearer.urdf"
    assert (
        _cli(
            "wearer",
            "--urdf",
            "exo_leg",
            "--mass",
            "75",
            "--height",
            "1.78",
            "--sex",
            "male",
            "--attach",
            "hip:thigh,knee:shank",
            "-o",
            str(out),
        )
        == 0
    )
    assert "wearer_thigh_strap" in out.read_text()
    printed = capsys.readouterr().out
    assert "10.62 kg" in printed
    # the picture of where the segments attach, beside the URDF and listed; none with --no-figures
    png = tmp_path / "exo_with_wearer.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert f"wrote {png} (where the segments attach" in printed
    person = ("--mass", "75", "--height", "1.78", "--sex", "male")
    assert _cli("wearer", *person, "--no-figures", "-o", str(tmp_path / "b.urdf")) == 0
    assert ".png" not in capsys.readouterr().out and not (tmp_path / "b.png").exists()
    assert sorted(f.name for f in tmp_path.iterdir()) == ["b.urdf", "exo_with_wearer.png", "exo_with_wearer.urdf"]


@pytest.mark.parametrize(
    "robot, attach, feet",
    [("exo_lower_body", None, ("l_foot", "r_foot")), ("exo_leg", "hip:thigh,knee:shank,knee:foot", ("foot",))],
)
def test_attachment_picture_puts_the_foot_forward(robot, attach, feet):
    """The attachment picture, read from its plotted data (not pixels): in the zero pose each foot's CoM is
    ahead of its attachment (+x, sagittal view) and level with the ankle, every thigh and shank hangs below
    its frame; a 3-D robot gets a frontal view with the left leg at +y.  The foot once pointed sideways."""
    import matplotlib.pyplot as plt

    from pinid.report.plot_wearer import attachment_figure
    from pinid.wearer.attach import wearer_segments

    text = wearer_urdf(robot, attach, mass=75, height=1.78, sex="male")
    segments = wearer_segments(text)
    fig = attachment_figure(text, segments)
    try:

        def point(ax, gid):
            (line,) = [ln for ln in ax.lines if ln.get_gid() == gid]
            return float(line.get_xdata()[0]), float(line.get_ydata()[0])

        sagittal = fig.axes[0]
        assert len(fig.axes) == (2 if robot == "exo_lower_body" else 1)
        for foot in feet:
            (cx, cz), (ax_, _) = point(sagittal, f"com:{foot}"), point(sagittal, f"attach:{foot}")
            assert cx - ax_ == pytest.approx(0.1165, abs=1e-3)  # de Leva's 44 % of the foot, forward
            (line,) = [ln for ln in sagittal.lines if ln.get_gid() == f"segment:{foot}"]  # heel to toe
            (x0, x1), (z0, z1) = line.get_xdata(), line.get_ydata()
            assert x1 - x0 == pytest.approx(0.2639, abs=1e-3) and z0 == pytest.approx(z1, abs=1e-6) == cz
        for seg in segments:
            if seg.endswith(("thigh", "shank")):
                assert point(sagittal, f"com:{seg}")[1] < point(sagittal, f"attach:{seg}")[1] - 0.1, seg
        if robot == "exo_lower_body":
            frontal = fig.axes[1]
            assert point(frontal, "com:l_foot")[0] > 0.05 > -0.05 > point(frontal, "com:r_foot")[0]
    finally:
        plt.close("all")


@pytest.mark.parametrize(
    "extra, words",
    [
        (["--mass", "200", "--height", "1.78"], "body mass 200 kg"),
        (["--mass", "75", "--height", "1.2"], "height 1.2 m"),
        (["--mass", "75", "--height", "1.78", "--attach", "ankle:foot"], "'ankle' names no joint or link"),
        (["--mass", "75", "--height", "1.78", "--attach", "hip:arm"], "segment 'arm'"),
        (["--mass", "75", "--height", "1.78", "--attach", "hip"], "expected POINT:SEGMENT"),
    ],
)
def test_cli_wearer_bad_input(tmp_path, capsys, extra, words):
    out = tmp_path / "x.urdf"
    assert _cli("wearer", "--sex", "male", "-o", str(out), *extra) == 2
    err = capsys.readouterr().err
    assert words in err and len(err.strip().splitlines()) == 1
    assert not out.exists() and not list(tmp_path.iterdir())
