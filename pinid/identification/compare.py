"""Compare estimators honestly: the same recordings, held-out validation, several seeds, the truth if known.

:func:`compare` runs chosen methods of :data:`pinid.estimators.ESTIMATORS` (default: all that do not simulate) on the same
training recordings — the deterministic ones (least squares, WLS, the LMI method, RLS) once, the
metaheuristics once per seed — and measures for every run:

* the **training costs** of the fit: ½·Σr² (seed 001's fitness, Eq. (22)) and Σ|r| (seed 000's), next to
  their global minima on the same rows — least squares for the first (no
  method can beat it there), the least-absolute-deviations fit (:func:`lad`) for the second;
* the **validation torque error** on held-out recordings, per joint: mean ± std of |e| (seed 000's
  Figs. 10 and 13), RMS and relative RMS — against the torque as recorded (``validation``), and against
  the torque after pinid's own low-pass (``validation_filtered``, which moves with the cut-off);
* the **identified values** and, when the recordings come from the twin, their **error against the
  true parameters**: ``100·|x − x_true| / max(|x_true|, 1 % of the parameter's natural magnitude)``;
* the **convergence curve** (best fitness per iteration, seed 000 Figs. 8 and 11, seed 001 Fig. 3b), the
  **time**, and whether a physically consistent standard set exists behind the result.

With ``segmental`` (seed 000 §3.1, :mod:`pinid.identification.segmental`) every method runs in the two stages.

:class:`Comparison` holds the runs, summarises them over seeds (mean and standard deviation of each
measure across runs), prints a table and saves/loads JSON; :mod:`pinid.report.plot_compare` draws them;
``pinid compare`` is the command.
"""

from __future__ import annotations

from functools import partial
import os
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from collections.abc import Mapping, Sequence

import numpy as np

from pinid.errors import SpecError
from pinid.estimators import ESTIMATORS, Metaheuristic, quick_methods
from pinid.estimators.metaheuristic import (
    SearchBox,
    cached_lad,
    least_absolute_deviations,
    least_squares,
    natural_scale,
    training_costs,
)
from pinid.identification.metrics import error_metrics, joint_units, torque_metrics
from pinid.problem.problem import (
    IdentificationProblem,
    base_regressor,
    check_dataset,
    predict_torque,
    recorded_torque,
)
from pinid.identification.run import (
    check_options,
    check_recordings,
    parse_methods,
    setup,
    EXPECTED_STUDY,
)
from pinid.identification.runner import Fit, run_jobs
from pinid.identification.study import Study
from pinid.identification.truth import true_base
from pinid.io import jsonable, read_json
from pinid.model.terms import as_terms, stribeck_settings
from pinid.model.serialize import robot_to_dict
from pinid.checks import array_like
from pinid.parallel import check_workers
from pinid.result_protocol import ResultProtocol

#: Methods that give the same result whatever the seed (run once): the registry's ``deterministic`` ones.
DETERMINISTIC: tuple[str, ...] = tuple(m for m, cls in ESTIMATORS.items() if cls.deterministic)
#: Default number of seeds for the metaheuristics.
DEFAULT_SEEDS = 5


# ============================================================================================ references
def lad(problem, iterations: int = 200, tol: float = 1e-12) -> np.ndarray:
    """Least-absolute-deviations base parameters, the global minimum of seed 000's fitness Σ|r|
    (:func:`pinid.estimators.metaheuristic.least_absolute_deviations`)."""
    if not hasattr(problem, "compressed"):
        raise SpecError(f"problem: got {type(problem).__name__}, expected an IdentificationProblem")
    return least_absolute_deviations(problem, iterations, tol)


def references(problem) -> dict:
    """The global minima of both training costs on the problem's rows and least squares' Σ|r|:
    ``{"sse", "sae", "sae_ls"}``."""
    if not hasattr(problem, "compressed"):
        raise SpecError(f"problem: got {type(problem).__name__}, expected an IdentificationProblem")
    x_ls = least_squares(problem)
    x_lad = cached_lad(problem)  # kept on the problem: the Σ|r| metaheuristics of every seed reuse it
    ls = training_costs(problem, x_ls)
    return {"sse": ls["sse"], "sae": training_costs(problem, x_lad)["sae"], "sae_ls": ls["sae"]}


