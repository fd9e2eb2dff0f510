"""Where ``match_stereo(left, right, rectified=False)`` goes wrong on the raw chessboard
photos (issue 18's goal: 95 % of the matches within 1 px of the calibrated epipolar lines):
the geometry it settles on, checked against the board's own corners.

Run: ``python benchmarks/chessboard_geometry.py [--pairs ID ...]`` (needs ``../shared/data``
or ``$HOPMATCH_SHARED_DATA``).

For each raw pair of ``opencv_stereo_calib`` (calibrated as ``benchmarks/unrectified.py``
does), the board's 9 x 6 inner corners found in both images (``cv2.findChessboardCorners``,
``cornerSubPix``) are true correspondences. Printed per pair:

- ``mode``, ``source``: how the network searched the pair (``aligned`` rows, the rows of a
  ``rectified`` frame, or the ``epipolar`` band) and where the reported F came from
  (``sift`` bootstrap or ``refit`` on the matches);
- ``on lines``: the share of the matches within 1 px of the calibrated epipolar lines (as
  ``benchmarks/unrectified.py --sections chessboards``);
- ``corners, calibrated``: median and largest distance (px) of the corners' correspondences
  to the calibrated epipolar lines (points undistorted first): what the check itself allows;
- ``corners, reported F``: the same to the epipolar lines of the F ``match_stereo`` reports
  (raw points): how far its geometry is from the truth on the board;
- ``board dy``, ``bootstrap dy``: in the frame the right image was aligned to (the
  similarity of :func:`hopmatch.matching.unrectified.aligned_frame`), the range of
  ``yl - yr`` over the board's corners and over the bootstrap inliers (5th to 95th
  percentile): the vertical offsets a row search would have to follow.

A second table asks how far the calibrated lines themselves can be trusted. The
calibration's board corners (all pairs) cover only part of each image (their convex hull,
the *calibrated area*); beyond it the distortion model extrapolates. Per pair: the share of
``match_stereo``'s matches within 1 px of the calibrated lines outside and inside that
area (a match is inside when both its points are, each in its own image's hull), and the
median signed distance (px) to the calibrated lines of SIFT + ratio 0.7 matches (2-D, no
geometry imposed; those within 3 px, the rest being wrong matches) outside and inside it.
SIFT's offset outside the area is the calibration's own error there, since nothing
constrains SIFT's matches to either side of a line.

``--smoke``: the first two pairs.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, single_thread  # noqa: E402
from unrectified import (  # noqa: E402
    board_corners,
    calibration,
    on_lines,
    undistorted_points,
)

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.matching.geometry import estimate_geometry, transform_points  # noqa: E402
from hopmatch.matching.unrectified import aligned_frame  # noqa: E402
from hopmatch.stereo import epipolar_distances  # noqa: E402


def corners(gray):
    """The board's inner corners (54, 2) float64 (:func:`unrectified.board_corners`), or
    None when not found."""
    c = board_corners(gray)
    return None if c is None else c.reshape(-1, 2).astype(np.float64)


def spread(values) -> str:
    return f"{np.median(values):.2f} / {np.max(values):.2f}"


def pair_row(folder, cal, i) -> str:
    left = cv2.imread(str(folder / f"left{i}.jpg"), cv2.IMREAD_GRAYSCALE)
    right = cv2.imread(str(folder / f"right{i}.jpg"), cv2.IMREAD_GRAYSCALE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = hopmatch.match_stereo(left, right, rectified=False)
    good, n = on_lines(cal, res.matched_left, res.matched_right, undistorted=False)
    cl, cr = corners(left), corners(right)
    cells = [res.geometry.search or "-", res.geometry.source,
             f"{good / n:.1%} of {n}" if n else "0 of 0"]
    if cl is None or cr is None or res.fundamental_matrix is None:
        return f"| {i} | " + " | ".join(cells + ["n/a"] * 4) + " |"
    ul, ur = undistorted_points(cal, cl, cr)
    cells.append(spread(epipolar_distances(ul, ur, cal.fundamental_matrix())))
    cells.append(spread(epipolar_distances(cl, cr, res.fundamental_matrix)))
    boot = estimate_geometry(left, right)  # the bootstrap match_stereo starts from
    if boot.fundamental is None:
        return f"| {i} | " + " | ".join(cells + ["n/a"] * 2) + " |"
    to_aligned = aligned_frame(boot, left.shape[::-1], right.shape[::-1])
    board_dy = cl[:, 1] - transform_points(cr, to_aligned)[:, 1]
    inl = boot.inliers
    boot_dy = (boot.left_points[inl, 1]
               - transform_points(boot.right_points[inl], to_aligned)[:, 1])
    lo, hi = np.percentile(boot_dy, [5, 95])
    cells += [f"{board_dy.min():.1f} .. {board_dy.max():.1f}", f"{lo:.1f} .. {hi:.1f}"]
    return f"| {i} | " + " | ".join(cells) + " |"


def signed_distances(cal, left, right) -> np.ndarray:
    """(N,) signed distance (px) of the raw right points to the calibrated epipolar lines of
    the raw left points (both undistorted first; the sign of ``l . x_r``)."""
    ul, ur = undistorted_points(cal, left, right)
    lines = np.c_[ul, np.ones(len(ul))] @ cal.fundamental_matrix().T
    return np.sum(lines * np.c_[ur, np.ones(len(ur))], axis=1) / np.hypot(lines[:, 0],
                                                                          lines[:, 1])


def calibrated_area(folder, used):
    """The convex hulls (float32 contours) of the board corners of every calibration pair,
    in the left and in the right images."""
    hulls = []
    for side in ("left", "right"):
        pts = [corners(cv2.imread(str(folder / f"{side}{i}.jpg"), cv2.IMREAD_GRAYSCALE))
               for i in used]
        hulls.append(cv2.convexHull(np.concatenate([c for c in pts if c is not None])
                                    .astype(np.float32)))
    return hulls


def inside(hull, points) -> np.ndarray:
    return np.array([cv2.pointPolygonTest(hull, (float(x), float(y)), False) >= 0
                     for x, y in np.reshape(points, (-1, 2))], dtype=bool)


def sift_matches(left, right, ratio=0.7):
    """SIFT + BFMatcher ratio ``ratio``: (left, right) (N, 2) float64 points."""
    sift = cv2.SIFT_create()
    kl, dl = sift.detectAndCompute(left, None)
    kr, dr = sift.detectAndCompute(right, None)
    if dl is None or dr is None or len(dr) < 2:
        return np.zeros((0, 2)), np.zeros((0, 2))
    good = [p[0] for p in cv2.BFMatcher().knnMatch(dl, dr, k=2)
            if len(p) == 2 and p[0].distance < ratio * p[1].distance]
    return (np.float64([kl[m.queryIdx].pt for m in good]).reshape(-1, 2),
            np.float64([kr[m.trainIdx].pt for m in good]).reshape(-1, 2))


def truth_row(folder, cal, hulls, i, totals) -> str:
    left = cv2.imread(str(folder / f"left{i}.jpg"), cv2.IMREAD_GRAYSCALE)
    right = cv2.imread(str(folder / f"right{i}.jpg"), cv2.IMREAD_GRAYSCALE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = hopmatch.match_stereo(left, right, rectified=False)
    cells = []
    d = np.abs(signed_distances(cal, res.matched_left, res.matched_right))
    area = inside(hulls[0], res.matched_left) & inside(hulls[1], res.matched_right)
    for k, where in enumerate((~area, area)):
        good, n = int(np.sum(d[where] <= 1.0)), int(where.sum())
        totals[k] = (totals[k][0] + good, totals[k][1] + n)
        cells.append(f"{good / n:.1%} of {n}" if n else "0 of 0")
    sl, sr = sift_matches(left, right)
    s = signed_distances(cal, sl, sr)
    plausible = np.abs(s) <= 3.0
    area = inside(hulls[0], sl) & inside(hulls[1], sr)
    for k, where in enumerate((~area & plausible, area & plausible)):
        totals[2 + k].append(s[where])
        cells.append(f"{np.median(s[where]):+.2f} ({where.sum()})" if where.any() else "-")
    return f"| {i} | " + " | ".join(cells) + " |"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", nargs="*", help="pair ids (default: every pair)")
    args = add_smoke_option(ap).parse_args(argv)
    single_thread()
    folder = datasets.shared_data_dir() / "opencv_stereo_calib"
    cal, used = calibration(folder)
    pairs = args.pairs or (used[:2] if args.smoke else used)
    print("## Raw chessboard pairs: the geometry match_stereo(rectified=False) settles on\n")
    print("| pair | mode | source | on lines | corners, calibrated (median / max px) | "
          "corners, reported F (median / max px) | board dy | bootstrap dy |")
    print("|---|---|---|---:|---:|---:|---:|---:|")
    for i in pairs:
        print(pair_row(folder, cal, i))
    print()
    hulls = calibrated_area(folder, used)
    share = (cv2.contourArea(hulls[0]) / (cal.image_size[0] * cal.image_size[1]))
    print("## Raw chessboard pairs: the calibrated lines outside and inside the calibrated "
          "area\n")
    print(f"calibrated area: the hull of the board corners of {len(used)} pairs, "
          f"{share:.0%} of the left image\n")
    print("| pair | match_stereo on lines, outside | inside | SIFT median signed px, "
          "outside (n) | inside (n) |")
    print("|---|---:|---:|---:|---:|")
    totals = [(0, 0), (0, 0), [], []]
    for i in pairs:
        print(truth_row(folder, cal, hulls, i, totals))
    (go, no), (gi, ni) = totals[0], totals[1]
    so, si = np.concatenate(totals[2]), np.concatenate(totals[3])
    print(f"\npooled: match_stereo {go / max(no, 1):.1%} of {no} on lines outside the "
          f"calibrated area, {gi / max(ni, 1):.1%} of {ni} inside; SIFT median signed "
          f"distance {np.median(so):+.2f} px outside ({len(so)}), {np.median(si):+.2f} px "
          f"inside ({len(si)})\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
