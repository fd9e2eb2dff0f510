"""The Numba policy's first-run notice (hopmatch._config.CompileNotice): one line on
stderr when one of hopmatch's kernels is compiled, none when it is loaded from the cache
or when another package compiles."""

from __future__ import annotations

import os
import subprocess
import sys

NOTICE = "compiling hopmatch's kernels for this CPU"
#: Compiles the smallest kernel twice over (two specialisations), then a foreign kernel.
CHILD = """
import numba, numpy as np
from hopmatch._kernels.arrays import lower_bound
lower_bound(np.arange(5), 0, 5, 3)
lower_bound(np.arange(5.0), 0, 5, 3.0)
numba.njit(lambda x: x + 1)(1.0)
"""


def _stderr(cache, **env):
    proc = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True,
                          env={**os.environ, "NUMBA_CACHE_DIR": str(cache),
                               "HOPMATCH_COMPILE_NOTICE": "1", **env}, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return proc.stderr


def test_the_notice_is_printed_once_on_compilation_and_not_on_a_cache_load(tmp_path):
    cold = _stderr(tmp_path)
    assert cold.count(NOTICE) == 1, cold
    assert "first run only" in cold and str(tmp_path) in cold
    assert NOTICE not in _stderr(tmp_path)  # loaded from the cache: nothing compiled


def test_the_notice_can_be_silenced(tmp_path):
    assert NOTICE not in _stderr(tmp_path, HOPMATCH_COMPILE_NOTICE="0")


def test_the_notice_ignores_other_packages_kernels():
    from numba.core import event

    from hopmatch._config import COMPILE_NOTICE

    class Ev:
        data = {"dispatcher": type("D", (), {"py_func": len})()}

    assert not COMPILE_NOTICE.is_ours(Ev())
    assert isinstance(COMPILE_NOTICE, event.Listener)