def _study_references(st) -> dict:
    """A comparison's references (:func:`references`): of the problem, and of the segmental strategy's first
    stage (the second stage's minimum depends on the first stage's values: per run, in ``run.info``)."""
    out = {"main": references(st.problem)}
    if st.segmental is not None:
        out["first"] = references(st.segmental.first_problem)
    return out


# ============================================================================================ results
@dataclass
class Run:
    """One method's run with one seed (``seed`` None for the deterministic methods)."""

    method: str
    seed: int | None
    base: np.ndarray
    seconds: float
    train: dict
    costs: dict
    validation: dict
    parameter_error: dict | None
    history: list | None
    history_first: list | None
    physically_consistent: bool
    standard_source: str
    info: dict = field(default_factory=dict)
    parameter_error_abs: dict | None = None
    train_filtered: dict | None = None
    validation_filtered: dict | None = None

    def to_dict(self, names: list[str]) -> dict:
        """Plain-JSON form, parameters named by ``names``."""
        return {
            "method": self.method,
            "seed": self.seed,
            "base": dict(zip(names, map(float, self.base))),
            "seconds": float(self.seconds),
            "train": self.train,
            "costs": self.costs,
            "validation": self.validation,
            "train_filtered": self.train_filtered,
            "validation_filtered": self.validation_filtered,
            "parameter_error_percent": self.parameter_error,
            "parameter_error_abs": self.parameter_error_abs,
            "history": self.history,
            "history_first": self.history_first,
            "physically_consistent": bool(self.physically_consistent),
            "standard_source": self.standard_source,
            "info": self.info,
        }

    @classmethod
    def from_dict(cls, d: dict, names: list[str]) -> "Run":
        """Rebuild from :meth:`to_dict`'s output."""
        return cls(
            d["method"],
            d["seed"],
            np.array([float(d["base"][n]) for n in names]),
            float(d["seconds"]),
            d["train"],
            d["costs"],
            d["validation"],
            d.get("parameter_error_percent"),
            d.get("history"),
            d.get("history_first"),
            bool(d["physically_consistent"]),
            d.get("standard_source", ""),
            d.get("info") or {},
            d.get("parameter_error_abs"),
            d.get("train_filtered"),
            d.get("validation_filtered"),
        )


def _mean_std(values) -> tuple[float, float]:
    a = np.array([np.nan if v is None else float(v) for v in values], dtype=float)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return float("nan"), float("nan")
    return float(a.mean()), float(a.std())


