#!/usr/bin/env python
"""Uncalibrated stereo: OpenCV's epipolar-geometry tutorial with hopmatch, then rectification.

On OpenCV's stereo-calibration photos (``../shared/data/opencv_stereo_calib``,
``leftNN.jpg`` / ``rightNN.jpg``, 640 x 480): two photos of a chessboard from two cameras
that nobody rectified. The flow of OpenCV's Python tutorial *Epipolar Geometry*
(``detectAndCompute`` on both images, ``knnMatch`` k=2 + Lowe's ratio test 0.8,
``cv2.findFundamentalMat(pts1, pts2, cv2.FM_LMEDS)``, ``cv2.computeCorrespondEpilines``
and its ``drawlines``), with only the detector and matcher creation changed, plus the two
calls a hopmatch matcher needs: ``setPairInfo`` (the keypoints) and
``estimateFundamentalMatrix`` (the pair is not rectified: the matcher finds its epipolar
geometry from the keypoints and descriptors, then searches along it). Then
``cv2.stereoRectifyUncalibrated`` with the LMEDS inliers and ``cv2.warpPerspective``.

One step comes before the tutorial's: the photos are undistorted with the cameras'
intrinsics (``cv2.undistort``). A fundamental matrix relates pinhole images; these lenses
bend lines by several pixels near the borders (k1 = 0.3 on one camera), which no F can
follow to 1 px. The pair stays uncalibrated: nothing about its rotation or baseline is
used. The intrinsics come from ``cv2.calibrateCamera`` of the chessboard corners of the 13
pairs (as ``examples/stereo_calibration.py`` computes them): the shipped
``intrinsics.yml`` fits these photos only to 1.8 px RMS (``cv2.stereoCalibrate`` with it
fixed), the corners' own calibration to 0.45 px.

Checked against the calibrated geometry: ``cv2.stereoCalibrate`` of the corners with those
intrinsics fixed gives ``R, T`` and the calibrated ``F = K2^-T [T]x R K1^-1``; the figure
is the share of the ratio-test matches within 1 px of its epipolar lines
(``hopmatch.stereo.epipolar_distances``, mean of both images).

Usage::

    python examples/uncalibrated.py [--pair NN] [--all-pairs] [--out DIR]

    --pair NN     the pair to match (default 01)
    --all-pairs   also match every pair and print the figure for each and for all
                  together (figures only; the check is the --pair one)
    --out DIR     where to write uncalibrated_epilines.png (the tutorial's drawing) and
                  uncalibrated_rectified.png (the rectified pair, a line every 40 rows);
                  default ./hopmatch-examples

Checks: the fundamental matrix is found; at least 90 % of the ratio-test matches lie
within 1 px of the calibrated epipolar lines; the LMEDS inliers, rectified, differ in y by
at most 1 px (median). Exit status: 0 when they pass, 1 when one fails (the message says
which), 2 when ``../shared/data`` (or ``$HOPMATCH_SHARED_DATA``) or the photos are
missing.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

import cv2
import numpy as np

import hopmatch
from hopmatch.datasets import shared_data_dir
from hopmatch.errors import InvalidArgumentError
from hopmatch.stereo import calibrate_from_corners, epipolar_distances

FOLDER = "opencv_stereo_calib"
PATTERN = (9, 6)          #: inner corners of the chessboard
RATIO = 0.8               #: Lowe's ratio, as in OpenCV's tutorial
ON_LINE_GOAL = 0.90       #: share of the matches within 1 px of the calibrated lines
RECTIFIED_DY_GOAL = 1.0   #: median |dy| of the rectified LMEDS inliers, px
SUBPIX = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)


def find_data():
    """The folder of the chessboard photos, or None after a message saying what is
    missing."""
    try:
        folder = shared_data_dir() / FOLDER
    except InvalidArgumentError as exc:
        print(f"uncalibrated: error: {exc}", file=sys.stderr)
        return None
    if not folder.is_dir() or not pair_ids(folder):
        print(f"uncalibrated: error: the shared stereo data has no {FOLDER!r} photos "
              f"({str(folder)!r} holds no leftNN.jpg / rightNN.jpg)", file=sys.stderr)
        return None
    return folder


def pair_ids(folder):
    return sorted(p.name[4:-4] for p in folder.glob("left*.jpg")
                  if (folder / f"right{p.name[4:]}").is_file())


def calibration(folder):
    """``((K1, D1, K2, D2), F, rms, pairs)``: the intrinsics (``cv2.calibrateCamera`` per
    camera) and the calibrated F of undistorted pixels (``cv2.stereoCalibrate``, intrinsics
    fixed) from the chessboard corners of every pair."""
    grid = np.zeros((PATTERN[0] * PATTERN[1], 3), np.float32)
    grid[:, :2] = np.mgrid[0:PATTERN[0], 0:PATTERN[1]].T.reshape(-1, 2)
    obj, lp, rp, size = [], [], [], None
    for i in pair_ids(folder):
        corners = []
        for side in ("left", "right"):
            gray = cv2.imread(str(folder / f"{side}{i}.jpg"), cv2.IMREAD_GRAYSCALE)
            size = gray.shape[::-1]
            found, c = cv2.findChessboardCorners(gray, PATTERN)
            corners.append(cv2.cornerSubPix(gray, c, (11, 11), (-1, -1), SUBPIX)
                           if found else None)
        if all(c is not None for c in corners):
            obj.append(grid)
            lp.append(corners[0])
            rp.append(corners[1])
    cal, rms = calibrate_from_corners(obj, lp, rp, size)  # single-threaded: reproducible
    f = cal.fundamental_matrix()
    return (cal.K1, cal.D1, cal.K2, cal.D2), f, rms, len(obj)


def drawlines(img1, img2, lines, pts1, pts2):
    """OpenCV's tutorial function: the epilines of ``pts2`` over ``img1``, and the points."""
    r, c = img1.shape
    img1 = cv2.cvtColor(img1, cv2.COLOR_GRAY2BGR)
    img2 = cv2.cvtColor(img2, cv2.COLOR_GRAY2BGR)
    rng = np.random.default_rng(0)
    for r_, pt1, pt2 in zip(lines, pts1, pts2):
        color = tuple(int(v) for v in rng.integers(0, 255, 3))
        x0, y0 = map(int, [0, -r_[2] / r_[1]])
        x1, y1 = map(int, [c, -(r_[2] + r_[0] * c) / r_[1]])
        img1 = cv2.line(img1, (x0, y0), (x1, y1), color, 1)
        img1 = cv2.circle(img1, tuple(int(v) for v in pt1), 5, color, -1)
        img2 = cv2.circle(img2, tuple(int(v) for v in pt2), 5, color, -1)
    return img1, img2


