"""``hopmatch match --unrectified`` (hopmatch.cli.commands): match_stereo(rectified=False)
from the command line, through the real entry point."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
from cli_helpers import assert_bad_input, printed, read_csv, run

from hopmatch.cli.commands import read_fundamental_matrix

#: The right image of :func:`rotated_pair`: rotated by ANGLE degrees about the centre and
#: shifted down by SHIFT rows.
ANGLE, SHIFT = 3.0, 6.0


def texture(rng, shape) -> np.ndarray:
    """Smoothed noise, uint8: corners for Moravec and blobs for SIFT."""
    img = cv2.GaussianBlur(rng.random(shape).astype(np.float32), (0, 0), 2.0)
    return ((img - img.min()) / (img.max() - img.min()) * 255).astype(np.uint8)


@pytest.fixture(scope="module")
def rotated_pair(tmp_path_factory):
    """A rectified pair (disparity 8, a box at 20) whose right image is then rotated and
    shifted: (left path, right path, truth) with ``truth(left points) -> right points``."""
    folder = tmp_path_factory.mktemp("rotated")
    left = texture(np.random.default_rng(3), (360, 480))
    d = np.full(left.shape, 8.0, np.float32)
    d[100:260, 150:330] = 20.0
    ys, xs = np.mgrid[0:360, 0:480].astype(np.float32)
    right = cv2.remap(left, xs + d, ys, cv2.INTER_LINEAR)  # right(x) = left(x + d)
    A = cv2.getRotationMatrix2D((239.5, 179.5), ANGLE, 1.0)
    A[1, 2] += SHIFT
    right = cv2.warpAffine(right, A, (480, 360), flags=cv2.INTER_LINEAR)
    paths = folder / "left.png", folder / "right.png"
    assert cv2.imwrite(str(paths[0]), left) and cv2.imwrite(str(paths[1]), right)
    gt = np.full(left.shape, np.nan, np.float32)  # the left image's disparity
    xl = np.round(xs + d).astype(int)
    ok = xl < 480
    gt[ys[ok].astype(int), xl[ok]] = d[ok]

    def truth(pts):
        xi, yi = np.round(pts).astype(int).T
        disp = gt[yi, xi]
        return np.c_[pts[:, 0] - disp, pts[:, 1], np.ones(len(pts))] @ A.T, np.isfinite(disp)

    return paths[0], paths[1], truth


def test_match_unrectified(rotated_pair, tmp_path):
    left, right, truth = rotated_pair
    out = tmp_path / "out"
    res = run("match", left, right, "--out", out, "--unrectified")
    assert res.returncode == 0, res.stderr
    n = int(printed(res.stdout, "matches"))
    assert n > 1000
    assert printed(res.stdout, "geometry").startswith("F from ")
    _, rows = read_csv(out / "matches.csv")
    table = np.array(rows, dtype=np.float64)
    assert len(table) == n
    t, known = truth(table[:, :2])
    err = np.hypot(*(table[:, 2:4] - t).T)
    assert known.sum() > 0.9 * n and np.mean(err[known] <= 1.0) >= 0.97
    # the F written is the one of run.json, readable by --fundamental-matrix
    F = read_fundamental_matrix(str(out / "fundamental_matrix.txt"))
    info = json.loads((out / "run.json").read_text())
    geometry = info["geometry"]
    np.testing.assert_allclose(F, geometry["fundamental_matrix"], rtol=1e-9, atol=1e-15)
    assert geometry["inliers"] >= 30 and geometry["search"] in ("aligned", "rectified",
                                                                 "epipolar")
    assert info["parameters"]["unrectified"] is True
    assert info["parameters"]["matcher"]["vertical_threshold"] == 0.75
    xl = np.c_[table[:, :2], np.ones(n)]
    xr = np.c_[table[:, 2:4], np.ones(n)]
    lines = xl @ F.T
    dist = np.abs(np.sum(lines * xr, axis=1)) / np.hypot(lines[:, 0], lines[:, 1])
    assert np.median(dist) < 0.5


def test_match_without_unrectified_finds_that_pair_off_its_rows(rotated_pair, tmp_path):
    """Without --unrectified the pair is found far from rectified, said so in CLI terms,
    and matched as --unrectified matches it; with a disparity range its rows are searched
    and far less is found."""
    left, right, _ = rotated_pair
    plain = run("match", left, right, "--out", tmp_path / "plain")
    assert plain.returncode == 0, plain.stderr
    line = plain.stderr.strip()
    assert line.startswith("hopmatch: warning: the pair does not look rectified") \
        and "as --unrectified does" in line and "\n" not in line
    with_flag = run("match", left, right, "--out", tmp_path / "flag", "--unrectified")
    assert printed(plain.stdout, "matches") == printed(with_flag.stdout, "matches")
    assert (tmp_path / "plain" / "fundamental_matrix.txt").read_text() \
        == (tmp_path / "flag" / "fundamental_matrix.txt").read_text()
    info = json.loads((tmp_path / "plain" / "run.json").read_text())
    assert info["parameters"]["geometry_estimated"] and not info["parameters"]["unrectified"]
    rows = run("match", left, right, "--out", tmp_path / "rows", "--max-disparity", 40)
    assert rows.returncode == 0, rows.stderr
    assert int(printed(rows.stdout, "matches")) < int(printed(with_flag.stdout, "matches")) / 3


def test_a_given_fundamental_matrix_is_reported_as_given(rotated_pair, tmp_path):
    """--fundamental-matrix with no range lines the rows up by that F: run.json's geometry
    says source 'given' and the geometry is not called estimated, no fundamental_matrix.txt
    is written (the F is the user's), and the line about the geometry says it was given."""
    left, right, _ = rotated_pair
    A = cv2.getRotationMatrix2D((239.5, 179.5), ANGLE, 1.0)
    A[1, 2] += SHIFT
    F = np.linalg.inv(np.vstack([A, [0.0, 0.0, 1.0]])).T @ np.array(
        [[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    np.savetxt(tmp_path / "F.txt", F)
    res = run("match", left, right, "--out", tmp_path / "o", "--fundamental-matrix",
              tmp_path / "F.txt")
    assert res.returncode == 0, res.stderr
    assert "geometry: the given F, " in res.stdout and "searched aligned" in res.stdout
    assert not (tmp_path / "o" / "fundamental_matrix.txt").exists()
    info = json.loads((tmp_path / "o" / "run.json").read_text())
    assert not info["parameters"]["geometry_estimated"]
    assert info["geometry"]["source"] == "given" and info["geometry"]["inliers"] >= 30
    _, rows = read_csv(tmp_path / "o" / "matches.csv")
    assert len(rows) == int(printed(res.stdout, "matches")) > 1000


def test_unrectified_lets_the_sizes_differ(rotated_pair, tmp_path):
    left, right, _ = rotated_pair
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), cv2.imread(str(right), cv2.IMREAD_GRAYSCALE)[:340, :460])
    res = run("match", left, small, "--out", tmp_path / "o", "--unrectified")
    assert res.returncode == 0, res.stderr
    assert int(printed(res.stdout, "matches")) > 500


def test_vertical_threshold_given_wins(rotated_pair, tmp_path):
    left, right, _ = rotated_pair
    out = tmp_path / "o"
    res = run("match", left, right, "--out", out, "--unrectified", "--vertical-threshold", 1.5,
              "--no-draw")
    assert res.returncode == 0, res.stderr
    info = json.loads((out / "run.json").read_text())
    assert info["parameters"]["matcher"]["vertical_threshold"] == 1.5


@pytest.mark.parametrize("extra, words", [
    (["--max-disparity", "20"], "--max-disparity"),
    (["--min-disparity", "2"], "--min-disparity"),
    (["--fundamental-matrix", "F.txt"], "--fundamental-matrix"),
])
def test_unrectified_refuses_what_it_finds_itself(rotated_pair, tmp_path, extra, words):
    left, right, _ = rotated_pair
    out = tmp_path / "out"
    res = run("match", left, right, "--out", out, "--unrectified", *extra, cwd=tmp_path)
    assert_bad_input(res, "--unrectified", words)
    assert not out.exists()


def test_unrelated_images_warn_and_write_no_matches(rotated_pair, tmp_path):
    left, _, _ = rotated_pair
    other = tmp_path / "other.png"
    cv2.imwrite(str(other), texture(np.random.default_rng(11), (360, 480)))
    out = tmp_path / "out"
    res = run("match", left, other, "--out", out, "--unrectified", "--no-draw")
    assert res.returncode == 0, res.stderr
    assert int(printed(res.stdout, "matches")) == 0
    assert "no epipolar geometry" in res.stderr
    assert printed(res.stdout, "geometry").startswith("none found")
    assert not (out / "fundamental_matrix.txt").exists()
    info = json.loads((out / "run.json").read_text())
    assert info["geometry"]["fundamental_matrix"] is None and info["geometry"]["reason"]