@dataclass
class Comparison(ResultProtocol):
    """Runs of several methods on the same data (what :func:`compare` returns); JSON with save/load.

    ``runs[method]`` is a list of :class:`Run`; ``reference`` the global minima of both training costs
    and the least-squares Σ|r| (``{"main": {"sse": …, "sae": …, "sae_ls": …}}``, plus ``"first"`` for the
    first stage of a segmental run);
    ``truth`` the true base parameters when known; ``nominal`` the URDF's.
    """

    robot: dict
    base_names: list[str]
    nominal: np.ndarray
    truth: np.ndarray | None
    methods: list[str]
    seeds: list[int]
    runs: dict[str, list[Run]]
    reference: dict
    data: dict
    validation_sources: dict[str, list[str]]
    settings: dict = field(default_factory=dict)
    segmental: dict | None = None
    seconds: float = 0.0

    PLOTS = {"errors": False, "convergence": True, "parameters": True}
    #: ``"errors:<label>"``: validation set ``label``; ``"convergence:first"``: a segmental run's first stage.
    PLOT_ARGUMENTS = ("errors", "convergence")
    FILE_KIND = "comparison"

    # ---------------------------------------------------------------- summaries
    @property
    def joints(self) -> list[str]:
        """Names of the robot's joints."""
        return list(self.robot.get("joints", []))

    def summary(self) -> dict:
        """Per method: every measure as ``[mean, std]`` over its runs (a single run has std 0)."""
        out = {}
        for m, runs in self.runs.items():
            s: dict = {"runs": len(runs)}
            for cost in ("sse", "sae"):
                s[f"train_{cost}"] = _mean_std(r.costs[cost] for r in runs)
            s["train_rms"] = _mean_std(r.train["all"]["rms"] for r in runs)
            s["train_rms_filtered"] = _mean_std((r.train_filtered or r.train)["all"]["rms"] for r in runs)
            s["seconds"] = _mean_std(r.seconds for r in runs)
            s["consistent"] = sum(bool(r.physically_consistent) for r in runs)
            val = {}
            for label in self.validation_sources:
                per = {}
                for j in self.joints + ["all"]:
                    pick = lambda r, k, label=label, j=j: (
                        r.validation[label]["all"] if j == "all" else r.validation[label]["per_joint"][j]
                    )[k]
                    per[j] = {
                        k: _mean_std(pick(r, k) for r in runs)
                        for k in ("mean_abs", "std_abs", "rms", "rel_rms_percent")
                    }
                val[label] = per
            s["validation"] = val
            s["validation_filtered"] = {
                label: _mean_std((r.validation_filtered or r.validation)[label]["all"]["rel_rms_percent"] for r in runs)
                for label in self.validation_sources
            }
            s["base"] = {n: _mean_std(r.base[i] for r in runs) for i, n in enumerate(self.base_names)}
            if self.truth is not None:
                s["parameter_error_percent"] = {
                    n: _mean_std(r.parameter_error.get(n) for r in runs) for n in self.base_names
                }
                s["parameter_error_max_percent"] = _mean_std(
                    max(r.parameter_error.values(), default=None) for r in runs
                )
                s["parameter_error_median_percent"] = _mean_std(
                    float(np.median(list(r.parameter_error.values()))) if r.parameter_error else None for r in runs
                )
                zero = self.zero_truth()
                s["parameter_error_abs_max_zero_truth"] = (
                    _mean_std(max(r.parameter_error_abs[n] for n in zero) for r in runs) if zero else None
                )
            out[m] = s
        return out

    def zero_truth(self) -> list[str]:
        """The base parameters whose true value is 0 (their errors are absolute, not relative)."""
        if self.truth is None or not self.runs:
            return []
        run = next(r for runs in self.runs.values() for r in runs)
        return [n for n in self.base_names if n not in (run.parameter_error or {})]

    def table(self) -> str:
        """Text tables (each ≤ 120 characters wide, split by columns when needed): the fit (training costs,
        error against the truth, consistency, time), then the validation error per joint."""
        from pinid.report.text import text_table

        summ = self.summary()
        ref = self.reference.get("main", {})

        def ms(v, fmt=".4g"):
            if v is None or not np.isfinite(v[0]):
                return "—"
            m, s = v
            return f"{m:{fmt}}" if s == 0 else f"{m:{fmt}} ± {s:.2g}"

        zero = self.zero_truth()
        head = ["method", "runs", "½Σr² above min %", "Σ|r| above min %"]
        if self.truth is not None:
            head += ["max err % (truth≠0)", "median %"] + (["max |err| (truth=0)"] if zero else [])
        head += ["consistent", "time [s]"]
        rows = []
        for m, s in summ.items():
            row = [m, str(s["runs"])]
            for cost in ("sse", "sae"):
                lo = ref.get(cost)
                mean, sd = s[f"train_{cost}"]
                row.append(
                    ms((100.0 * (mean / lo - 1.0), 100.0 * sd / lo), ".3g")
                    if lo and np.isfinite(mean)
                    else ms((mean, sd))
                )
            if self.truth is not None:
                row += [ms(s["parameter_error_max_percent"], ".3g"), ms(s["parameter_error_median_percent"], ".3g")]
                if zero:
                    row.append(ms(s["parameter_error_abs_max_zero_truth"], ".3g"))
            row += [f"{s['consistent']}/{s['runs']}", ms(s["seconds"], ".3g")]
            rows.append(row)
        lines = [
            f"training cost minima on the same rows: ½Σr² (least squares) {ref.get('sse', float('nan')):.6g}, "
            f"Σ|r| (least absolute deviations) {ref.get('sae', float('nan')):.6g}",
            "",
            text_table(head, rows),
        ]
        for label in self.validation_sources:
            head = ["method", "rel RMS raw %", "rel RMS filtered %"] + [f"{j} |e| raw [N·m]" for j in self.joints]
            rows = []
            for m, s in summ.items():
                v = s["validation"][label]
                rows.append(
                    [m, ms(v["all"]["rel_rms_percent"], ".3g"), ms(s["validation_filtered"][label], ".3g")]
                    + [f"{v[j]['mean_abs'][0]:.4g} ± {v[j]['std_abs'][0]:.3g}" for j in self.joints]
                )
            lines += [
                "",
                f"{label}: relative RMS raw (as recorded) and filtered (low-passed); mean ± std of |e| raw per joint",
                text_table(head, rows),
            ]
        notes = [
            "… above min %: how far the fit's training cost (½Σr² or Σ|r|) is above the global minimum of that "
            "cost on the same rows (0 for least squares on ½Σr²: nothing can be below it).",
            "|e|: mean ± std of the absolute validation torque error within a run (seed 000's format), averaged "
            "over the runs; the spread over the seeds is in comparison.json.",
            "raw: against the torque as recorded, the fixed yardstick; filtered: against the torque after pinid's "
            "own low-pass, which moves with --cutoff (docs/identification.md, The yardstick).",
        ]
        if self.truth is not None:
            notes.append(
                "err %: |x − x_true| / |x_true| [%] over the base parameters whose truth is not 0"
                + (
                    f"; where it is 0 ({', '.join(zero)}) the absolute error |x| in the parameter's unit."
                    if zero
                    else "."
                )
            )
        import textwrap

        lines.append("")
        lines += [w for n in notes for w in textwrap.wrap(n, 118, subsequent_indent="  ")]
        return "\n".join(lines)

    def values_table(self) -> str:
        """Identified base parameters (mean over runs) per method, with the truth and the URDF's values;
        split by columns to fit 120 characters."""
        from pinid.report.text import text_table

        summ = self.summary()
        head = ["parameter", "URDF"] + (["truth"] if self.truth is not None else []) + list(summ)
        rows = []
        for i, n in enumerate(self.base_names):
            row = [n, f"{self.nominal[i]:.5g}"] + ([f"{self.truth[i]:.5g}"] if self.truth is not None else [])
            for s in summ.values():
                mean, sd = s["base"][n]
                row.append(f"{mean:.5g}" + (f" ± {sd:.2g}" if sd > 0 else ""))
            rows.append(row)
        return text_table(head, rows)

    # ---------------------------------------------------------------- JSON
    def _plot(self, kind: str, ax):
        """One figure of ``pinid compare`` (:mod:`pinid.report.plot_compare`), the same drawing and title.

        ``"errors"`` (the absolute validation torque error per joint and method, mean and [p5, p95] over
        the runs, on the first validation set; ``"errors:<label>"``: on set ``label``), ``"convergence"``
        (the metaheuristics' best fitness per iteration; ``"convergence:first"``: a segmental run's first
        stage) or ``"parameters"`` (the base parameters' error against the truth [%]).
        """
        from pinid.report import plot_compare  # loads the report (matplotlib on drawing): on use only

        figure, _, arg = kind.partition(":")
        if figure == "errors":
            if not self.validation_sources:
                raise SpecError("kind: no 'errors' figure, the comparison has no validation recordings")
            if arg and arg not in self.validation_sources:
                raise SpecError(f"kind: no validation set {arg!r} (sets: {', '.join(self.validation_sources)})")
            return plot_compare.validation_errors(self, arg or None)
        if figure == "parameters":
            if self.truth is None:
                raise SpecError("kind: no 'parameters' figure, the comparison has no true parameters")
            return plot_compare.parameter_errors(self, ax=ax, title="error against the true parameters")
        if arg not in ("", "main", "first"):
            raise SpecError(f"kind: got {kind!r}, expected 'convergence' or 'convergence:first'")
        stage = "first" if arg == "first" else "main"
        second = " (second stage)" if self.segmental else ""
        title = "convergence (first stage)" if stage == "first" else "convergence" + second
        return plot_compare.convergence(self, stage=stage, ax=ax, title=title)

    def text(self) -> str:
        """What ``pinid compare`` prints (:meth:`table`)."""
        return self.table()

    def to_dict(self) -> dict:
        """Plain-JSON form (``comparison.json``)."""
        from pinid import __version__  # the package's own attribute: set after its submodules load

        return jsonable(
            {
                "pinid_version": __version__,
                "robot": self.robot,
                "base_names": self.base_names,
                "nominal": self.nominal.tolist(),
                "truth": None if self.truth is None else self.truth.tolist(),
                "methods": self.methods,
                "seeds": self.seeds,
                "reference": self.reference,
                "data": self.data,
                "validation_sources": self.validation_sources,
                "settings": self.settings,
                "segmental": self.segmental,
                "seconds": self.seconds,
                "summary": self.summary(),
                "runs": {m: [r.to_dict(self.base_names) for r in runs] for m, runs in self.runs.items()},
            }
        )

    @classmethod
    def from_dict(cls, d: dict) -> "Comparison":
        """Rebuild from :meth:`to_dict`'s output."""
        names = list(d["base_names"])
        nan = lambda v: float("nan") if v is None else float(v)
        return cls(
            robot=d["robot"],
            base_names=names,
            nominal=np.array([nan(v) for v in d["nominal"]]),
            truth=None if d.get("truth") is None else np.array([nan(v) for v in d["truth"]]),
            methods=list(d["methods"]),
            seeds=list(d["seeds"]),
            runs={m: [Run.from_dict(r, names) for r in runs] for m, runs in d["runs"].items()},
            reference=d.get("reference") or {},
            data=d.get("data") or {},
            validation_sources=d.get("validation_sources") or {},
            settings=d.get("settings") or {},
            segmental=d.get("segmental"),
            seconds=float(d.get("seconds") or 0.0),
        )

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Comparison":
        """Read a file written by :meth:`save` (or ``pinid compare``)."""
        d = read_json(path, "comparison")
        if "runs" not in d or "base_names" not in d:
            raise SpecError(f"{path}: not a comparison file (no 'runs' or 'base_names')")
        return cls.from_dict(d)


