"""The CLI's BLAS thread setting (pinid/blas.py): one thread unless the user chose a count."""

from __future__ import annotations

import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from pinid.blas import THREAD_VARIABLES, cli_blas_threads


def _blas_threads() -> set[int]:
    return {i["num_threads"] for i in threadpool_info() if i.get("user_api") == "blas"}


def test_cli_runs_single_threaded_and_restores_the_setting(monkeypatch):
    for v in THREAD_VARIABLES:
        monkeypatch.delenv(v, raising=False)
    with threadpool_limits(2, user_api="blas"):
        if _blas_threads() != {2}:
            pytest.skip("this BLAS cannot run two threads here")
        with cli_blas_threads():
            assert _blas_threads() == {1}
        assert _blas_threads() == {2}


def test_a_count_chosen_by_the_user_is_respected(monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    with threadpool_limits(2, user_api="blas"):
        if _blas_threads() != {2}:
            pytest.skip("this BLAS cannot run two threads here")
        with cli_blas_threads():
            assert _blas_threads() == {2}