def tutorial(img1, img2):
    """The tutorial's matching with hopmatch: ``(pts1, pts2, F, mask)`` (F None when the
    matcher finds no epipolar geometry)."""
    detector = hopmatch.DericheMoravecDetector.create()       # was cv2.SIFT_create()
    kp1, des1 = detector.detectAndCompute(img1, None)
    kp2, des2 = detector.detectAndCompute(img2, None)
    matcher = hopmatch.HopfieldMatcher.create()                # was cv2.FlannBasedMatcher
    matcher.setPairInfo(kp1, kp2, img1.shape[::-1], img2.shape[::-1])
    if matcher.estimateFundamentalMatrix(des1, des2).fundamental is None:
        return None
    matches = matcher.knnMatch(des1, des2, k=2)
    pts1, pts2 = [], []
    for m, n in matches:                                       # the ratio test, as is
        if m.distance < RATIO * n.distance:
            pts2.append(kp2[m.trainIdx].pt)
            pts1.append(kp1[m.queryIdx].pt)
    # the tutorial rounds to np.int32 here; the points are sub-pixel, keep them so
    pts1, pts2 = np.float32(pts1), np.float32(pts2)
    F, mask = cv2.findFundamentalMat(pts1, pts2, cv2.FM_LMEDS)
    return pts1, pts2, F, mask