# ============================================================================================ the runner
def _truth_vector(truth, names: list[str], st) -> np.ndarray | None:
    """The true base parameters in ``names``' order from an array, ``{name: value}``, a truth dict of
    :func:`pinid.simulation.twin.simulate` or the path of its JSON.  A truth whose own base parameters are
    not this run's (other joint terms, fit joints or payloads change the base map) is mapped from its
    standard parameters through the run's base map (``st``: the run's setup), as ``pinid identify --truth``
    does."""
    if truth is None:
        return None
    if isinstance(truth, (str, os.PathLike)):
        p = Path(truth)
        truth = read_json(p, "truth")
    if isinstance(truth, Mapping) and isinstance(truth.get("standard"), Mapping):
        b = truth.get("base")
        if not (isinstance(b, Mapping) and isinstance(b.get("names"), list) and set(names) <= set(b["names"])):
            return true_base(truth, st.model, st.terms, st.base)
    if isinstance(truth, Mapping) and "base" in truth and isinstance(truth["base"], Mapping):
        b = truth["base"]
        if not (isinstance(b.get("names"), list) and isinstance(b.get("values"), list)):
            raise SpecError("truth: 'base' must hold 'names' and 'values' lists, as pinid simulate's truth JSON does")
        truth = dict(zip(b["names"], b["values"]))
    if isinstance(truth, Mapping):
        missing = [n for n in names if n not in truth]
        if missing:
            raise SpecError(
                f"truth: no value for base parameter(s) {', '.join(missing)} (has {', '.join(truth)}); "
                "were the recordings simulated with the same joint terms?"
            )
        return np.array([float(truth[n]) for n in names])
    a = np.asarray(truth, dtype=float).reshape(-1)
    if a.shape != (len(names),):
        raise SpecError(f"truth: {a.size} values, expected {len(names)} base parameters ({', '.join(names)})")
    return a


