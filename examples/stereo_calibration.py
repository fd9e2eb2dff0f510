#!/usr/bin/env python
"""Calibrated stereo: chessboard calibration, rectification, hopmatch, triangulation, PLY.

On OpenCV's stereo-calibration sample (``../shared/data/opencv_stereo_calib``: 13
chessboard pairs, 9 x 6 inner corners, 640 x 480):

1. ``cv2.findChessboardCorners`` + ``cv2.cornerSubPix`` on every pair;
   ``cv2.calibrateCamera`` for each camera, then ``cv2.stereoCalibrate`` with
   ``CALIB_FIX_INTRINSIC`` (the usual OpenCV flow). Object points are in squares.
2. ``cv2.stereoRectify`` + ``remap`` of one pair (``hopmatch.stereo.rectify``, alpha 0).
3. ``hopmatch.match_stereo`` on the rectified pair, ``hopmatch.stereo.triangulate_matches``
   with the rectified ``P1``, ``P2``, and ``hopmatch.stereo.write_ply`` (coloured points).

Checks (printed, and the exit status is 1 if one fails):

* calibration RMS reprojection error under 1 px;
* rectification: at least 95 % of the hopmatch matches with ``|dy| <= 1 px``. hopmatch's
  default search band is ``max_vertical = 1`` px, so with default parameters this holds
  by construction (the script prints that figure, marked so). The checked figure comes
  from runs with a band of ``DY_BAND = 4`` px, four times the tolerance, in which matches
  *can* land off the row, on every pair rectified with the calibration (all of them
  together: one pair's 25-50 matches make a noisy percentage; the ``--pair`` figure is
  printed beside). In those runs the matcher's vertical check
  (``vertical_check="all"``, the default: every kept pair within ``vertical_threshold``
  = 1 px of the *median* vertical disparity of the matches) removes the off-row
  look-alikes; what it cannot remove is an offset common to the matches, so the figure
  still measures the rectification (shifting the right images down by 2 px drops it to
  about 5 %: ``benchmarks/chessboard_dy.py --shift 2``). The script also prints the
  figure of section 4 as the paper
  writes it (``vertical_check="multiple"``), which lets off-row singular pairs through;
* planarity: the chessboard's inner corners, detected again in the rectified images and
  triangulated, lie on a plane within ``PLANE_TOLERANCE = 0.05`` square (RMS distance to
  the least-squares plane). Why 0.05: corner positions are good to about 0.1 px, i.e.
  about 0.14 px of disparity; at the board's depth Z (11-16 squares here) with baseline B
  (3.3 squares) and focal length f (about 500 px) that is a depth noise of
  ``Z**2 / (f B) * 0.14`` = 0.01-0.02 square. The tolerance is about 2.5 times that
  (a printed board is not perfectly flat either); the script prints the expected figure
  beside the measured one. The triangulated spacing of neighbouring corners must also be
  within 2 % of one square (a scale check).

The board's real square size is not recorded with OpenCV's sample; figures in mm use
``--square-size`` (default 30 mm, the illustrative value of OpenCV's calibration
tutorial) and scale with it; the figures in squares do not depend on it.

Usage::

    python examples/stereo_calibration.py [--pair NN] [--square-size MM] [--out DIR]
                                          [--all-pairs]

    --pair NN          which pair to rectify, match and triangulate (default 01)
    --square-size MM   chessboard square size in mm for the mm figures (default 30)
    --out DIR          where to write stereo_calibration.ply and
                       stereo_calibration_rectified.png (default ./hopmatch-examples)
    --all-pairs        also rectify every pair in which the board was found and print,
                       per pair and over all pairs together, the share of matches with
                       |dy| <= 1 px for search bands of ALL_PAIRS_BANDS = 4, 3, 2 and
                       1.5 px, and the |dy| of the chessboard corners detected again in
                       the rectified images (figures only: the checks stay those of
                       the default run)

Exit status: 0 when every check passes, 1 when one fails (the message says which), 2 when
``../shared/data`` (or ``$HOPMATCH_SHARED_DATA``) is missing or a pair cannot be read.
"""

from __future__ import annotations

import argparse
import os
import re
import sys

import cv2
import numpy as np

import hopmatch
from hopmatch.datasets import shared_data_dir
from hopmatch.errors import InvalidArgumentError
from hopmatch.stereo import calibrate_from_corners, rectify, triangulate_matches, write_ply

PATTERN = (9, 6)          #: inner corners per row, per column
RMS_GOAL = 1.0            #: px, calibration RMS reprojection error
DY_GOAL = 0.95            #: fraction of matches with |dy| <= 1 px after rectification
DY_BAND = 4.0             #: px, search band of the rectification check run
ALL_PAIRS_BANDS = (DY_BAND, 3.0, 2.0, 1.5)  #: px, search bands printed by --all-pairs
PLANE_TOLERANCE = 0.05    #: squares, RMS distance of the corners to their plane
SPACING_TOLERANCE = 0.02  #: relative error of the triangulated square size
CORNER_NOISE_PX = 0.1     #: assumed corner localisation error, for the expected figure
SUBPIX = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)


