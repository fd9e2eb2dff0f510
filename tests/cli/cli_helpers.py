"""Helpers of the command-line tests: the real entry points run in subprocesses
(``python -m hopmatch.cli``, and the installed ``hopmatch`` console script next to
``sys.executable`` when it exists); the fixture ``pair`` is in conftest.py."""

from __future__ import annotations

import csv
import os
import re
import subprocess
import sys
from pathlib import Path

CLI = [sys.executable, "-m", "hopmatch.cli"]
SCRIPT = Path(sys.executable).with_name("hopmatch.exe" if os.name == "nt" else "hopmatch")
DISPARITY = 6
MATCH_FIELDS = ["left_x", "left_y", "right_x", "right_y", "disparity", "distance"]


def run(*args, cwd=None, cmd=CLI, stderr=subprocess.PIPE, timeout=180):
    return subprocess.run([*cmd, *map(str, args)], cwd=cwd, stdout=subprocess.PIPE,
                          stderr=stderr, text=True, timeout=timeout)


def files_in(folder: Path) -> list[str]:
    """Every entry of ``folder`` (hidden temporary files included); [] if it does not exist."""
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


def assert_bad_input(res, *needles):
    """Exit status 2 and one line ``hopmatch: error: <where>: <problem>`` naming the input."""
    assert res.returncode == 2, (res.returncode, res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert re.match(r"^hopmatch: error: .+: .+", lines[0]), lines[0]
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


def read_csv(path: Path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def printed(stdout: str, key: str) -> str:
    m = re.search(rf"^{re.escape(key)}: (.*)$", stdout, re.M)
    assert m, (key, stdout)
    return m.group(1)