def _parameter_errors(x: np.ndarray, truth: np.ndarray, scale: np.ndarray, names: list[str]) -> tuple[dict, dict]:
    """Errors against the truth: ``({name: 100·|x − x_true| / max(|x_true|, 0.01·scale)} [%] for the
    parameters whose truth is not zero, {name: |x − x_true|} [the parameter's unit] for all})``.

    A relative error is meaningless where the truth is 0 (|x_true| ≤ 1e-9·scale): there only the absolute
    error is reported.
    """
    array_like(x, "x")
    err = np.abs(x - truth)
    nonzero = np.abs(truth) > 1e-9 * scale
    rel = 100.0 * err / np.maximum(np.abs(truth), 0.01 * scale)
    return ({n: float(e) for n, e, nz in zip(names, rel, nonzero) if nz}, dict(zip(names, map(float, err))))


def compare(
    study: Study,
    methods: Sequence[str] | str | None = None,
    seeds: int | Sequence[int] = DEFAULT_SEEDS,
    *,
    truth=None,
    options: Mapping[str, Mapping] | None = None,
    metaheuristic: Mapping | None = None,
    complete: bool = True,
    show_progress: bool | None = False,
    workers: int | None = 1,
    scheduler=None,
) -> Comparison:
    """Run ``methods`` on the same recordings of ``study`` (a :class:`~pinid.identification.study.Study`) with
    several seeds; validate; compare (module text).

    ``study.model``: the robot with its **nominal** (URDF/CAD) parameters — the metaheuristics' default box is
    built around them, so on the twin pass the CAD model, not the truth.  ``study.data``: training
    recordings (Datasets or paths).  ``study.validate``: held-out recordings — a list, or ``{label: recordings}``
    to report several validation sets separately.  ``methods``: names of
    :data:`pinid.estimators.ESTIMATORS` (default: those that do not simulate the robot, :func:`~pinid.estimators.quick_methods`).  ``seeds``: a number of seeds (0, 1, …) or the
    seeds themselves, for the metaheuristics; deterministic methods run once.  ``truth``: true base
    parameters (array, dict, a truth dict of :func:`pinid.simulation.twin.simulate` or its JSON path).
    ``options``: settings per method; ``metaheuristic``: settings for every metaheuristic (``population``,
    ``iterations``, ``fitness``, ``box`` …; ``options`` override them).  ``study.segmental``:
    ``{"first": recordings, "joints": ("knee",)}`` runs seed 000's segmental strategy (``data`` is then
    the recording with every joint moving).  The study's other fields (without drive gains: a study with
    ``payload`` is refused) and ``complete``: as in :func:`pinid.identification.run.identify`.  ``workers``: local processes for the
    runs (None: every core); ``scheduler``: a Dask scheduler's address (or ``distributed.Client``) to run
    them on a cluster instead (:mod:`pinid.parallel`).  The numbers do not depend on either.  A floating-base
    ``study.model`` is compared on its base and joint rows (``study.floating``: as in :func:`~pinid.identification.run.identify`;
    ``truth``: the truth of ``pinid simulate --base floating``).
    """
    t_start = time.perf_counter()
    if not isinstance(study, Study):
        raise SpecError(f"compare: got {type(study).__name__}, {EXPECTED_STUDY}")
    model, rest_velocity, segmental, floating = study.model, study.rest_velocity, study.segmental, study.floating
    manifest = study.manifest
    stribeck_velocity, stribeck_shape, fit_joints, delay = (
        study.stribeck_velocity, study.stribeck_shape, study.fit_joints, study.delay
    )  # fmt: skip
    if study.payload is not None or study.payload_data is not None:
        where = f"{manifest}: " if manifest is not None else ""
        raise SpecError(f"{where}drive gains (payload) are not supported by compare; use identify")
    if study.offsets is not None or study.calibrate_offsets is not None:
        raise SpecError("offsets per recording (and their calibration) are not supported by compare; use identify")
    terms = as_terms(study.terms)
    methods = parse_methods(methods, default=quick_methods())
    seed_list = list(range(int(seeds))) if np.ndim(seeds) == 0 else [int(s) for s in seeds]
    if not seed_list:
        raise SpecError("seeds: expected at least one seed")
    options = check_options(options, methods)
    meta = dict(metaheuristic or {})
    workers = check_workers(workers)
    serial = workers == 1 and scheduler is None

    def settings_for(m: str, seed: int | None) -> dict:
        s = {}
        if issubclass(ESTIMATORS[m], Metaheuristic):
            s.update(meta)
            if ESTIMATORS[m].default_box != "nominal" and "box" in s:
                # rls-pso is PSO in *its* RLS box: a box choice for the others leaves it alone (not the RLS settings)
                s["box"] = replace(SearchBox.of(s["box"]), kind=None)
            s["seed"] = seed
        s.update(options.get(m, {}))
        return s

    if getattr(model, "base", "fixed") == "floating":
        unsupported = dict(manifest=manifest, segmental=segmental, stribeck_velocity=stribeck_velocity,
                           stribeck_shape=stribeck_shape, fit_joints=fit_joints, delay=delay)  # fmt: skip
        st, val_W, truth_x = _floating_study(replace(study, terms=terms), truth, unsupported)
        model, problem, seg, base, terms = st.model, st.problem, None, st.base, st.terms
        names, scale = problem.names, natural_scale(problem)
    else:
        if floating is not None:
            raise SpecError(f"floating: given for {model.name}, a fixed-base robot (base='floating' loads it floating)")
        shapes, auto = stribeck_settings(model, terms, stribeck_velocity, stribeck_shape)
        model = model.with_stribeck(shapes) if shapes else model
        st = setup(replace(study, model=model, terms=terms), stribeck_auto=auto)
        model, problem, seg, base = st.model, st.problem, st.segmental, st.base  # the model with fitted shapes
        check_recordings(st)  # as identify: a flipped torque sign, a validation recording that repeats training
        names = problem.names
        truth_x = _truth_vector(truth, names, st)
        scale = natural_scale(problem)
        val_W = {
            label: [(ds, base_regressor(model, terms, base, ds)) for ds in (check_dataset(d, model) for d in sets)]
            for label, sets in st.validation.items()
        }
    jobs = [(m, s, settings_for(m, s)) for m in methods for s in ([None] if ESTIMATORS[m].deterministic else seed_list)]
    runs: dict[str, list[Run]] = {m: [] for m in methods}
    *done, reference = run_jobs(
        st,
        jobs,
        complete=complete,
        show_progress=show_progress,
        label="compare",
        workers=workers,
        scheduler=scheduler,
        beside=_study_references,
        fit_progress=show_progress if serial else False,  # in parallel: jobs done / total only
        # each run validated where it was fitted (on the workers too)
        after=partial(_run_of, problem=problem, val_W=val_W, truth_x=truth_x, scale=scale, segmental=seg is not None),
    )
    for run in done:
        runs[run.method].append(run)
    settings_out = {
        "metaheuristic": {k: (asdict(v) if isinstance(v, SearchBox) else v) for k, v in meta.items()},
        "options": options,
        "terms": terms.names,
        "rest_velocity": rest_velocity if isinstance(rest_velocity, str) else np.asarray(rest_velocity).tolist(),
    }
    return Comparison(
        robot=robot_to_dict(model, terms),
        base_names=names,
        nominal=problem.nominal_base.copy(),
        truth=truth_x,
        methods=methods,
        seeds=seed_list,
        runs=runs,
        reference=reference,
        data={
            **problem.summary(),
            **({"stribeck": st.stribeck} if st.stribeck else {}),
            **({"delay": st.delay} if st.delay is not None else {}),
        },
        validation_sources={label: [ds.source for ds in sets] for label, sets in st.validation.items()},
        settings=settings_out,
        segmental=None
        if seg is None
        else {
            "first_joints": seg.first_joints,
            "first_sources": seg.first_problem.sources,
            "first_rows": seg.first_problem.rows,
        },
        seconds=time.perf_counter() - t_start,
    )


