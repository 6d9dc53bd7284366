"""pinid.parallel and the parallel studies: the same numbers on 1 or N local processes or on a Dask cluster;
clear errors; Ctrl-C stops every worker and writes nothing."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from pinid.blas import single_threaded_blas
from pinid.data.formats import write_recording
from pinid.errors import PinidError, SpecError
from pinid.identification.compare import compare
from pinid.identification.study import Study
from pinid.parallel import check_workers, default_workers, run_parallel
from pinid.simulation.cad import perturb

from conftest import assert_clean_error, run_cli
from test_identification import true_base, truth_model, twin

SMALL = {"population": 12, "iterations": 8}


def _square_plus(shared: float, item: float) -> tuple[int, float]:
    return os.getpid(), shared + item * item


def _fails_on_three(shared, item):
    if item == 3:
        raise SpecError("item 3: refused")
    return item


def test_results_come_back_in_the_order_of_the_items_from_several_processes():
    items = list(range(12))
    serial = run_parallel(_square_plus, 0.5, items, workers=1)
    parallel = run_parallel(_square_plus, 0.5, items, workers=2)
    assert [v for _, v in parallel] == [v for _, v in serial] == [0.5 + i * i for i in items]
    assert {pid for pid, _ in serial} == {os.getpid()}
    assert os.getpid() not in {pid for pid, _ in parallel}  # the jobs ran in the workers


def test_a_jobs_error_reaches_the_caller_as_itself():
    with pytest.raises(SpecError, match="item 3: refused"):
        run_parallel(_fails_on_three, None, list(range(6)), workers=2)


def _refuse_to_load():
    raise RuntimeError("input stream error")


class _Unloadable:
    """A result that pickles but cannot be unpickled (as pin 4.0's Data was)."""

    def __reduce__(self):
        return (_refuse_to_load, ())


def _unloadable(shared, item):
    return _Unloadable()


def test_a_result_that_cannot_come_back_is_an_error_not_a_hang():
    with pytest.raises(PinidError, match="could not be carried back"):
        run_parallel(_unloadable, None, [1, 2, 3], workers=2)


def test_a_robot_model_travels_to_a_worker_and_back():
    import pickle

    model = truth_model("exo_leg")
    back = pickle.loads(pickle.dumps(model))
    q, dq, ddq = (np.array([0.3, 0.5]), np.array([0.1, -0.2]), np.array([1.0, 2.0]))
    assert np.array_equal(back.rnea(q, dq, ddq), model.rnea(q, dq, ddq))


@pytest.mark.parametrize("workers", [0, -1, 1.5, "2", True])
def test_workers_must_be_a_count(workers):
    with pytest.raises(SpecError, match="workers"):
        check_workers(workers)


def test_default_workers_are_the_cores():
    assert check_workers(None) == default_workers() >= 1


@pytest.fixture(scope="module")
def study():
    truth = truth_model("exo_leg")
    cad = perturb(truth, 20, np.random.default_rng(3))
    train = twin(truth, seconds=10, rate=100, seed=1, noise=0.5)
    valid = twin(truth, seconds=6, rate=100, seed=2, noise=0.5)
    return cad, train, valid, true_base(truth)[1]


def _numbers(comp) -> dict:
    """Everything a comparison measured except the clock."""
    d = comp.to_dict()
    d.pop("seconds", None)
    for runs in d["runs"].values():
        for r in runs:
            r.pop("seconds")
    d.pop("summary", None)
    return d


def _compare(study, **where):
    cad, train, valid, xt = study
    with single_threaded_blas():  # the CLI's setting: the workers run with one BLAS thread too
        return compare(Study(cad, train, valid), ["ols", "sdp", "pso", "de"], 3, truth=xt, metaheuristic=SMALL, **where)


@pytest.mark.slow
def test_compare_gives_the_same_numbers_on_one_or_two_processes(study):
    one, two = _compare(study, workers=1), _compare(study, workers=2)
    assert _numbers(one) == _numbers(two)
    assert [r.seed for r in two.runs["pso"]] == [0, 1, 2]


@pytest.mark.slow
def test_compare_gives_the_same_numbers_on_a_dask_cluster(study):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as c:
        on_cluster = _compare(study, scheduler=c.scheduler_address)
    assert _numbers(on_cluster) == _numbers(_compare(study, workers=1))


@pytest.mark.slow  # 10 s waiting of CPU (docs/benchmarks.md, Test suite)
def test_an_address_where_no_scheduler_answers_is_a_clear_error(study):
    pytest.importorskip("distributed")
    with pytest.raises(SpecError, match="no Dask scheduler answers"):
        run_parallel(_square_plus, 0.0, [1, 2], scheduler="tcp://127.0.0.1:9")


def test_cli_refuses_zero_workers(tmp_path):
    res = run_cli("compare", "--urdf", "exo_leg", "--data", "x.csv", "--workers", "0", "-o", str(tmp_path / "o"))
    assert_clean_error(res, "workers")
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_stops_every_worker_and_writes_nothing(tmp_path, study):
    cad, train, valid, _ = study
    data = tmp_path / "train.csv"
    write_recording(data, train)
    out = tmp_path / "out"
    argv = ["compare", "--urdf", "exo_leg", "--data", str(data), "--methods", "pso,de", "--seeds", "8"]
    argv += ["--iterations", "20000", "--workers", "2", "--no-plots", "-o", str(out)]
    proc = subprocess.Popen(
        [sys.executable, "-m", "pinid.cli", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    children: list[int] = []
    deadline = time.monotonic() + 60
    while len(children) < 2 and time.monotonic() < deadline and proc.poll() is None:  # wait for the pool
        time.sleep(0.2)
        children = _children(proc.pid)
    assert len(children) >= 2, "the two workers never started"
    time.sleep(1.0)  # the workers are fitting
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode in (2, 130), (proc.returncode, err)
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1 and "interrupted" in err, err
    assert not out.exists()
    time.sleep(0.5)
    assert not [pid for pid in children if _alive(pid)], "a worker outlived the interrupt"


def _children(pid: int) -> list[int]:
    try:
        text = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout
    except FileNotFoundError:
        return []
    return [int(p) for p in text.split()]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    with open(f"/proc/{pid}/stat") as f:  # a zombie is dead
        return f.read().split()[2] != "Z"


def _rows_of(s) -> int:
    return s.problem.rows


def test_a_job_beside_the_fits_comes_back_last_on_one_or_two_processes():
    from pinid.identification.run import setup
    from pinid.identification.runner import run_jobs

    truth = truth_model("exo_leg")
    s = setup(Study(truth, [twin(truth, seconds=4, rate=100, seed=1, noise=0.5)]))
    jobs = [("ols", None, {}), ("ridge", None, {})]
    one = run_jobs(s, jobs, beside=_rows_of)
    two = run_jobs(s, jobs, beside=_rows_of, workers=2)
    assert one[-1] == two[-1] == s.problem.rows
    assert [f.method for f in one[:-1]] == [f.method for f in two[:-1]] == ["ols", "ridge"]
    assert np.array_equal(one[0].estimator.base_, two[0].estimator.base_)
    with pytest.raises(SpecError, match="beside"):
        run_jobs(s, jobs, beside="rows")


def test_each_fit_shows_its_progress_as_the_caller_chose_on_one_or_two_processes(tmp_path, monkeypatch):
    """run_jobs(fit_progress=) reaches the fits where they run (compare: its show_progress on one process, off
    on workers), even against PINID_PROGRESS; None leaves the rules of pinid.progress."""
    import pinid.optimizers.pso as pso
    from pinid.identification.run import setup
    from pinid.identification.runner import run_jobs
    from pinid.progress import shown

    real, seen = pso.progress_bar, tmp_path / "seen.txt"

    def recording(*args, **kwargs):
        with open(seen, "a") as f:  # appended from the workers too (forked: the patch goes with them)
            f.write(f"{shown(kwargs.get('enabled'))}\n")
        return real(*args, **kwargs)

    monkeypatch.setattr(pso, "progress_bar", recording)
    truth = truth_model("exo_leg")
    s = setup(Study(truth, [twin(truth, seconds=4, rate=100, seed=1, noise=0.5)]))
    jobs = [("pso", seed, {"population": 6, "iterations": 3, "seed": seed}) for seed in (0, 1)]
    for env, choice, workers, want in (("1", False, 2, "False"), ("0", True, 1, "True"), ("0", None, 1, "False")):
        monkeypatch.setenv("PINID_PROGRESS", env)
        seen.write_text("")
        run_jobs(s, jobs, workers=workers, fit_progress=choice)
        assert seen.read_text().split() == [want, want], (env, choice, workers)
    with pytest.raises(SpecError, match="fit_progress"):
        run_jobs(s, jobs, fit_progress="yes")


def test_workers_forked_after_an_sdp_fit_do_not_hang():
    """Clarabel's default thread pool, started by an SDP fit in this process, left forked workers waiting for
    ever (the in-process CLI test of `pinid compare --base floating` hung once in three): the conic solver
    runs on one thread.  In a child process with a time limit, so that a hang fails instead of blocking."""
    import subprocess
    import sys

    script = """
import numpy as np
from pinid import RobotModel, Study
from pinid.estimators import make_estimator
from pinid.identification.run import setup
from pinid.identification.runner import run_jobs
from pinid.simulation.twin import simulate
from pinid.simulation.trajectories import load_trajectory
model = RobotModel.from_urdf("exo_leg")
ds, _ = simulate(model, load_trajectory("zha2019-1", model), seconds=4, seed=1)
s = setup(Study(model, ds))
make_estimator("sdp").fit(s.problem)
out = run_jobs(s, [("sdp", None, {}), ("sdp", None, {})], workers=2)
print(np.max(np.abs(out[0].result.base - out[1].result.base)))
"""
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert float(proc.stdout.split()[-1]) == 0.0


def test_a_fit_that_jobs_share_runs_once_on_two_processes_with_the_serial_numbers(study, tmp_path, monkeypatch):
    """rls and every RLS-PSO seed need one RLS run (kept in the problem's cache): on two processes it runs once,
    before the jobs that need it, not once per worker; the numbers are the serial run's."""
    from pinid.estimators.rls import RLS

    runs = tmp_path / "rls_runs.txt"
    recursion = RLS._run

    def counted(self, *args):  # the forked workers inherit the patch and append to the same file
        with open(runs, "a") as f:
            f.write(f"{os.getpid()}\n")
        return recursion(self, *args)

    monkeypatch.setattr(RLS, "_run", counted)
    cad, train, valid, xt = study

    def run(workers: int):
        runs.write_text("")
        with single_threaded_blas():
            comp = compare(Study(cad, train, valid), ["ols", "rls", "rls-pso"], 2, truth=xt, metaheuristic=SMALL,
                           workers=workers)  # fmt: skip
        return comp, len(runs.read_text().split())

    (one, serial_runs), (two, parallel_runs) = run(1), run(2)
    assert serial_runs == 1 and parallel_runs == 1
    assert _numbers(one) == _numbers(two)
    assert [r.seed for r in two.runs["rls-pso"]] == [0, 1]


@pytest.mark.parametrize("workers", [1, 2])
def test_local_workers_start_the_items_a_finished_one_releases(workers):
    """LocalWorkers.results(more=): an item's follow-ups are submitted when it is done and indexed after
    the items before them; every result arrives once, the same on one process and on two."""
    from pinid.parallel import LocalWorkers

    def more(item, result):
        return [item * 10, item * 100] if item in (1, 3) else []

    with LocalWorkers(_square_plus, 0.5, workers) as pool:
        got = dict(pool.results([1, 2, 3], more=more))
    values = {i: v for i, (_, v) in got.items()}
    assert sorted(values) == list(range(7))
    assert sorted(values.values()) == sorted(0.5 + x * x for x in (1, 2, 3, 10, 100, 30, 300))
    assert {values[i] for i in range(3)} == {1.5, 4.5, 9.5}  # the first items keep their indices
    if workers == 1:  # one process: in the order they were queued
        assert [values[i] for i in range(7)] == [0.5 + x * x for x in (1, 2, 3, 10, 100, 30, 300)]
