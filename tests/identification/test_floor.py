"""The model-class floor (pinid.identification.floor, issue 44): a lower bound of every method's pooled validation
error, and it never stops identify when the validation recording does not excite every parameter."""

from __future__ import annotations

import numpy as np
import pytest

from pinid import TermSelection
from pinid.data.dataset import Dataset
from pinid.identification.floor import validation_floor
from pinid.identification.outputs import identification_text
from pinid.identification.run import identify
from pinid.identification.study import Study

from test_identification import truth_model, twin


def test_the_floor_is_below_every_method_on_data_the_class_does_not_fit():
    """The class misses the truth (an offset and armature not in fc,fv, a delay-like filter on the torque):
    every method's pooled validation error, sdp's constrained one included, is at or above the floor, which
    is the least-squares fit of the recorded torque itself (checked against numpy's lstsq of the whole
    regressor)."""
    model = truth_model("exo_leg")
    train, valid = twin(model, seconds=10, seed=0, noise=0.05), twin(model, seconds=8, seed=3, noise=0.05)

    def distort(ds):
        tau = ds.tau + np.array([0.6, -0.4]) + 0.3 * np.tanh(ds.ddq)
        return Dataset(ds.t, ds.q, ds.joints, dq=ds.dq, ddq=ds.ddq, tau=tau, source=ds.source)

    ident = identify(Study(model, distort(train), validate=distort(valid), terms="fc,fv"), "ols,wls,sdp")
    for r in ident:
        assert ident.floor.all["rms"] <= r.validation.all["rms"] + 1e-12, r.method
    from pinid.model.base import base_parameters
    from pinid.problem.problem import base_regressor

    terms = TermSelection()
    W = base_regressor(model, terms, base_parameters(model, terms), distort(valid))
    y = distort(valid).tau.reshape(-1)
    e = W @ np.linalg.lstsq(W, y, rcond=None)[0] - y
    assert ident.floor.all["rms"] == pytest.approx(np.sqrt(np.mean(e**2)), rel=1e-9)


def test_a_validation_recording_that_excites_too_little_gives_a_floor_and_a_note():
    """Issue 44 item 1: the knee at rest in the validation recording (its friction and inertia not excited):
    identify does not stop; the floor is the minimum-norm fit and names what the recording did not determine."""
    model = truth_model("exo_leg")
    train = twin(model, seconds=10, seed=0, noise=0.02)
    v = twin(model, seconds=6, seed=4, noise=0.02)
    q, dq, ddq = v.q.copy(), v.dq.copy(), v.ddq.copy()
    q[:, 1], dq[:, 1], ddq[:, 1] = 0.3, 0.0, 0.0
    tau = model.rnea(q, dq, ddq) + model.coulomb * np.sign(dq) + model.viscous * dq
    still = Dataset(v.t, q, v.joints, dq=dq, ddq=ddq, tau=tau, source="still_knee")
    metrics, fit = validation_floor(model, TermSelection(), [still])
    assert fit.rank < fit.parameters
    assert any(n.startswith("knee.") for n in fit.undetermined)
    assert np.isfinite(metrics.all["rms"])
    ident = identify(Study(model, train, validate=still, terms="fc,fv"), "ols,sdp")
    assert ident.floor is not None and ident.data["floor"]["undetermined"] == fit.undetermined
    for r in ident:
        assert ident.floor.all["rms"] <= r.validation.all["rms"] + 1e-12
    text = " ".join(identification_text(ident).split())
    assert f"the validation recording determines {fit.rank} of {fit.parameters} parameters" in text


def test_the_floor_with_offsets_per_recording_has_one_offset_per_validation_recording():
    """Offsets per recording: each validation recording gets its own offsets in the floor too."""
    model = truth_model("exo_leg")
    a, b = twin(model, seconds=6, seed=5), twin(model, seconds=6, seed=6)
    b = Dataset(b.t, b.q, b.joints, dq=b.dq, ddq=b.ddq, tau=b.tau + np.array([0.5, -0.3]), source="b")
    plain, _ = validation_floor(model, TermSelection(), [a, b])
    metrics, fit = validation_floor(model, TermSelection(), [a, b], offsets_per_recording=True)
    assert fit.parameters == fit.rank and metrics.all["rms"] < 1e-9 < plain.all["rms"]