def _floating_study(study: Study, truth, unsupported: dict):
    """``(setup, validation rows, true base parameters)`` of a floating-base study (:func:`~pinid.identification.run.setup`,
    :mod:`pinid.identification.floating`)."""
    from pinid.identification.floating import floating_truth, refuse_fixed_only

    refuse_fixed_only(unsupported)
    st = setup(study)
    val_W = {} if st.floating.validation is None else {"validation": st.floating.validation}
    return st, val_W, None if truth is None else floating_truth(truth, st.problem)


_INFO_KEYS = (
    "fitness",
    "fitness_value",
    "ls_fitness",
    "min_fitness",
    "message",
    "iterations",
    "nfev",
    "box",
    "at_bound",
)


def _predicted(problem, ds, Wb: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``(N, nv)`` torque [N·m] predicted on a validation recording as identify predicts it: with the cached
    base regressor ``Wb``, or (``--fit-joints``) through the completed standard set
    (:func:`~pinid.problem.problem.predict_torque`: the left-out joints need the bodies the fitted rows miss)."""
    if problem.base.fit_joints is not None:
        return predict_torque(problem.model, problem.terms, problem.base, ds, values)
    return (Wb @ values).reshape(ds.n, problem.model.nv)


def _run_of(fit: Fit, problem, val_W: dict, truth_x, scale, segmental: bool) -> Run:
    """The measures of one fitted job (:class:`Run`)."""
    res, model = fit.result, problem.model
    validation, filtered = {}, {}
    for label, items in val_W.items():
        if isinstance(items, IdentificationProblem):  # a floating base's validation rows, per body
            joints, units = items.model.joint_names, joint_units(items.model)
            m = error_metrics(items.tau, items.tau - items.predict(res.base), joints, items.joint, units).to_dict()
            validation[label] = filtered[label] = m
            continue
        tau = np.concatenate([ds.tau for ds, _ in items])
        recorded = np.concatenate([recorded_torque(ds) for ds, _ in items])
        pred = np.concatenate([_predicted(problem, ds, Wb, res.base) for ds, Wb in items])
        validation[label] = torque_metrics(recorded, pred, model.joint_names, units=joint_units(model)).to_dict()
        filtered[label] = torque_metrics(tau, pred, model.joint_names, units=joint_units(model)).to_dict()
    hist_first = None
    info: dict = {}
    if segmental:
        st = res.info.get("segmental", {})
        hist_first = (st.get("first_stage") or {}).get("history")
        info["segmental"] = {k: v for k, v in st.items() if k not in ("first_stage", "second_stage")}
        for stage in ("first_stage", "second_stage"):
            d = st.get(stage) or {}
            info[stage] = {k: d[k] for k in ("seconds",) + _INFO_KEYS[1:] if k in d}
    else:
        info = {k: res.info[k] for k in _INFO_KEYS if k in res.info}
    if issubclass(ESTIMATORS[fit.method], Metaheuristic):
        info["fitness"] = fit.settings.get("fitness", "sse")
    if "not_realisable" in res.info:
        info["not_realisable"] = res.info["not_realisable"]
    names = problem.names
    errors = (None, None) if truth_x is None else _parameter_errors(res.base, truth_x, scale, names)
    return Run(
        method=fit.method,
        seed=fit.seed,
        base=res.base.copy(),
        seconds=fit.seconds,
        train=res.train.to_dict(),
        costs=training_costs(problem, res.base),
        validation=validation,
        train_filtered=None if res.train_filtered is None else res.train_filtered.to_dict(),
        validation_filtered=filtered,
        parameter_error=errors[0],
        parameter_error_abs=errors[1],
        history=None if res.history is None else [float(h) for h in res.history],
        history_first=None if hist_first is None else [float(h) for h in hist_first],
        physically_consistent=res.physically_consistent,
        standard_source=res.standard_source or "",
        info=info,
    )
