"""The scripts in ``examples/``, run as a user runs them: ``python examples/X.py --out DIR``
in a subprocess (``sys.executable``), checking the exit status and the figures they print.

Each script is run once per module (fixtures), and the figures are parsed from stdout.
Scripts on ``../shared/data`` use the ``shared_data`` fixture (skipped with a reason when
the data is absent) and get its location through ``HOPMATCH_SHARED_DATA``.
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SHARED_EXAMPLES = ["stereo_calibration.py", "uncalibrated.py", "kitti_depth.py",
                   "stereo_match.py"]
ALL_EXAMPLES = ["feature_matching.py", *SHARED_EXAMPLES]


#: Seconds an example may run before it counts as hung (a guard, not a speed goal: the
#: longest, ``stereo_calibration.py --all-pairs``, takes about 90 s on an idle 2-core machine
#: and went past the former 120 s on a loaded one).
EXAMPLE_TIMEOUT = 600


def run_example(script, *args, shared=None, cwd=None):
    env = dict(os.environ)
    if shared is not None:
        env["HOPMATCH_SHARED_DATA"] = str(shared)
    return subprocess.run([sys.executable, str(EXAMPLES / script), *map(str, args)],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                          env=env, cwd=cwd, timeout=EXAMPLE_TIMEOUT)


def figure(stdout: str, pattern: str) -> tuple:
    """The groups of the first line of ``stdout`` matching ``pattern`` (as floats)."""
    m = re.search(pattern, stdout, re.M)
    assert m, f"no line matching {pattern!r} in:\n{stdout}"
    return tuple(float(g) for g in m.groups())


def ok(res):
    assert res.returncode == 0, (res.returncode, res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    return res.stdout


# --------------------------------------------------------------------------------------
# every example
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("script", ALL_EXAMPLES)
def test_example_has_the_opencv_sample_shape(script):
    """Usage docstring, main(argv=None), and the sys.exit(main()) guard."""
    tree = ast.parse((EXAMPLES / script).read_text())
    doc = ast.get_docstring(tree)
    assert doc and "Usage::" in doc and f"examples/{script}" in doc
    mains = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "main"]
    assert mains and [a.arg for a in mains[0].args.args] == ["argv"]
    assert mains[0].args.defaults and ast.literal_eval(mains[0].args.defaults[0]) is None
    assert 'if __name__ == "__main__":\n    sys.exit(main())' in (EXAMPLES / script).read_text()


@pytest.mark.parametrize("script", SHARED_EXAMPLES)
def test_missing_shared_data_exits_2_with_a_message(script, tmp_path):
    res = run_example(script, "--out", tmp_path / "out", shared=tmp_path / "absent")
    assert res.returncode == 2, (res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    assert "shared stereo data folder is absent" in res.stderr
    assert str(tmp_path / "absent") in res.stderr


# --------------------------------------------------------------------------------------
# feature_matching.py
# --------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def feature_matching(tmp_path_factory):
    out = tmp_path_factory.mktemp("feature_matching")
    return run_example("feature_matching.py", "--out", out), out


def test_feature_matching_on_motorcycle(feature_matching):
    res, out = feature_matching
    stdout = ok(res)
    n_left, n_right = figure(stdout, r"^keypoints: (\d+) left, (\d+) right$")
    assert n_left > 1000 and n_right > 1000
    (n_good,) = figure(stdout, r"^ratio-test matches: (\d+)")
    (n_match,) = figure(stdout, r"^match matches: (\d+)$")
    assert n_good > 500 and n_match > 500
    for label in ("ratio-test", "match"):
        (p,) = figure(stdout, rf"^{label} precision \(1 px\): ([\d.]+)%")
        assert p >= 90.0
    for name in ("knn_matches.png", "matches.png"):
        img = cv2.imread(str(out / name))
        assert img is not None and img.shape == (500, 2 * 741, 3)


def test_feature_matching_on_two_image_paths(tmp_path):
    from hopmatch.datasets import load_motorcycle

    scene = load_motorcycle()
    left, right = tmp_path / "l.png", tmp_path / "r.png"
    cv2.imwrite(str(left), scene.left[:, :400])
    cv2.imwrite(str(right), scene.right[:, :400])
    res = run_example("feature_matching.py", left, right, "--out", tmp_path / "out")
    stdout = ok(res)
    assert "precision" not in stdout  # no ground truth for user images
    (n_match,) = figure(stdout, r"^match matches: (\d+)$")
    assert n_match > 100
    assert (tmp_path / "out" / "matches.png").is_file()


def test_feature_matching_unreadable_image_exits_2(tmp_path):
    res = run_example("feature_matching.py", tmp_path / "no.png", tmp_path / "no2.png",
                      "--out", tmp_path)
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "cannot read the image" in res.stderr and "no.png" in res.stderr


# --------------------------------------------------------------------------------------
# stereo_calibration.py
# --------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def stereo_calibration(shared_data, tmp_path_factory):
    out = tmp_path_factory.mktemp("stereo_calibration")
    return run_example("stereo_calibration.py", "--out", out, shared=shared_data), out


def test_stereo_calibration_figures(stereo_calibration):
    """Calibration RMS, planarity and scale pass; the PLY is written. (The |dy| check of
    the rectified matches is the next test.)"""
    res, out = stereo_calibration
    assert res.returncode in (0, 1), (res.returncode, res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    failed = [ln for ln in res.stderr.splitlines() if "FAILED" in ln]
    assert all("|dy| <= 1 px" in ln for ln in failed), failed
    stdout = res.stdout
    assert figure(stdout, r"^chessboard found in: (\d+) of (\d+) pairs$") == (13.0, 13.0)
    (rms,) = figure(stdout, r"^calibration RMS: ([\d.]+) px$")
    assert rms < 1.0
    (n_match,) = figure(stdout, r"^matches: (\d+) ")
    assert n_match >= 20  # a PLY worth the name: 33 on pair 01 with OpenCV 4.14, 25 with 5.0
    (spacing,) = figure(stdout, r"^square size from triangulation: ([\d.]+) squares$")
    assert abs(spacing - 1.0) <= 0.02
    plane_sq, plane_mm = figure(stdout, r"^plane RMS: ([\d.]+) squares = ([\d.]+) mm")
    assert plane_sq <= 0.05 and plane_mm == pytest.approx(30 * plane_sq, abs=0.01)
    (n_ply,) = figure(stdout, r"^PLY: .*, (\d+) points")
    text = (out / "stereo_calibration.ply").read_text().splitlines()
    assert f"element vertex {int(n_ply)}" in text
    assert len(text) == text.index("end_header") + 1 + n_ply
    assert cv2.imread(str(out / "stereo_calibration_rectified.png")) is not None


def test_stereo_calibration_rectified_matches_meet_the_dy_goal(stereo_calibration):
    """With a 4 px band, >= 95 % of the matches of the rectified pairs have |dy| <= 1 px
    (all 13 pairs together); this needs the matcher's vertical check of every kept pair
    (the default, ``vertical_check="all"``): section 4 as written (``"multiple"``, printed
    beside it) lets off-row look-alikes of the chessboard through (docs/pipelines.md)."""
    res, _ = stereo_calibration
    (frac, n, pairs) = figure(res.stdout, r"^rectified \|dy\| <= 1 px: ([\d.]+)% of (\d+) "
                                          r"matches in the (\d+) pairs")
    assert frac >= 95.0 and pairs == 13 and n > 300
    (paper, n_paper) = figure(res.stdout, r"^  without the vertical check of every pair "
                                          r"\(vertical_check='multiple', .*\): ([\d.]+)% of "
                                          r"(\d+) matches")
    # section 4 as written keeps the off-row look-alikes the check of every pair removes:
    # about twice as many matches with |dy| > 1 px (OpenCV 4.14: 247 against 125 with the
    # seeds of 2026-12-02, 250 against 126 with the seeds of every unmatched point of
    # 2026-12-04). Counted, not as fractions: the guided pass and the seeds add matches on
    # the aligned rows to both (93.3 % against 96.7 % then, 94.7 % against 97.3 % now)
    assert n_paper * (100.0 - paper) >= 1.6 * n * (100.0 - frac)
    assert res.returncode == 0, res.stderr


def test_stereo_calibration_all_pairs(shared_data, tmp_path):
    """--all-pairs prints the |dy| figures of every pair and of all pairs together, the
    figures docs/pipelines.md quotes; the checks stay those of the default run."""
    res = run_example("stereo_calibration.py", "--all-pairs", "--out", tmp_path,
                      shared=shared_data)
    assert res.returncode in (0, 1), (res.returncode, res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    failed = [ln for ln in res.stderr.splitlines() if "FAILED" in ln]
    assert all("|dy| <= 1 px" in ln for ln in failed), failed
    stdout = res.stdout
    pairs = re.findall(r"^all pairs: pair (\d+): ", stdout, re.M)
    assert len(pairs) == 13 and pairs[0] == "01"
    # the 4 px band over all pairs is the checked figure of the default run, and pair 01's
    # figure is the one printed beside it
    (frac, pair01) = figure(stdout, r"^rectified \|dy\| <= 1 px: ([\d.]+)% of .*; "
                                    r"pair 01: ([\d.]+)% of")
    (frac01,) = figure(stdout, r"^all pairs: pair 01: .*?band 4 px: ([\d.]+)% of")
    (pooled,) = figure(stdout, r"^all pairs: band 4 px: ([\d.]+)% of")
    assert frac01 == pair01 and pooled == frac
    for band in ("4", "3", "2", "1.5"):
        p, n, lo, hi = figure(stdout, rf"^all pairs: band {re.escape(band)} px: ([\d.]+)% of "
                                      r"(\d+) matches with \|dy\| <= 1 px "
                                      r"\(per pair ([\d.]+)%\.\.([\d.]+)%")
        assert n > 13 and lo <= p <= hi
        if band == "4":  # the goal, over all pairs together
            assert p >= 95.0
    p, n = figure(stdout, r"^all pairs: corners: ([\d.]+)% of (\d+) with \|dy\| <= 1 px")
    assert n == 13 * 54 and p >= 95.0


# --------------------------------------------------------------------------------------
# uncalibrated.py
# --------------------------------------------------------------------------------------

def test_uncalibrated_on_the_chessboard_photos(shared_data, tmp_path):
    res = run_example("uncalibrated.py", "--out", tmp_path, shared=shared_data)
    stdout = ok(res)
    (rms,) = figure(stdout, r"^calibration \(for the check only\): 13 pairs, RMS ([\d.]+) px$")
    assert rms < 1.0
    (n,) = figure(stdout, r"^pair 01: ratio-test matches: (\d+)$")
    assert n >= 20
    (share,) = figure(stdout, r"^pair 01: within 1 px of the calibrated epipolar lines: "
                              r"([\d.]+)%$")
    assert share >= 90.0
    n_in, n_all = figure(stdout, r"^pair 01: FM_LMEDS inliers: (\d+) of (\d+)$")
    assert 8 <= n_in <= n_all == n
    (dy,) = figure(stdout, r"^pair 01: rectified inliers \|dy\|: median ([\d.]+) px$")
    assert dy <= 1.0
    for name in ("uncalibrated_epilines.png", "uncalibrated_rectified.png"):
        assert cv2.imread(str(tmp_path / name)) is not None


# --------------------------------------------------------------------------------------
# kitti_depth.py
# --------------------------------------------------------------------------------------

def test_kitti_depth(shared_data, tmp_path):
    res = run_example("kitti_depth.py", "--out", tmp_path, shared=shared_data)
    stdout = ok(res)
    f, b = figure(stdout, r"^focal length: ([\d.]+) px, baseline: ([\d.]+) m$")
    assert f == pytest.approx(718.856) and b == pytest.approx(0.537, abs=1e-3)
    n, n_gt = figure(stdout, r"^matches: (\d+), (\d+) with LiDAR ground truth$")
    assert n_gt > 100
    (median,) = figure(stdout, r"^median relative depth error: ([\d.]+)%$")
    (within,) = figure(stdout, r"^within 5%: ([\d.]+)%$")
    assert median <= 5.0 and within >= 90.0
    table = np.loadtxt(tmp_path / "kitti_depth.csv", delimiter=",", skiprows=1, ndmin=2)
    assert table.shape == (n, 5)
    has_gt = np.isfinite(table[:, 4])
    assert has_gt.sum() == n_gt
    rel = np.abs(table[has_gt, 3] - table[has_gt, 4]) / table[has_gt, 4]
    assert np.median(rel) * 100 == pytest.approx(median, abs=0.05)


# --------------------------------------------------------------------------------------
# stereo_match.py (OpenCV's stereo_match flow with hopmatch.StereoHopfield)
# --------------------------------------------------------------------------------------

def test_stereo_match_writes_a_ply_of_the_matched_points(shared_data, tmp_path):
    res = run_example("stereo_match.py", "--out", tmp_path, shared=shared_data)
    stdout = ok(res)
    lo, hi, unmatched = figure(stdout, r"^disparity: int16, 641x555, values (-?\d+)\.\.(\d+) "
                                       r"\(x16; no match: (-?\d+)\)$")
    assert lo == unmatched == 15 * 16 and hi <= 111 * 16
    n_pixels, n_matches = figure(stdout, r"^matched pixels: (\d+) \((\d+) matches\)$")
    assert n_matches >= n_pixels > 2000
    (n_ply,) = figure(stdout, r"^PLY: .*, (\d+) vertices$")
    assert n_ply == n_pixels
    text = (tmp_path / "out.ply").read_text().splitlines()
    assert f"element vertex {int(n_ply)}" in text
    assert len(text) == text.index("end_header") + 1 + n_ply
    n, p, scored = figure(stdout, r"^StereoHopfield: (\d+) pixels with a disparity, ([\d.]+)% of "
                                  r"the (\d+) with ground truth within 1 px$")
    assert n == n_pixels and scored > 0.9 * n and p >= 97.0
    (sgbm,) = figure(stdout, r"^StereoSGBM \(the sample's line\): (\d+) pixels")
    assert sgbm > n  # dense: nearly every pixel
