"""Smoke run of ``benchmarks/unrectified.py`` (the figures of issue 18 that
docs/pipelines.md and docs/parameters.md quote): it runs and prints every section."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

from conftest import SHARED_DATA

ROOT = Path(__file__).resolve().parents[2]


def test_unrectified_smoke(shared_data):
    env = {**os.environ, "HOPMATCH_SHARED_DATA": str(SHARED_DATA)}
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "unrectified.py"),
                           "--smoke"], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout
    for heading in ("## Perturbed pairs: match_stereo(left, right, rectified=False)",
                    "## Chessboard pairs: matches within 1 px of the calibrated epipolar lines",
                    "## Ranges found with max_disparity=None (rectified pairs)"):
        assert heading in out
    assert re.search(r"^\| middlebury/tsukuba \| \+5 deg, \+30 px, x1\.03 \| \d+ \| \d+ \| "
                     r"0\.\d+ \| \d+ \|", out, re.M)
    assert re.search(r"^All pairs: \d+ correct of \d+ scored \(pooled precision", out, re.M)
    assert re.search(r"^All pairs, undistorted: match_stereo \d+ of \d+", out, re.M)
    assert re.search(r"^## Large pair: motorcycle upsampled to 1000 x 675", out, re.M)
    assert re.search(r"^precision: 0\.\d+ at 1 px, 0\.\d+ at 2 px", out, re.M)
    assert re.search(r"^precision at 1 px by ground truth: flat [\d.]+ of \d+; slanted "
                     r"(?:[\d.]+|nan) of \d+; edge (?:[\d.]+|nan) of \d+; mean error within "
                     r"2 px [+-][\d.]+ px$", out, re.M)
    assert re.search(r"^\| middlebury/tsukuba \| [\d.]+\.\.[\d.]+ \| 5\.0\.\.14\.0 \| 1\.0000 \|$",
                     out, re.M)
