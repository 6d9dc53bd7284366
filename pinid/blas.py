"""How many BLAS threads pinid uses.

pinid's linear algebra is skinny (at most ~100 columns) or small (a swarm of 100 parameter vectors, 20 × 20
factors, the SDP's blocks).  Measured on the project's 2-core machine (docs/benchmarks.md): on a quiet
machine one thread per core gains 0–30 % (``tests/benchmarks/bench_blas.py``); on a busy one its threads
wait on each other and tall QR factorisations slow down 10–40× (docs/identification.md).  The CLI therefore
runs every command with one BLAS thread unless the user chose a count through the usual variables.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

#: Environment variables through which a user chooses the BLAS thread count; the CLI respects them.
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")


@contextlib.contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Run the block with one BLAS thread (every BLAS in the process), restoring the setting afterwards."""
    import scipy.linalg  # noqa: F401 - load scipy's own OpenBLAS too, so that it is limited as well
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1, user_api="blas"):
        yield


def cli_blas_threads() -> contextlib.AbstractContextManager[None]:
    """The CLI's setting: one BLAS thread, unless one of :data:`THREAD_VARIABLES` is set."""
    if any(os.environ.get(v) for v in THREAD_VARIABLES):
        return contextlib.nullcontext()
    return single_threaded_blas()
