"""Smoke run of ``benchmarks/unrectified.py`` (the figures of issue 18 that
docs/pipelines.md and docs/parameters.md quote): it runs and prints every section; and its
ground truth of the upsampled pair against a slow reference."""

from __future__ import annotations

import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
from shared_data import SHARED_DATA

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
    assert re.search(r"^time \(best of 3\): [\d.]+ s; peak memory \d+ MB; SIFT "
                     r"detectAndCompute on both images [\d.]+ s \(ratio [\d.]+\)$", out, re.M)
    assert re.search(r"^stages of the last run: detect_left [\d.]+ s, detect_right [\d.]+ s, "
                     r"network [\d.]+ s, guided [\d.]+ s, refine [\d.]+ s$", out, re.M)
    assert re.search(r"^precision at 1 px by ground truth: flat [\d.]+ of \d+; slanted "
                     r"(?:[\d.]+|nan) of \d+; edge (?:[\d.]+|nan) of \d+; mean error within "
                     r"2 px [+-][\d.]+ px$", out, re.M)
    assert re.search(r"^\| middlebury/tsukuba \| -?[\d.]+\.\.[\d.]+ \| 5\.0\.\.14\.0 \| "
                     r"1\.0000 \|$", out, re.M)
    assert re.search(r"^mean error within 2 px by ground truth: flat [+-][\d.]+; slanted "
                     r"(?:[+-][\d.]+|nan); edge (?:[+-][\d.]+|nan); on the original pair "
                     r"\(within [\d.]+ px\) x [\d.]+: [+-][\d.]+ px$", out, re.M)
    assert re.search(r"^with the nearest original pixel as truth: precision 0\.\d+ at 1 px, "
                     r"mean error within 2 px [+-][\d.]+ px$", out, re.M)
    assert "## Ground truth against its own images (photometric fit, no matcher)" in out
    assert re.search(r"^\| motorcycle \| [+-][\d.]+ \| [+-][\d.]+ \| [+-][\d.]+ \| [+-][\d.]+ \| "
                     r"[+-][\d.]+ \| \d+ / \d+ \| 0\.\d+ \| 0\.\d+ \|$", out, re.M)
    assert re.search(r"^## A known fundamental matrix: match_stereo\(left, right, "
                     r"fundamental_matrix=F\), right image \+2 deg, \+8 px, x1$", out, re.M)
    assert re.search(r"^\| middlebury/tsukuba \| \d+ \| \d+ \| 0\.\d+ \| \d+ \| \d+ \| "
                     r"\d+ \| \d+ \| 0\.\d+ \| (aligned|rectified|epipolar|band) \| \d+ \|$",
                     out, re.M)
    for label in ("With the range", "Without"):
        assert re.search(rf"^{label}: \d+ correct of \d+ scored \(0\.\d+\), [\d.]+ s in "
                         r"all$", out, re.M)


def test_unrectified_large_scene_smoke(shared_data):
    """--large-scene / --large-factor (docs/parameters.md quotes ArtL upsampled 8 times)."""
    env = {**os.environ, "HOPMATCH_SHARED_DATA": str(SHARED_DATA)}
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "unrectified.py"),
                           "--smoke", "--sections", "large", "--large-scene",
                           "middlebury/tsukuba", "--large-factor", "1.5"], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"^## Large pair: middlebury/tsukuba upsampled to 576 x 432, ",
                     proc.stdout, re.M)
    assert re.search(r"^precision: 0\.\d+ at 1 px, 0\.\d+ at 2 px", proc.stdout, re.M)