def find_data(name: str):
    """The folder ``name`` of the shared stereo data (``hopmatch.datasets.shared_data_dir``),
    or None after a message saying what is missing."""
    try:
        folder = shared_data_dir() / name
    except InvalidArgumentError as exc:
        print(f"stereo_calibration: error: {exc}", file=sys.stderr)
        return None
    if not folder.is_dir():
        print(f"stereo_calibration: error: the shared stereo data has no {name!r} folder "
              f"({str(folder)!r} does not exist)", file=sys.stderr)
        return None
    return folder


def corners(gray):
    """Refined inner corners (54, 2) float32, or None when the board is not found."""
    found, pts = cv2.findChessboardCorners(gray, PATTERN)
    if not found:
        return None
    return cv2.cornerSubPix(gray, pts, (11, 11), (-1, -1), SUBPIX).reshape(-1, 2)


def calibrate(folder):
    """``(StereoCalibration, rms, pair ids, image size)`` from every pair in ``folder``."""
    ids = sorted(m.group(1) for p in folder.glob("left*.jpg")
                 if (m := re.fullmatch(r"left(\d+)\.jpg", p.name))
                 and (folder / f"right{m.group(1)}.jpg").is_file())
    grid = np.zeros((PATTERN[0] * PATTERN[1], 3), np.float32)
    grid[:, :2] = np.mgrid[0:PATTERN[0], 0:PATTERN[1]].T.reshape(-1, 2)  # in squares
    obj, left_pts, right_pts, used = [], [], [], []
    size = None
    for i in ids:
        gl = cv2.imread(str(folder / f"left{i}.jpg"), cv2.IMREAD_GRAYSCALE)
        gr = cv2.imread(str(folder / f"right{i}.jpg"), cv2.IMREAD_GRAYSCALE)
        if gl is None or gr is None:
            raise FileNotFoundError(f"cannot read pair {i} in {folder}")
        size = gl.shape[::-1]
        cl, cr = corners(gl), corners(gr)
        if cl is not None and cr is not None:
            obj.append(grid)
            left_pts.append(cl)
            right_pts.append(cr)
            used.append(i)
    if len(used) < 3:
        raise FileNotFoundError(f"the chessboard was found in only {len(used)} pairs in {folder}")
    # cv2.calibrateCamera per camera, then cv2.stereoCalibrate with the intrinsics fixed,
    # single-threaded: the same calibration in every run
    cal, rms = calibrate_from_corners(obj, left_pts, right_pts, size)
    return cal, rms, ids, used


