"""Memory checks (pinid/memory.py): a one-line warning near the limit, an error beyond it."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import load

from pinid.data.dataset import Dataset
from pinid.errors import SpecError


def test_memory_warning_for_large_recordings(monkeypatch):
    import pinid.memory as memory
    from pinid.errors import DataWarning
    from pinid.identification.recording_checks import bytes_per_sample, warn_if_large_recordings
    from pinid.model.terms import TermSelection

    leg = load("exo_leg")
    per = bytes_per_sample(leg, TermSelection())
    assert 100 < per < 200  # measured 103 B per sample, 132 at 1e7 (docs/benchmarks.md, Memory)
    t = np.arange(50_000) / 1000.0
    ds = Dataset(t, np.zeros((len(t), 2)), leg.joint_names, tau=np.ones((len(t), 2)))
    monkeypatch.setattr(memory, "available_bytes", lambda: int(1.5 * per * len(t)))  # needs 2/3 of it
    with pytest.warns(DataWarning, match=r"50,000 training samples of exo_leg: needs about .* more than half"):
        assert warn_if_large_recordings(leg, TermSelection(), [ds])
    monkeypatch.setattr(memory, "available_bytes", lambda: int(3 * per * len(t)))  # a third: no warning
    assert not warn_if_large_recordings(leg, TermSelection(), [ds])
    monkeypatch.setattr(memory, "available_bytes", lambda: int(0.5 * per * len(t)))  # more than there is
    with pytest.raises(SpecError, match="more than the .* available"):
        memory.check_fits(per * len(t), "recording", per_item=per)
