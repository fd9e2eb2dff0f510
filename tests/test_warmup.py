"""``hopmatch.warmup()`` compiles every kernel the library calls (issue: first-call delay)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import hopmatch

PACKAGE = Path(hopmatch.__file__).resolve().parent

CHECK = textwrap.dedent("""
    import importlib, json, sys
    import hopmatch
    hopmatch.warmup()
    out = {}
    for module, name in json.loads(sys.argv[1]):
        kernel = getattr(importlib.import_module(module), name)
        out[f"{module}.{name}"] = len(kernel.signatures)
    print(json.dumps(out))
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


def test_warmup_compiles_every_kernel_the_library_calls(tmp_path):
    kernels = kernels_called_from_python()
    assert len(kernels) >= 15          # the scan itself works
    env = {**os.environ, "HOPMATCH_NUMBA_CACHE": "0",
           "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    proc = subprocess.run([sys.executable, "-c", CHECK, json.dumps(kernels)],
                          capture_output=True, text=True, env=env, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    compiled = json.loads(proc.stdout.strip().splitlines()[-1])
    assert [name for name, n in compiled.items() if n == 0] == []
