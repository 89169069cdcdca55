"""One BLAS thread for the command line and for sweep workers (docs/design.md, "BLAS threads").

mirl's dense linear algebra is small (solves of a few hundred unknowns): a second OpenBLAS thread
never made it faster and made it 1.6–1.9× slower when the other core was busy. OpenBLAS reads
its thread count once, when the library loads, so the limit is set in the environment *before*
numpy or scipy load their BLAS; libraries that are already loaded (numpy imported by the caller)
are limited through ``threadpoolctl``. A thread count the user set in the environment wins.
"""

from __future__ import annotations

import os
import sys

__all__ = ["one_blas_thread"]

_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


def one_blas_thread() -> None:
    """Limit BLAS to one thread in this process, unless the user chose a thread count."""
    if any(v in os.environ for v in _VARS):
        return
    for v in _VARS:
        os.environ[v] = "1"  # read by every BLAS library loaded from now on
    if "numpy" in sys.modules or "scipy" in sys.modules:  # already loaded: limit them live
        from threadpoolctl import threadpool_limits

        threadpool_limits(limits=1, user_api="blas")
