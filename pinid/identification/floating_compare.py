"""``pinid compare --base floating``: several estimators, several seeds, on the same floating recordings.

Every method fits the same floating problem (:func:`pinid.problem.floating.floating_problem`:
base rows and joint rows, ``rows``, ``base_weight`` as in ``pinid identify --base floating``); the
deterministic ones once, the metaheuristics once per seed.  Each run is scored by its training and
validation RMS over the rows used [N, N·m] and, with a truth (the ``.truth.json`` of ``pinid simulate
--base floating``), by its largest base-parameter error relative to the parameter's natural scale
(mass, mass·length, mass·length²).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pinid.parallel import run_parallel
from pinid.errors import SpecError
from pinid.estimators import ESTIMATORS, Metaheuristic, make_estimator
from pinid.identification.floating import load_floating
from pinid.problem.floating import floating_problem
from pinid.identification.run import check_options, parse_methods
from pinid.io import Artefacts, json_text, read_json
from pinid.model.floating import FloatingRobotModel, as_floating
from pinid.model.terms import TermSelection, as_terms

#: Files :func:`write_floating_comparison` writes.
FILES = ("comparison.json", "comparison.md")


@dataclass
class FloatingComparison:
    """Every run (method, seed, base parameters, RMS, error against the truth) and their summary per method."""

    robot: str
    rows: str
    names: list[str]
    nominal: np.ndarray
    truth: np.ndarray | None
    runs: list[dict] = field(default_factory=list)
    data: dict = field(default_factory=dict)
    seconds: float = 0.0

    def summary(self) -> dict[str, dict]:
        """Per method: mean and standard deviation over its runs of the training and validation RMS and of
        the parameter error, and the number of runs."""
        out: dict[str, dict] = {}
        for m in dict.fromkeys(r["method"] for r in self.runs):
            rs = [r for r in self.runs if r["method"] == m]
            entry = {"runs": len(rs)}
            for key in ("train_rms", "validation_rms", "parameter_error", "seconds"):
                v = [r[key] for r in rs if r[key] is not None]
                entry[key] = None if not v else [float(np.mean(v)), float(np.std(v))]
            out[m] = entry
        return out

    def to_dict(self) -> dict:
        return {
            "robot": self.robot,
            "base": "floating",
            "rows": self.rows,
            "base_parameter_names": self.names,
            "nominal_base": self.nominal.tolist(),
            "truth_base": None if self.truth is None else self.truth.tolist(),
            "data": self.data,
            "runs": self.runs,
            "summary": self.summary(),
            "seconds": self.seconds,
        }

    def table(self) -> str:
        """Markdown table: per method, mean ± std over its runs."""

        def ms(v, fmt=".4g"):
            return "–" if v is None else f"{v[0]:{fmt}} ± {v[1]:{fmt}}"

        lines = [
            "| method | runs | train RMS | validation RMS | parameter error | seconds |",
            "|---|---|---|---|---|---|",
        ]
        for m, s in self.summary().items():
            lines.append(
                f"| {m} | {s['runs']} | {ms(s['train_rms'])} | {ms(s['validation_rms'])} | "
                f"{ms(s['parameter_error'], '.3g')} | {ms(s['seconds'], '.3g')} |"
            )
        return "\n".join(lines)


def floating_truth(truth, problem) -> np.ndarray:
    """The true base parameters of ``problem`` from a truth dict or its JSON path (``standard_names`` and
    ``standard`` of ``pinid simulate --base floating``).  SpecError naming what is missing."""
    origin = str(truth) if isinstance(truth, (str, os.PathLike)) else "truth"
    d = read_json(truth, "truth") if isinstance(truth, (str, os.PathLike)) else truth
    if not isinstance(d, Mapping) or d.get("base") != "floating" or "standard" not in d or "standard_names" not in d:
        raise SpecError(f"{origin}: not the truth of a floating twin (pinid simulate --base floating)")
    values = dict(zip(d["standard_names"], d["standard"]))
    missing = [n for n in problem.standard_names if n not in values]
    if missing:
        raise SpecError(f"{origin}: no true value of {', '.join(missing[:3])} (another robot or other --terms)")
    return problem.base.from_standard(np.array([float(values[n]) for n in problem.standard_names]))


def compare_floating(
    model: FloatingRobotModel,
    data,
    validate=None,
    *,
    methods: Sequence[str] | str | None = ("ols", "sdp"),
    seeds: int | Sequence[int] = 3,
    truth=None,
    terms: TermSelection = TermSelection(),
    rows: str = "all",
    base_weight: float = 1.0,
    preprocess=None,
    options: Mapping[str, Mapping] | None = None,
    metaheuristic: Mapping | None = None,
    swing_rows: bool = False,
    rest_velocity=None,
    mapping=None,
    workers: int | None = 1,
    scheduler=None,
) -> FloatingComparison:
    """Run ``methods`` on the same floating recordings (see the module text); ``seeds``: a number (0, 1, …)
    or the seeds of the metaheuristics; ``metaheuristic``: settings of every metaheuristic (``population``,
    ``iterations``, ``fitness``, ``box`` …; ``options`` per method override them); the other arguments as
    :func:`pinid.identification.run.identify` with a floating robot; ``workers``, ``scheduler``: where the runs go
    (:mod:`pinid.parallel`), as in :func:`pinid.identification.compare.compare`."""
    start = time.perf_counter()
    model = as_floating(model)
    terms = as_terms(terms)
    methods = parse_methods(methods, default=["ols", "sdp"])
    seed_list = list(range(int(seeds))) if np.ndim(seeds) == 0 else [int(s) for s in seeds]
    if not seed_list:
        raise SpecError("seeds: expected at least one seed")
    options = check_options(options, methods)
    if mapping is not None:
        from pinid.data.contacts import floating_mapping

        mapping = floating_mapping(mapping)
    train = load_floating(data, model, preprocess, swing_rows=swing_rows, mapping=mapping)
    kw = dict(rows=rows, base_weight=base_weight, rest_velocity=rest_velocity)
    problem = floating_problem(model, train, terms=terms, **kw)
    val = None
    if validate:
        samples = load_floating(validate, model, preprocess, "validation", swing_rows=swing_rows, mapping=mapping)
        val = floating_problem(model, samples, terms=problem.terms, base=problem.base, **kw)
    truth_x = None if truth is None else floating_truth(truth, problem)
    scale = problem.natural_scale
    comp = FloatingComparison(model.name, rows, problem.names, problem.nominal_base, truth_x)
    comp.data = problem.summary()
    jobs = []
    for m in methods:
        metaheuristic_method = issubclass(ESTIMATORS[m], Metaheuristic)
        for seed in [None] if ESTIMATORS[m].deterministic else seed_list:
            settings = {**(metaheuristic or {}), "seed": seed, "progress": False} if metaheuristic_method else {}
            settings.update(options.get(m, {}))
            jobs.append((m, seed, settings))
    shared = (problem, val, truth_x, scale)
    comp.runs = run_parallel(_floating_run, shared, jobs, workers=workers, scheduler=scheduler, label="compare")
    comp.seconds = time.perf_counter() - start
    return comp


def _floating_run(shared: tuple, job: tuple[str, int | None, dict]) -> dict:
    """One method with one seed on the shared floating problem: its row of ``FloatingComparison.runs``."""
    problem, val, truth_x, scale = shared
    m, seed, settings = job
    t0 = time.perf_counter()
    est = make_estimator(m, **settings).fit(problem)
    seconds = time.perf_counter() - t0
    r = problem.tau - problem.predict(est.base_)
    rv = None if val is None else val.tau - val.predict(est.base_)
    return {
        "method": m,
        "seed": seed,
        "base": est.base_.tolist(),
        "train_rms": float(np.sqrt(np.mean(r * r))),
        "validation_rms": None if rv is None else float(np.sqrt(np.mean(rv * rv))),
        "parameter_error": None if truth_x is None else float(np.max(np.abs(est.base_ - truth_x) / scale)),
        "physically_consistent": getattr(est, "standard_", None) is not None,
        "seconds": seconds,
    }


def write_floating_comparison(comp: FloatingComparison, folder, *, command: str | None = None) -> list[Path]:
    """``comparison.json`` and ``comparison.md`` (the command and the table) into ``folder``, all or nothing."""
    folder = Path(folder)
    block = f"```\n{command}\n```\n\n" if command else ""
    md = (
        f"# Comparison on {comp.robot} (floating base, {comp.rows} rows)\n\n{block}{comp.table()}\n\n"
        "RMS over the rows used [N, N·m]; parameter error: the largest |estimate − truth| of a base parameter "
        "relative to its natural scale (mass, mass·length, mass·length²); mean ± std over the runs "
        "(metaheuristics: one per seed).\n"
    )
    arts = Artefacts()
    arts.add(folder / FILES[0], json_text(comp.to_dict()))
    arts.add(folder / FILES[1], md)
    return arts.write()
