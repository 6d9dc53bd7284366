"""The model-class floor (issue 34, item 4; a lower bound since issue 44): the same model class (rigid bodies
and the same joint terms) fitted in-sample on the validation recordings themselves, its torque error measured
like the validation error (against the torque as recorded, every sample).

It is the **least-squares fit of the torque as recorded** on the base regressor of the validation samples,
every sample and every joint's row (the rows at rest too): that is the exact minimiser, over every parameter
vector of the class, of the pooled squared error the validation figure is made of.  So no method of this class
fitted on any data — ols, wls, a physically consistent sdp that is constrained, any metaheuristic — validates
below it (pooled; a single joint can, since the pooled fit trades joints against each other).  The earlier
floor (OLS as the identification fits: the low-passed torque, the rows at rest left out) was not a bound: on
the KUKA Med7, mext → js, it read 10.51 % against sdp's 10.05 %.

A validation recording need not excite every parameter.  The fit is the minimum-norm least-squares solution
on the column-scaled regressor, whose prediction (the projection of the recorded torque on the columns the
recording excites) is unique whatever the columns it does not: the floor never stops identify, and
:class:`FloorFit` names the base parameters the validation recording does not determine (the columns a
pivoted QR leaves over), which the terminal and the report mention.

With offsets per recording (:mod:`pinid.identification.offsets`), every validation recording gets its own
constant offset per joint in the floor (the validated predictions carry each recording's own offsets)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg

from pinid.data.dataset import Dataset
from pinid.identification.metrics import TorqueMetrics, joint_units, torque_metrics
from pinid.model.base import base_parameters
from pinid.model.robot import RobotModel
from pinid.model.terms import TermSelection
from pinid.problem.problem import base_regressor, check_dataset, recorded_torque

#: Samples per block of the regressor (its tall form never exists whole).
_CHUNK = 20_000
#: A scaled column whose pivoted-QR diagonal is below this fraction of the largest is not determined.
RANK_TOL = 1e-9


@dataclass
class FloorFit:
    """What the floor's fit on the validation recordings determined: ``parameters`` columns (base
    parameters, plus one offset per joint and recording with offsets per recording), ``rank`` of them
    determined, ``undetermined`` the names of the others (empty when the recordings excite every one)."""

    parameters: int
    rank: int
    undetermined: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        """Plain-JSON form (``identification.json``'s ``data.floor``)."""
        return {
            "fitted_by": "least squares of the torque as recorded, every sample of the validation recordings",
            "parameters": self.parameters,
            "rank": self.rank,
            "undetermined": list(self.undetermined),
        }

    def note(self) -> str | None:
        """One line when the validation recordings leave parameters undetermined, else None."""
        if not self.undetermined:
            return None
        more = len(self.undetermined) - 5
        names = ", ".join(self.undetermined[:5]) + (f" and {more} more" if more > 0 else "")
        return (
            f"the validation recording determines {self.rank} of the floor's {self.parameters} parameters "
            f"(not {names}): the floor is the minimum-norm fit of the columns it excites"
        )


def validation_floor(
    model: RobotModel,
    terms: TermSelection,
    datasets: Sequence[Dataset],
    *,
    offsets_per_recording: bool = False,
) -> tuple[TorqueMetrics, FloorFit]:
    """``(metrics, fit)``: per-joint torque metrics [N·m or N] of the least-squares fit of the torque as
    recorded on the (prepared) validation ``datasets``' own base regressor, every sample, against that
    torque (module text); ``offsets_per_recording``: one offset column per joint and recording besides."""
    checked = [check_dataset(ds, model) for ds in datasets]
    base = base_parameters(model, terms)
    nv, nb, nrec = model.nv, base.count, len(checked)
    extra = nv * nrec if offsets_per_recording else 0

    def blocks():  # (recording, slice, W (rows, nb + extra), recorded torque rows)
        for i, ds in enumerate(checked):
            rec = recorded_torque(ds)
            for start in range(0, ds.n, _CHUNK):
                part = ds.select(slice(start, min(ds.n, start + _CHUNK)))
                W = base_regressor(model, terms, base, part)
                if extra:
                    O = np.zeros((W.shape[0], extra))
                    O[:, i * nv : (i + 1) * nv] = np.tile(np.eye(nv), (part.n, 1))
                    W = np.hstack([W, O])
                yield i, slice(start, start + part.n), W, rec[start : start + part.n].reshape(-1)

    # one pass: the compressed form R, c of the tall system (W = Q·R, so ‖W_j‖ = ‖R_j‖: the columns are scaled
    # on R), then one more for the prediction
    R, c = np.zeros((0, nb + extra)), np.zeros(0)
    for _, _, W, y in blocks():
        Q, R = np.linalg.qr(np.vstack([R, W]))
        c = Q.T @ np.concatenate([c, y])
    scale = np.linalg.norm(R, axis=0)
    scale[scale == 0] = 1.0
    R = R / scale
    _, diag, piv = scipy.linalg.qr(R, mode="economic", pivoting=True)
    d = np.abs(np.diag(diag))
    rank = int(np.count_nonzero(d > RANK_TOL * max(d.max(initial=0.0), 1e-300)))
    theta = scipy.linalg.lstsq(R, c, cond=RANK_TOL)[0] / scale
    names = (
        list(base.names)
        + [f"{j}.offset ({Path(str(ds.source)).name})" for ds in checked for j in model.joint_names][:extra]
    )
    undetermined = sorted(names[k] for k in piv[rank:])
    pred = [np.empty((ds.n, nv)) for ds in checked]
    for i, sl, W, _ in blocks():
        pred[i][sl] = (W @ theta).reshape(-1, nv)
    recorded = np.concatenate([recorded_torque(ds) for ds in checked])
    metrics = torque_metrics(recorded, np.concatenate(pred), model.joint_names, units=joint_units(model))
    return metrics, FloorFit(nb + extra, rank, undetermined)
