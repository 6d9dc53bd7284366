"""Issue 32: one writer and one text for a twin's run whatever the base.  ``write_simulation`` and
``simulation_text`` take the floating twin's ``(recording, truth)`` as they take the fixed twin's: the recording
read back is the simulated one, the truth JSON is the truth without its in-memory signals, the figure needs no
reference (the legs follow the prescribed positions exactly)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from pinid.data.formats import read_recording
from pinid.errors import SpecError
from pinid.simulation.floating_twin import Noise
from pinid.simulation.outputs import simulation_text, write_simulation
from pinid.simulation.twin import simulate, truth_json

NOISE = Noise(1e-4, 0.2, 1.0, 0.1, 0.004, 0.04)


@pytest.fixture(scope="module")
def gait(floating_exo):
    return simulate(floating_exo, "gait", seconds=0.5, seed=4, sample_rate=200, noise=NOISE)


def test_a_floating_run_is_written_by_write_simulation(floating_exo, gait, tmp_path):
    recording, truth = gait
    files = {"truth_path": tmp_path / "t" / "g.json", "figure": tmp_path / "g.png"}
    written = write_simulation(recording, truth, tmp_path / "g.csv", **files)
    assert written == [tmp_path / "g.csv", files["truth_path"], files["figure"]]
    back = read_recording(tmp_path / "g.csv", model=floating_exo)
    assert back.n == recording.n == truth["signals"].n == 101
    for k, v in recording.floating.columns().items():
        np.testing.assert_allclose(back.floating.columns()[k], v, rtol=1e-9, atol=1e-12, err_msg=k)
    stored = json.loads(files["truth_path"].read_text())
    assert "signals" not in stored and stored == json.loads(json.dumps(truth_json(truth)))
    assert files["figure"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = simulation_text(recording, truth, tmp_path / "g.csv", **files)
    assert text == (
        "simulated gait exo_lower_body on a floating base: 101 samples, 0.5 s; recorded 8 joints, base pose (motion capture), "
        "force plate under l_sole, force plate under r_sole, contact phases\n"
        f"wrote {tmp_path / 'g.csv'}, {files['truth_path']}, {files['figure']}"
    )


def test_a_fixed_figure_still_needs_its_reference(gait, tmp_path):
    """Only a floating run draws its figure from the truth alone; a truth without signals draws none."""
    recording, truth = gait
    fixed = dataclasses.replace(recording, floating=None)
    with pytest.raises(SpecError, match=r"^reference: got None, expected the reference positions"):
        write_simulation(fixed, truth, tmp_path / "f.csv", figure=tmp_path / "f.png")
    no_signals = truth_json(truth)
    with pytest.raises(SpecError, match=r'^truth: no "signals", expected the truth dict of simulate'):
        write_simulation(recording, no_signals, tmp_path / "g.csv", figure=tmp_path / "g.png")
    with pytest.raises(SpecError, match=r"^truth: got list, expected the truth dict of simulate"):
        write_simulation(recording, [truth], tmp_path / "g.csv")
    assert not list(tmp_path.iterdir())