def plane_fit(xyz):
    """RMS and max distance of the points to their least-squares plane."""
    centred = xyz - xyz.mean(axis=0)
    normal = np.linalg.svd(centred, full_matrices=False)[2][2]
    dist = centred @ normal
    return float(np.sqrt(np.mean(dist ** 2))), float(np.abs(dist).max())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pair", default="01", help="pair to rectify and match (default 01)")
    parser.add_argument("--square-size", type=float, default=30.0,
                        help="chessboard square size in mm (default 30, assumed)")
    parser.add_argument("--out", default="hopmatch-examples", help="output folder")
    parser.add_argument("--all-pairs", action="store_true",
                        help="also print the |dy| figures of every pair and of all pairs "
                             "together (figures only)")
    args = parser.parse_args(argv)
    if not args.square_size > 0:
        parser.error("--square-size must be positive")

    folder = find_data("opencv_stereo_calib")
    if folder is None:
        return 2
    try:
        cal, rms, ids, used = calibrate(folder)
    except FileNotFoundError as exc:
        print(f"stereo_calibration: error: {exc}", file=sys.stderr)
        return 2
    if args.pair not in ids:
        print(f"stereo_calibration: error: no pair {args.pair!r}; available: {', '.join(ids)}",
              file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    sq = args.square_size
    print(f"data: {folder}")
    print(f"chessboard found in: {len(used)} of {len(ids)} pairs")
    print(f"calibration RMS: {rms:.3f} px")
    print(f"baseline: {cal.baseline:.3f} squares ({cal.baseline * sq:.1f} mm)")

    left = cv2.imread(str(folder / f"left{args.pair}.jpg"))
    right = cv2.imread(str(folder / f"right{args.pair}.jpg"))
    cal_all = cal  # before rectify() adds one pair's rectification
    left_r, right_r, cal = rectify(left, right, cal, alpha=0.0)
    cv2.imwrite(os.path.join(args.out, "stereo_calibration_rectified.png"),
                _with_rows(np.hstack([left_r, right_r])))

    # hopmatch on the rectified pair, default parameters
    res = hopmatch.match_stereo(left_r, right_r)
    dy = np.abs(res.matched_left[:, 1] - res.matched_right[:, 1])
    print(f"pair: {args.pair}")
    print(f"matches: {len(res.matches)} (default band max_vertical=1 px: "
          f"{np.mean(dy <= 1.0):.1%} with |dy| <= 1 px by construction)")
    # the rectification check: a band wider than the tolerance, on every rectified pair
    rectified = list(rectified_pairs(folder, used, cal_all))
    wide = match_dy(rectified, max_vertical=DY_BAND)
    wdy = np.concatenate(list(wide.values()))
    dy_frac = float(np.mean(wdy <= 1.0)) if len(wdy) else float("nan")
    median_dy = float(np.median(wdy)) if len(wdy) else float("nan")
    mine = wide.get(args.pair, np.zeros(0))
    print(f"rectified |dy| <= 1 px: {dy_frac:.1%} of {len(wdy)} matches in the {len(wide)} "
          f"pairs (search band max_vertical={DY_BAND:g} px; median |dy| {median_dy:.2f} px; "
          f"pair {args.pair}: {np.mean(mine <= 1.0) if len(mine) else float('nan'):.1%} of "
          f"{len(mine)})")
    pdy = np.concatenate(list(match_dy(rectified, max_vertical=DY_BAND,
                                       vertical_check="multiple").values()))
    print(f"  without the vertical check of every pair (vertical_check='multiple', section 4 "
          f"as written): {np.mean(pdy <= 1.0) if len(pdy) else float('nan'):.1%} of "
          f"{len(pdy)} matches with |dy| <= 1 px (figure only)")

    # triangulate the matches and write the point cloud (mm)
    xyz = triangulate_matches(res.matched_left, res.matched_right, cal.P1, cal.P2) * sq
    px = np.rint(res.matched_left).astype(int)
    colours = np.ascontiguousarray(left_r[px[:, 1], px[:, 0], ::-1])
    ply = os.path.join(args.out, "stereo_calibration.ply")
    n_ply = write_ply(ply, xyz, colours)
    print(f"PLY: {ply}, {n_ply} points, median depth {np.nanmedian(xyz[:, 2]):.0f} mm")

    # planarity of the board's corners, detected again in the rectified images
    failures = []
    if rms >= RMS_GOAL:
        failures.append(f"calibration RMS {rms:.3f} px is not under {RMS_GOAL} px")
    if not dy_frac >= DY_GOAL:
        failures.append(f"only {dy_frac:.1%} of the matches have |dy| <= 1 px after "
                        f"rectification (goal {DY_GOAL:.0%}, band {DY_BAND:g} px)")
    gl = cv2.cvtColor(left_r, cv2.COLOR_BGR2GRAY)
    gr = cv2.cvtColor(right_r, cv2.COLOR_BGR2GRAY)
    cl, cr = corners(gl), corners(gr)
    if cl is None or cr is None:
        failures.append(f"the chessboard was not found in rectified pair {args.pair}")
    else:
        if abs(cl[0, 1] - cr[0, 1]) > abs(cl[0, 1] - cr[-1, 1]):
            cr = cr[::-1].copy()  # the two detections started from opposite corners
        board = triangulate_matches(cl, cr, cal.P1, cal.P2)  # squares
        plane_rms, plane_max = plane_fit(board)
        grid = board.reshape(PATTERN[1], PATTERN[0], 3)
        spacing = float(np.mean(np.concatenate([
            np.linalg.norm(np.diff(grid, axis=1), axis=2).ravel(),
            np.linalg.norm(np.diff(grid, axis=0), axis=2).ravel()])))
        z = float(board[:, 2].mean())
        f = float(cal.P1[0, 0])
        expected = z ** 2 / (f * cal.baseline) * CORNER_NOISE_PX * np.sqrt(2)
        cdy = np.abs(cl[:, 1] - cr[:, 1])
        print(f"corner |dy| after rectification: median {np.median(cdy):.2f} px, "
              f"max {cdy.max():.2f} px")
        print(f"board depth: {z:.1f} squares ({z * sq:.0f} mm)")
        print(f"square size from triangulation: {spacing:.4f} squares")
        print(f"plane RMS: {plane_rms:.4f} squares = {plane_rms * sq:.2f} mm "
              f"(max {plane_max * sq:.2f} mm; tolerance {PLANE_TOLERANCE} squares = "
              f"{PLANE_TOLERANCE * sq:.2f} mm; expected from {CORNER_NOISE_PX} px corner noise: "
              f"{expected:.4f} squares)")
        if not plane_rms <= PLANE_TOLERANCE:
            failures.append(f"the triangulated corners are {plane_rms:.4f} squares RMS from "
                            f"their plane (tolerance {PLANE_TOLERANCE})")
        if not abs(spacing - 1.0) <= SPACING_TOLERANCE:
            failures.append(f"the triangulated square size is {spacing:.4f} squares "
                            f"(tolerance {SPACING_TOLERANCE:.0%})")
    if args.all_pairs:
        all_pairs(folder, used, cal_all)
    for failure in failures:
        print(f"stereo_calibration: FAILED: {failure}", file=sys.stderr)
    return 1 if failures else 0


def rectified_corners(left_r, right_r):
    """Corners detected again in a rectified pair, ``(left, right)`` in the same order, or
    None when the board is not found in one of the images."""
    cl = corners(cv2.cvtColor(left_r, cv2.COLOR_BGR2GRAY))
    cr = corners(cv2.cvtColor(right_r, cv2.COLOR_BGR2GRAY))
    if cl is None or cr is None:
        return None
    if abs(cl[0, 1] - cr[0, 1]) > abs(cl[0, 1] - cr[-1, 1]):
        cr = cr[::-1].copy()  # the two detections started from opposite corners
    return cl, cr


def rectified_pairs(folder, used, cal):
    """``(pair id, rectified left, rectified right)`` for every pair in ``used``."""
    for i in used:
        left = cv2.imread(str(folder / f"left{i}.jpg"))
        right = cv2.imread(str(folder / f"right{i}.jpg"))
        left_r, right_r, _ = rectify(left, right, cal, alpha=0.0)
        yield i, left_r, right_r


def match_dy(rectified, **params):
    """``{pair id: |dy| of each hopmatch match}`` over rectified pairs."""
    out = {}
    for i, left_r, right_r in rectified:
        res = hopmatch.match_stereo(left_r, right_r, **params)
        out[i] = np.abs(res.matched_left[:, 1] - res.matched_right[:, 1])
    return out


def all_pairs(folder, used, cal):
    """``--all-pairs``: the |dy| figures of every pair in ``used`` and of all of them
    together (matches for each band of ``ALL_PAIRS_BANDS``, and chessboard corners)."""
    pooled = {band: [] for band in ALL_PAIRS_BANDS}
    per_pair = {band: [] for band in ALL_PAIRS_BANDS}
    corner_dy, worst = [], (-1.0, None, None)
    for i, left_r, right_r in rectified_pairs(folder, used, cal):
        cells = []
        for band in ALL_PAIRS_BANDS:
            dy = match_dy([(i, left_r, right_r)], max_vertical=band)[i]
            pooled[band].append(dy)
            frac = float(np.mean(dy <= 1.0)) if len(dy) else float("nan")
            per_pair[band].append(frac)
            cells.append(f"band {band:g} px: {frac:.1%} of {len(dy)}")
        found = rectified_corners(left_r, right_r)
        if found is None:
            cells.append("corners: board not found after rectification")
        else:
            cl, cr = found
            cdy = np.abs(cl[:, 1] - cr[:, 1])
            corner_dy.append(cdy)
            k = int(np.argmax(cdy))
            if cdy[k] > worst[0]:
                worst = (float(cdy[k]), i, cl[k])
            cells.append(f"corner |dy| median {np.median(cdy):.2f} px, max {cdy.max():.2f} px")
        print(f"all pairs: pair {i}: matches with |dy| <= 1 px: " + "; ".join(cells))
    for band in ALL_PAIRS_BANDS:
        dy = np.concatenate(pooled[band])
        fracs = [f for f in per_pair[band] if np.isfinite(f)]
        print(f"all pairs: band {band:g} px: {np.mean(dy <= 1.0):.1%} of {len(dy)} matches "
              f"with |dy| <= 1 px (per pair {min(fracs):.1%}..{max(fracs):.1%}; "
              f"median |dy| {np.median(dy):.2f} px)")
    if corner_dy:
        cdy = np.concatenate(corner_dy)
        size, pair, at = worst
        print(f"all pairs: corners: {np.mean(cdy <= 1.0):.1%} of {len(cdy)} with |dy| <= 1 px "
              f"(median {np.median(cdy):.2f} px; max {size:.2f} px, pair {pair} at "
              f"x {at[0]:.0f}, y {at[1]:.0f} of the rectified left image)")


def _with_rows(image, step=40):
    """Horizontal lines every ``step`` rows, to check rectification by eye."""
    out = image.copy()
    for y in range(step // 2, out.shape[0], step):
        cv2.line(out, (0, y), (out.shape[1] - 1, y), (0, 255, 0), 1)
    return out


if __name__ == "__main__":
    sys.exit(main())
