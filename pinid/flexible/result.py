"""The result of an output-error fit (:func:`pinid.flexible.output_error.fit_output_error`): fitted values,
cost curve, time, angle errors, and the error against the truth when it is known.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pinid.errors import DataError, SpecError
from pinid.io import jsonable, read_bounded_file
from pinid.result_protocol import ResultProtocol


# ====================================================================== results
@dataclass
class OutputErrorResult(ResultProtocol):
    """One fit: fitted values, cost and its curve, time, and the error against the truth when it is known.

    ``history``: ``[[simulations, best cost], ...]``; ``nfev``: parameter sets simulated; ``seconds``: wall
    time of the fit; ``metrics``: angle errors per joint at the fit [rad]; ``rel_error``: (fitted − truth)/|truth|.
    """

    method: str
    model_kind: str
    cost_kind: str
    names: list[str]
    x: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    cost: float
    history: list
    nfev: int
    seconds: float
    message: str
    step: float
    metrics: dict
    truth: dict | None = None
    extra: dict = field(default_factory=dict)

    PLOTS = {"cost": True, "errors": True}

    @property
    def values(self) -> dict[str, float]:
        """Fitted values by name [SI]."""
        return {n: float(v) for n, v in zip(self.names, self.x)}

    @property
    def rel_error(self) -> dict[str, float] | None:
        """Relative error against the truth per parameter, (fitted − truth)/|truth| (a fraction, not %);
        None without a truth."""
        if not self.truth:
            return None
        out = {}
        for n, v in zip(self.names, self.x):
            if n in self.truth:
                t = self.truth[n]
                out[n] = float((v - t) / abs(t)) if t != 0 else float("inf") if v != 0 else 0.0
        return out

    @property
    def rms(self) -> float:
        """RMS angle error over every compared angle [rad]."""
        return float(np.sqrt(np.mean([m["rms"] ** 2 for m in self.metrics.values()])))

    def to_dict(self) -> dict:
        """Plain-JSON form (the file ``pinid flex fit`` writes)."""
        return jsonable(
            {
                "method": self.method,
                "model": self.model_kind,
                "cost_kind": self.cost_kind,
                "cost": self.cost,
                "values": self.values,
                "bounds": {n: [float(a), float(b)] for n, a, b in zip(self.names, self.lower, self.upper)},
                "truth": self.truth,
                "rel_error": self.rel_error,
                "metrics": self.metrics,
                "rms": self.rms,
                "history": self.history,
                "nfev": self.nfev,
                "seconds": self.seconds,
                "message": self.message,
                "step": self.step,
                **self.extra,
            }
        )

    @classmethod
    def from_dict(cls, d: dict) -> "OutputErrorResult":
        """Rebuild from :meth:`to_dict`'s output."""
        names = list(d["values"])
        known = {
            "method",
            "model",
            "cost_kind",
            "cost",
            "values",
            "bounds",
            "truth",
            "rel_error",
            "metrics",
            "rms",
            "history",
            "nfev",
            "seconds",
            "message",
            "step",
        }
        return cls(
            d["method"],
            d["model"],
            d["cost_kind"],
            names,
            np.array([d["values"][n] for n in names]),
            np.array([d["bounds"][n][0] for n in names]),
            np.array([d["bounds"][n][1] for n in names]),
            float(d["cost"]),
            d["history"],
            int(d["nfev"]),
            float(d["seconds"]),
            d["message"],
            float(d["step"]),
            d["metrics"],
            d.get("truth"),
            {k: v for k, v in d.items() if k not in known},
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> "OutputErrorResult":
        """Read a file written by :meth:`save`."""
        p = Path(path)
        try:
            return cls.from_dict(json.loads(read_bounded_file(p, "output-error result (JSON)", error=DataError)))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise DataError(f"{p}: not an output-error result ({exc})") from None

    def _plot(self, kind: str, ax):
        """``"cost"``: the best cost against the number of simulated parameter sets (log-log,
        :func:`pinid.report.plot_flexible.plot_cost_curves`); ``"errors"``: every fitted parameter's
        relative error against the truth [%] (:func:`~pinid.report.plot_flexible.plot_parameter_errors`,
        needs a truth)."""
        from pinid.report.plot_flexible import plot_cost_curves, plot_parameter_errors  # matplotlib: on use

        if kind == "cost":
            title = f"output-error fit ({self.method}, {self.model_kind} model, {self.cost_kind} cost)"
            return plot_cost_curves({self.method: self.history}, ax=ax, title=title)
        if self.rel_error is None:
            raise SpecError("kind: no 'errors' figure without a truth (the fit's truth is unknown)")
        title = f"{self.method}: fitted parameters against the truth"
        return plot_parameter_errors({self.method: self.rel_error}, ax=ax, title=title)

    def text(self) -> str:
        """The fitted values against the truth and the bounds (:meth:`table`), then cost, RMS and time."""
        from pinid.report.text import text_table

        head = ["parameter", "fitted", "truth", "error %", "lower", "upper"]
        return (
            text_table(head, self.table())
            + f"\n{self.method} ({self.model_kind} model, {self.cost_kind} cost): cost {self.cost:.6g}, "
            f"angle RMS {self.rms:.3g} rad, {self.nfev} simulations, {self.seconds:.3g} s; {self.message}"
        )

    def table(self) -> list[list[str]]:
        """Rows ``[name, fitted, truth, error %, lower, upper]`` as text."""
        rel = self.rel_error or {}
        rows = []
        for n, v, lo, hi in zip(self.names, self.x, self.lower, self.upper):
            t = (self.truth or {}).get(n)
            rows.append(
                [
                    n,
                    f"{v:.6g}",
                    "-" if t is None else f"{t:.6g}",
                    "-" if n not in rel else f"{100 * rel[n]:+.3f}",
                    f"{lo:.4g}",
                    f"{hi:.4g}",
                ]
            )
        return rows
