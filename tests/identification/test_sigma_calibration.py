"""σ at the edges (issue 47 findings 2 and 3): never σ = 0 on a short recording, and σ that covers the truth when
the torque noise is slow (low-passed at 1 Hz, inside the excitation band) as well as when it is white."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from pinid.data.filters import butter_sos, filtfilt_sos
from pinid.errors import DataWarning
from pinid.identification.run import identify
from pinid.identification.study import Study
from pinid.model.robot import RobotModel
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import simulate


def _twin(seconds: float, seed: int, **options):
    model = RobotModel.from_urdf("exo_leg")
    ds, truth = simulate(model, load_trajectory("exo_leg", model), seconds=seconds, seed=seed, **options)
    return model, ds, truth


def _first(ds, n: int):
    return dataclasses.replace(ds, t=ds.t[:n], q=ds.q[:n], tau=ds.tau[:n])


@pytest.mark.filterwarnings("ignore::pinid.errors.DataWarning")
def test_short_recording_never_gives_sigma_zero():
    """Reproducer 06 (round 5): 0.7 s and 0.8 s of a 1 kHz twin (62 and 162 samples after the trim) printed
    σ = 0 and |error|/σ up to 42.  Now their residuals' lag spans most of the recording: no σ (NaN, "—") and a
    warning naming why; 3 s keeps an honest σ."""
    model, ds, truth = _twin(10.0, 1)
    for n in (700, 800):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ident = identify(Study(model, _first(ds, n)), methods="ols,wls", truth=truth, complete=False)
        assert any("recording too short for the standard deviations" in str(w.message) for w in caught), n
        assert any(issubclass(w.category, DataWarning) for w in caught)
        for r in ident:
            assert not np.any(np.asarray(r.std) == 0.0), (n, r.method)
            assert np.all(np.isnan(r.std)), (n, r.method)
    ident = identify(Study(model, _first(ds, 3000)), methods="ols,wls", truth=truth, complete=False)
    for r in ident:
        z = np.array([abs(r.truth_error["error"][k]) for k in r.base_names]) / np.asarray(r.std)
        assert np.all(np.asarray(r.std) > 0) and np.median(z) < 1.5, (r.method, np.median(z))


def _coverage(kind: str, seeds: int, methods=("ols", "wls")) -> dict[str, float]:
    """Share of the true base parameters within ±2σ over ``seeds`` noise draws added to one noise-free 20 s twin
    (1 kHz): white noise or noise low-passed at ``kind`` Hz (4th-order Butterworth, zero phase), 1 % of each
    joint's peak torque either way."""
    model, ds, truth = _twin(20.0, 1, torque_noise=0.0)
    level = 0.01 * np.abs(ds.tau).max(axis=0)
    hits = {m: [] for m in methods}
    for s in range(seeds):
        noise = np.random.default_rng(100 + s).normal(size=ds.tau.shape)
        if kind != "white":
            noise = filtfilt_sos(butter_sos(4, float(kind), 1000.0), noise, 3000)
            noise /= noise.std(axis=0)
        noisy = dataclasses.replace(ds, tau=ds.tau + noise * level)
        ident = identify(Study(model, noisy), methods=list(methods), truth=truth, complete=False)
        for m in methods:
            r = ident[m]
            err = np.array([r.truth_error["error"][k] for k in r.base_names])
            hits[m] += list(np.abs(err) <= 2 * np.asarray(r.std))
    return {m: 100 * float(np.mean(h)) for m, h in hits.items()}


@pytest.mark.slow  # about 80 s: 2 × 40 identifications of a 20 s recording
@pytest.mark.filterwarnings("ignore::pinid.errors.DataWarning")
def test_sigma_covers_the_truth_for_white_and_slow_noise():
    """Issue 47 finding 3: with noise low-passed at 1 Hz the Andrews lag alone left 86 % (ols) / 82.5 % (wls)
    of the truths within ±2σ; the kernel-bias lag and the fixed-b factor bring it to ≥ 90 %, and white noise
    stays between 90 % and 99.5 % (docs/identification.md, "How σ is computed")."""
    white = _coverage("white", 40)
    slow = _coverage("1", 40)
    for m in white:
        assert 90.0 <= white[m] <= 99.5, (m, white)
        assert slow[m] >= 90.0, (m, slow)