def match_pair(folder, i, intrinsics, f_cal):
    """``(images, tutorial result, share on the calibrated lines, n)`` of pair ``i``."""
    m1, d1, m2, d2 = intrinsics
    img1 = cv2.undistort(cv2.imread(str(folder / f"left{i}.jpg"), cv2.IMREAD_GRAYSCALE), m1, d1)
    img2 = cv2.undistort(cv2.imread(str(folder / f"right{i}.jpg"), cv2.IMREAD_GRAYSCALE), m2, d2)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", hopmatch.errors.HopmatchWarning)
        out = tutorial(img1, img2)
    for w in caught:
        print(f"pair {i}: warning: {w.message}")
    if out is None or len(out[0]) == 0:
        return (img1, img2), out, float("nan"), 0
    pts1, pts2 = out[0], out[1]
    d = epipolar_distances(pts1, pts2, f_cal)
    return (img1, img2), out, float(np.mean(d <= 1.0)), len(d)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pair", default="01", help="pair number (default 01)")
    parser.add_argument("--all-pairs", action="store_true", help="also match every pair")
    parser.add_argument("--out", default="hopmatch-examples", help="output folder")
    args = parser.parse_args(argv)

    folder = find_data()
    if folder is None:
        return 2
    if not (folder / f"left{args.pair}.jpg").is_file():
        print(f"uncalibrated: error: no pair {args.pair!r} in {str(folder)!r}", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    intrinsics, f_cal, rms, n_cal = calibration(folder)
    print(f"calibration (for the check only): {n_cal} pairs, RMS {rms:.3f} px")

    (img1, img2), out, share, n = match_pair(folder, args.pair, intrinsics, f_cal)
    failures = []
    if out is None:
        failures.append(f"pair {args.pair}: no fundamental matrix found")
    else:
        pts1, pts2, F, mask = out
        print(f"pair {args.pair}: ratio-test matches: {n}")
        print(f"pair {args.pair}: within 1 px of the calibrated epipolar lines: {share:.1%}")
        inl = mask.ravel() == 1
        pts1, pts2 = pts1[inl], pts2[inl]
        print(f"pair {args.pair}: FM_LMEDS inliers: {inl.sum()} of {len(inl)}")
        lines1 = cv2.computeCorrespondEpilines(pts2.reshape(-1, 1, 2), 2, F).reshape(-1, 3)
        img5, _ = drawlines(img1, img2, lines1, pts1, pts2)
        lines2 = cv2.computeCorrespondEpilines(pts1.reshape(-1, 1, 2), 1, F).reshape(-1, 3)
        img3, _ = drawlines(img2, img1, lines2, pts2, pts1)
        cv2.imwrite(os.path.join(args.out, "uncalibrated_epilines.png"), np.hstack([img5, img3]))
        size = img1.shape[::-1]
        ok, H1, H2 = cv2.stereoRectifyUncalibrated(pts1, pts2, F, size)
        if not ok:
            failures.append(f"pair {args.pair}: cv2.stereoRectifyUncalibrated failed")
        else:
            r1 = cv2.perspectiveTransform(pts1.reshape(-1, 1, 2).astype(np.float64), H1)
            r2 = cv2.perspectiveTransform(pts2.reshape(-1, 1, 2).astype(np.float64), H2)
            dy = float(np.median(np.abs(r1[:, 0, 1] - r2[:, 0, 1])))
            print(f"pair {args.pair}: rectified inliers |dy|: median {dy:.2f} px")
            if not dy <= RECTIFIED_DY_GOAL:
                failures.append(f"rectified |dy| median {dy:.2f} px > {RECTIFIED_DY_GOAL} px")
            sbs = np.hstack([cv2.warpPerspective(img1, H1, size),
                             cv2.warpPerspective(img2, H2, size)])
            sbs = cv2.cvtColor(sbs, cv2.COLOR_GRAY2BGR)
            for y in range(20, sbs.shape[0], 40):
                cv2.line(sbs, (0, y), (sbs.shape[1] - 1, y), (0, 255, 0), 1)
            cv2.imwrite(os.path.join(args.out, "uncalibrated_rectified.png"), sbs)
        if not share >= ON_LINE_GOAL:
            failures.append(f"pair {args.pair}: {share:.1%} of the matches within 1 px of the "
                            f"calibrated epipolar lines, below {ON_LINE_GOAL:.0%}")

    if args.all_pairs:
        on, total, found = 0, 0, 0
        for i in pair_ids(folder):
            _, out_i, share_i, n_i = match_pair(folder, i, intrinsics, f_cal)
            found += out_i is not None
            on += round(share_i * n_i) if n_i else 0
            total += n_i
            print(f"pair {i}: " + (f"{n_i} matches, {share_i:.1%} within 1 px" if n_i
                                   else "no fundamental matrix found"))
        print(f"all pairs: F found in {found} of {len(pair_ids(folder))}; {on} of {total} "
              f"matches ({on / max(total, 1):.1%}) within 1 px of the calibrated lines")

    for failure in failures:
        print(f"uncalibrated: FAILED: {failure}", file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