def _unrectified():
    """benchmarks/unrectified.py as a module (it imports benchmarks/_common.py)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    spec = importlib.util.spec_from_file_location("unrectified",
                                                  ROOT / "benchmarks" / "unrectified.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _reference_truth(disparity, x, y, factor, surface):
    """One point of ``upsampled_truth``, written out: the pixel-centre position of
    cv2.resize, its 2 x 2 original pixels, bilinear on one surface, else the nearest."""
    xs, ys = (x + 0.5) / factor - 0.5, (y + 0.5) / factor - 0.5
    h, w = disparity.shape
    xn, yn = int(np.floor(xs + 0.5)), int(np.floor(ys + 0.5))
    if not (0 <= xn < w and 0 <= yn < h):
        return np.nan
    x0, y0 = min(max(int(np.floor(xs)), 0), w - 2), min(max(int(np.floor(ys)), 0), h - 2)
    q = [disparity[y0 + j, x0 + i] for j in (0, 1) for i in (0, 1)]
    if surface >= 0 and np.all(np.isfinite(q)) and max(q) - min(q) <= surface:
        tx, ty = min(max(xs - x0, 0.0), 1.0), min(max(ys - y0, 0.0), 1.0)
        v = (1 - ty) * ((1 - tx) * q[0] + tx * q[1]) + ty * ((1 - tx) * q[2] + tx * q[3])
    else:
        v = disparity[yn, xn]
    return v * factor


def test_upsampled_truth_matches_a_slow_reference():
    m = _unrectified()
    yy, xx = np.mgrid[0:20, 0:30].astype(np.float64)
    gt = 10.0 + 0.3 * xx + 0.2 * yy  # a plane ...
    gt[:, 18:] += 15.0  # ... with a depth edge ...
    gt[12:15, 3:6] = np.nan  # ... and unknown pixels
    rng = np.random.default_rng(0)
    pts = np.c_[rng.uniform(-3, 123, 3000), rng.uniform(-3, 83, 3000)]
    for surface in (1.0, -1.0):
        got = m.upsampled_truth(gt, pts, 4, surface)
        want = np.array([_reference_truth(gt, x, y, 4, surface) for x, y in pts])
        np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    # on one surface: the plane itself, at the position cv2.resize samples
    inner = (pts[:, 0] > 2) & (pts[:, 0] < 68) & (pts[:, 1] > 2) & (pts[:, 1] < 42)  # rows < 11
    plane = 4 * (10.0 + 0.3 * ((pts[:, 0] + 0.5) / 4 - 0.5) + 0.2 * ((pts[:, 1] + 0.5) / 4 - 0.5))
    np.testing.assert_allclose(m.upsampled_truth(gt, pts, 4)[inner], plane[inner], atol=1e-9)
    # nearest everywhere: the map cv2.INTER_NEAREST upsamples, read at the nearest pixel
    big = cv2.resize(gt.astype(np.float32), (120, 80), interpolation=cv2.INTER_NEAREST) * 4
    ok = (pts >= 0).all(axis=1) & (pts[:, 0] < 119.5) & (pts[:, 1] < 79.5)
    xi, yi = np.floor(pts[ok] + 0.5).astype(int).T
    np.testing.assert_allclose(m.upsampled_truth(gt, pts[ok], 4, -1.0), big[yi, xi], rtol=1e-6)


def test_a_verged_perturbation_and_its_truth_agree():
    """``--verge``: the right image warped by perturbation(..., verge) and the truth map
    ``apply`` are one map in one direction: the warped image read at ``A (x, y)`` is the
    original read at (x, y) (inside the image), for the affine perturbations as for the
    verged homography; and a verged map is not affine (its rows do not stay parallel)."""
    m = _unrectified()
    rng = np.random.default_rng(2)
    image = cv2.GaussianBlur(rng.random((240, 320)).astype(np.float32), (0, 0), 3.0)
    pts = np.c_[rng.uniform(60, 260, 200), rng.uniform(50, 190, 200)]
    for verge in (0.0, 4.0, -4.0):
        A = m.perturbation((320, 240), 2.0, 8.0, 1.01, verge)
        assert A.shape == ((2, 3) if verge == 0 else (3, 3))
        moved = m.apply(A, pts).astype(np.float32)
        warped = m.warp(image, A, (320, 240))
        got = cv2.remap(warped, moved[:, :1], moved[:, 1:], cv2.INTER_LINEAR).ravel()
        want = cv2.remap(image, pts[:, :1].astype(np.float32), pts[:, 1:].astype(np.float32),
                         cv2.INTER_LINEAR).ravel()
        np.testing.assert_allclose(got, want, atol=2e-3)
    corners = np.array([[0.0, 0.0], [319.0, 0.0], [0.0, 239.0], [319.0, 239.0]])
    top, bottom = m.apply(m.perturbation((320, 240), 0.0, 0.0, 1.0, 4.0), corners).reshape(
        2, 2, 2)
    assert abs((bottom[0, 1] - top[0, 1]) - (bottom[1, 1] - top[1, 1])) > 1.0  # keystone


def test_unrectified_defaults_smoke(shared_data):
    """--defaults: the perturbed pairs matched by match_stereo(left, right) with no
    parameter, the search column saying how (the smallest perturbation first)."""
    env = {**os.environ, "HOPMATCH_SHARED_DATA": str(SHARED_DATA)}
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "unrectified.py"),
                           "--smoke", "--sections", "perturbed", "--defaults"], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert "## Perturbed pairs: match_stereo(left, right)\n" in proc.stdout
    assert re.search(r"^\| middlebury/tsukuba \| \+0\.5 deg, \+2 px, x1 \| \d+ \| \d+ \| "
                     r"0\.\d+ \| \d+ \| [\d.]+ \| [\d.]+ \| .+ \| (rows|aligned|rectified|"
                     r"epipolar) \| [\d.]+ \|$", proc.stdout, re.M)
