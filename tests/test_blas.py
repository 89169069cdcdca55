"""One BLAS thread: set in the environment before BLAS loads, live through threadpoolctl after,
and never over a thread count the user chose. Each case runs in a fresh interpreter, since the
environment and the loaded libraries are the process's."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")


def _run(code: str, **env: str) -> dict:
    clean = {k: v for k, v in os.environ.items() if k not in VARS}
    out = subprocess.run(
        [sys.executable, "-c", code], env={**clean, **env}, capture_output=True, text=True,
        check=True,
    )  # fmt: skip
    return json.loads(out.stdout)


REPORT = (
    "import json, os, sys\n"
    "from threadpoolctl import threadpool_info\n"
    "blas = [p['num_threads'] for p in threadpool_info() if p['user_api'] == 'blas']\n"
    f"print(json.dumps({{'env': {{v: os.environ.get(v) for v in {VARS!r}}}, 'blas': blas}}))\n"
)


def test_before_numpy_loads_the_environment_says_one():
    got = _run("from mirl._blas import one_blas_thread\none_blas_thread()\nimport numpy\n" + REPORT)
    assert set(got["env"].values()) == {"1"}
    assert got["blas"] and set(got["blas"]) == {1}


def test_after_numpy_loaded_the_libraries_are_limited_live():
    got = _run("import numpy\nfrom mirl._blas import one_blas_thread\none_blas_thread()\n" + REPORT)
    assert got["blas"] and set(got["blas"]) == {1}


@pytest.mark.parametrize("var", VARS)
def test_a_thread_count_the_user_set_wins(var):
    got = _run("from mirl._blas import one_blas_thread\none_blas_thread()\n" + REPORT, **{var: "2"})
    assert got["env"][var] == "2"
    assert all(got["env"][v] is None for v in VARS if v != var)  # nothing else set either
