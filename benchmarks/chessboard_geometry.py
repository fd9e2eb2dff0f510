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
from unrectified import board_corners, calibration, on_lines  # noqa: E402

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
    ul = cv2.undistortPoints(cl.reshape(-1, 1, 2), cal.K1, cal.D1, P=cal.K1).reshape(-1, 2)
    ur = cv2.undistortPoints(cr.reshape(-1, 1, 2), cal.K2, cal.D2, P=cal.K2).reshape(-1, 2)
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
