"""``hopmatch.warmup()`` compiles every kernel the library calls (issue: first-call delay)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from collections import Counter
from pathlib import Path

import pytest

import hopmatch

PACKAGE = Path(hopmatch.__file__).resolve().parent

# argv: the kernels (JSON), the processes of hopmatch.warmup
CHECK = textwrap.dedent("""
    import importlib, json, sys
    from numba.core import event
    compiled = []


    class Seen(event.Listener):  # every specialisation this process compiles
        def on_start(self, ev):
            f = ev.data["dispatcher"].py_func
            compiled.append(f"{f.__module__}.{f.__qualname__}")

        def on_end(self, ev):
            pass


    event.register("numba:compile", Seen())
    import hopmatch
    hopmatch.warmup(int(sys.argv[2]))
    out = {}
    for module, name in json.loads(sys.argv[1]):
        kernel = getattr(importlib.import_module(module), name)
        out[f"{module}.{name}"] = len(kernel.signatures)
    print(json.dumps({"signatures": out, "compiled": compiled}))
""")


def kernels_called_from_python() -> list[tuple[str, str]]:
    """Every ``<alias>.<kernel>(`` call outside ``hopmatch._kernels``, with the kernel module
    that module imports as ``<alias>`` (``from .._kernels import candidates as _kc``...)."""
    found = set()
    for path in PACKAGE.rglob("*.py"):
        if "_kernels" in path.parts:
            continue
        text = path.read_text()
        for module, alias in re.findall(r"from \.+_kernels import (\w+) as (\w+)\b", text):
            for name in re.findall(rf"\b{alias}\.(\w+)\(", text):
                found.add((f"hopmatch._kernels.{module}", name))
    return sorted(found)


@pytest.fixture(scope="module")
def cold_warmup(tmp_path_factory):
    """What a cold ``hopmatch.warmup()`` compiles (cache off), in a fresh interpreter: the
    signatures of every kernel the library calls and every specialisation compiled."""
    kernels = kernels_called_from_python()
    assert len(kernels) >= 15          # the scan itself works
    env = {**os.environ, "HOPMATCH_NUMBA_CACHE": "0",
           "NUMBA_CACHE_DIR": str(tmp_path_factory.mktemp("cache"))}
    proc = subprocess.run([sys.executable, "-c", CHECK, json.dumps(kernels), "1"],
                          capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_warmup_compiles_every_kernel_the_library_calls(cold_warmup):
    assert [name for name, n in cold_warmup["signatures"].items() if n == 0] == []


def test_warmup_compiles_each_kernel_once_and_none_of_numbas_costly_extras(cold_warmup):
    """Compile time (issue 17, ``benchmarks/compile_times.py``): every specialisation costs a
    full compilation, so each of hopmatch's kernels is compiled for one signature (a
    literal ``0`` passed where an int64 also arrives compiles a kernel twice), NumPy's sort
    for one (the kernels sort int64 keys only), and nothing compiles Numba's string
    functions (the error message of a slice assignment's shape check costs seconds)."""
    compiled = cold_warmup["compiled"]
    ours = Counter(name for name in compiled if name.startswith("hopmatch."))
    assert len(ours) >= 30                                   # the events were seen
    # the binary searches serve int64 rows and float32 x alike (inlined: no entry of their own)
    assert {name: n for name, n in ours.items() if n > 1} == {}
    sorts = Counter(name for name in compiled if name.startswith("numba.misc.quicksort."))
    assert sorts and max(sorts.values()) == 1, sorts
    assert [name for name in compiled if name.startswith("numba.cpython.unicode.")] == []




def test_warmup_in_two_processes_loads_the_helpers_kernels_from_the_cache(tmp_path):
    """``warmup(2)`` with an empty on-disk cache: afterwards every kernel the library calls
    is ready in this process, the network's compiled here, the detector's and the guided
    pass's compiled by the second interpreter and only loaded here (no compile event)."""
    kernels = kernels_called_from_python()
    env = {**os.environ, "HOPMATCH_NUMBA_CACHE": "1", "NUMBA_CACHE_DIR": str(tmp_path),
           "HOPMATCH_COMPILE_NOTICE": "0"}
    proc = subprocess.run([sys.executable, "-c", CHECK, json.dumps(kernels), "2"],
                          capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    got = json.loads(proc.stdout.strip().splitlines()[-1])
    assert [name for name, n in got["signatures"].items() if n == 0] == []
    here = set(got["compiled"])
    assert "hopmatch._kernels.network.run_network" in here
    helpers = {"hopmatch._kernels.guided.row_search", "hopmatch._kernels.refine.refine_rows",
               "hopmatch._kernels.moravec.moravec_response",
               "hopmatch._kernels.descriptor.bilinear_windows"}
    assert helpers <= set(got["signatures"])  # kernels the library calls, by these names
    assert helpers.isdisjoint(here), helpers & here
    assert list(tmp_path.rglob("*.nbi"))  # the cache the two shared


@pytest.mark.parametrize("bad, error", [(0, hopmatch.errors.InvalidArgumentError),
                                        (1.5, hopmatch.errors.InvalidTypeError),
                                        (True, hopmatch.errors.InvalidTypeError)])
def test_warmup_refuses_a_bad_process_count(bad, error):
    with pytest.raises(error, match="`processes`"):
        hopmatch.warmup(bad)


FIRST_COMPILE = textwrap.dedent("""
    import json, sys
    import numpy as np
    import hopmatch
    from hopmatch import _warmup
    hopmatch.setNumThreads(int(sys.argv[1]))
    img = (np.random.default_rng(0).random((40, 60)) * 255).astype(np.uint8)
    hopmatch.DericheMoravecDetector().detect(img)  # the first compilation of the process
    helper = _warmup._state["helper"]
    out = {"pid": None if helper is None else helper.pid}
    if helper is not None and sys.argv[2] == "wait":
        out["code"] = helper.wait(timeout=600)
    print(json.dumps(out))
""")


def _first_compile(tmp_path, threads, wait, **env):
    """What FIRST_COMPILE prints, run with ``threads`` hopmatch threads and an empty cache
    in ``tmp_path``; ``env`` on top of this environment without HOPMATCH_COMPILE_HELPER."""
    inherited = {k: v for k, v in os.environ.items() if k != "HOPMATCH_COMPILE_HELPER"}
    env = {**inherited, "HOPMATCH_NUMBA_CACHE": "1", "NUMBA_CACHE_DIR": str(tmp_path),
           "HOPMATCH_COMPILE_NOTICE": "0", **env}
    proc = subprocess.run([sys.executable, "-c", FIRST_COMPILE, str(threads),
                           "wait" if wait else "exit"],
                          capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_the_first_compilation_starts_a_helper_for_the_kernels_needed_last(tmp_path):
    """A process's first compilation of one of hopmatch's kernels (here the detector's)
    starts a second interpreter that compiles the guided pass's and the refinement's
    kernels into the on-disk cache, where the first process will load them from."""
    got = _first_compile(tmp_path, 2, wait=True)
    assert got["pid"] is not None and got["code"] == 0
    cached = {p.name.split("-")[0] for p in tmp_path.rglob("*.nbi")}
    assert {"guided.row_search", "refine.refine_rows", "halves.half_windows"} <= cached


def test_the_helper_does_not_outlive_its_process(tmp_path):
    pid = _first_compile(tmp_path, 2, wait=False)["pid"]
    assert pid is not None
    with pytest.raises(ProcessLookupError):  # stopped and reaped at the interpreter's exit
        os.kill(pid, 0)


@pytest.mark.parametrize("threads, env", [(1, {}), (2, {"HOPMATCH_COMPILE_HELPER": "0"}),
                                          (2, {"HOPMATCH_NUMBA_CACHE": "0"})])
def test_no_helper_with_one_thread_the_switch_off_or_no_cache(tmp_path, threads, env):
    assert _first_compile(tmp_path, threads, wait=False, **env)["pid"] is None
