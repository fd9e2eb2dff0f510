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

A third table asks what one lens-distortion parameter, estimated from the pair itself,
would give (2026-12-06; nothing in the library does this yet). The division model
``x_u = c + (x_d - c) / (1 + lam r^2)`` (``c`` the image centre, ``r`` the distance to it
in half-diagonals) is estimated per pair from mutual SIFT + ratio 0.7 matches
(4000 points; :func:`estimate_division`: for each ``lam`` of :data:`LAMBDAS`, F by MAGSAC and by
reweighted eight-point fits from the ``lam = 0`` F, scored by the truncated squared
epipolar error of :data:`TRUNCATION` px; ``gain`` is the score's relative drop from ``lam =
0``). Both images are undistorted by it (:func:`undistorted_image`, on a canvas large
enough to keep every pixel, the rest masked), matched by ``match_stereo(...,
rectified=False, mask_left=..., mask_right=...)``, and the matches are distorted back and
scored as above: with the estimate (``lam = 0`` when ``|lam| < 0.04`` or ``gain < 0.03``),
and with the ``lam`` fitted to the calibration's own distortion (the mean of both
cameras', :func:`calibrated_division`) for every pair.

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
from hopmatch.matching.geometry import (  # noqa: E402
    estimate_geometry,
    magsac,
    symmetric_epipolar_error,
    transform_points,
)
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


def sift_matches(left, right, ratio=0.7, *, features=0, contrast=0.04, mutual=False):
    """SIFT (``features`` points, 0: all; ``contrast`` its contrast threshold) + BFMatcher
    ratio ``ratio``, with ``mutual`` only the matches that are also the best one back:
    (left, right) (N, 2) float64 points."""
    sift = cv2.SIFT_create(nfeatures=features, contrastThreshold=contrast)
    kl, dl = sift.detectAndCompute(left, None)
    kr, dr = sift.detectAndCompute(right, None)
    if dl is None or dr is None or len(dl) < 2 or len(dr) < 2:
        return np.zeros((0, 2)), np.zeros((0, 2))
    bf = cv2.BFMatcher(cv2.NORM_L2)
    back = ({m[0].queryIdx: m[0].trainIdx for m in bf.knnMatch(dr, dl, k=1) if m}
            if mutual else None)
    good = [p[0] for p in bf.knnMatch(dl, dr, k=2)
            if len(p) == 2 and p[0].distance < ratio * p[1].distance
            and (back is None or back.get(p[0].trainIdx) == p[0].queryIdx)]
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


#: The division-model parameters tried (third table) ...
LAMBDAS = np.round(np.arange(-0.3, 0.301, 0.02), 3)
#: ... the epipolar error (px) at which a correspondence's squared error is truncated ...
TRUNCATION = 1.5
#: ... and the estimate is used only when at least this far from 0 and this much better.
MIN_LAMBDA = 0.04
MIN_GAIN = 0.03


def division_undistort(points, lam, centre, scale) -> np.ndarray:
    """(N, 2) float64: ``points`` undistorted by the division model of the module doc."""
    q = (np.reshape(points, (-1, 2)).astype(np.float64) - centre) / scale
    return centre + scale * q / (1.0 + lam * np.sum(q * q, axis=1, keepdims=True))


def division_distort(points, lam, centre, scale) -> np.ndarray:
    """(N, 2) float64: the inverse of :func:`division_undistort` (the root of ``lam r_u
    r_d^2 - r_d + r_u = 0`` that tends to ``r_u`` as ``lam`` tends to 0)."""
    q = (np.reshape(points, (-1, 2)).astype(np.float64) - centre) / scale
    ru = np.hypot(q[:, 0], q[:, 1])
    if lam == 0.0:
        return centre + scale * q
    disc = np.sqrt(np.maximum(1.0 - 4.0 * lam * ru * ru, 0.0))
    factor = 2.0 / (1.0 + disc)  # r_d / r_u, rationalised: 1 at the centre, no division by r_u
    return centre + scale * q * factor[:, None]


def frame_of(shape):
    """``(centre, scale)`` of the division model for an image of ``shape``."""
    h, w = shape[:2]
    return np.array([(w - 1) / 2.0, (h - 1) / 2.0]), float(np.hypot(w, h)) / 2.0


def truncated_cost(left, right, F) -> tuple[float, np.ndarray]:
    """``(score, F)``: F refined by reweighted eight-point fits on the correspondences within
    :data:`TRUNCATION` px, and the sum of their truncated squared errors (in units of the
    truncation's square)."""
    for _ in range(5):
        inl = symmetric_epipolar_error(F, left, right) < TRUNCATION
        if inl.sum() < 8:
            break
        refit, _ = cv2.findFundamentalMat(left[inl], right[inl], cv2.FM_8POINT)
        if refit is None:
            break
        F = refit[:3]
    e = symmetric_epipolar_error(F, left, right)
    return float(np.minimum(e * e, TRUNCATION ** 2).sum() / TRUNCATION ** 2), F


def estimate_division(left, right) -> tuple[float, float]:
    """``(lam, gain)`` of the module doc's third table for two grey images."""
    pl, pr = sift_matches(left, right, features=4000, contrast=0.01, mutual=True)
    F0 = magsac(pl, pr, 1.0)[0] if len(pl) >= 15 else None
    if F0 is None:
        return 0.0, 0.0
    base, F0 = truncated_cost(pl, pr, F0)
    centre, scale = frame_of(left.shape)
    costs = []
    for lam in LAMBDAS:
        ul = division_undistort(pl, lam, centre, scale)
        ur = division_undistort(pr, lam, centre, scale)
        tries = [truncated_cost(ul, ur, F0)[0]]
        F = magsac(ul, ur, 1.0)[0]
        if F is not None:
            tries.append(truncated_cost(ul, ur, F)[0])
        costs.append(min(tries))
    k = int(np.argmin(costs))
    base = min(base, costs[int(np.argmin(np.abs(LAMBDAS)))])
    return float(LAMBDAS[k]), (base - costs[k]) / base if base > 0 else 0.0


def calibrated_division(cal) -> float:
    """The division ``lam`` closest (least squares over a 41 x 31 grid of the image) to the
    calibration's undistortion, the mean of both cameras'."""
    w, h = cal.image_size
    gx, gy = np.meshgrid(np.linspace(0, w - 1, 41), np.linspace(0, h - 1, 31))
    raw = np.c_[gx.ravel(), gy.ravel()]
    centre, scale = frame_of((h, w))
    fits = []
    for K, D in ((cal.K1, cal.D1), (cal.K2, cal.D2)):
        true = cv2.undistortPoints(raw.reshape(-1, 1, 2), K, D, P=K).reshape(-1, 2)
        true -= true.mean(axis=0) - raw.mean(axis=0)  # the model has no shift
        grid = np.linspace(-0.4, 0.4, 801)
        err = [np.sum((division_undistort(raw, lam, centre, scale) - true) ** 2)
               for lam in grid]
        fits.append(grid[int(np.argmin(err))])
    return float(np.mean(fits))


def undistorted_image(image, lam, centre, scale):
    """``(image, mask, offset)``: ``image`` undistorted by ``lam`` (Lanczos) on a canvas
    that keeps all of it (grown by ``1 / (1 + lam)`` for ``lam < 0``), where it holds
    image pixels (bool), and the canvas position of the image's (0, 0) frame origin."""
    h, w = image.shape[:2]
    grow = 1.0 / (1.0 + lam) if lam < 0 else 1.0
    W, H = int(np.ceil(w * grow)), int(np.ceil(h * grow))
    offset = np.array([(W - w) / 2.0, (H - h) / 2.0])
    yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
    src = division_distort(np.c_[xx.ravel(), yy.ravel()] - offset, lam, centre, scale)
    mx = src[:, 0].reshape(H, W).astype(np.float32)
    my = src[:, 1].reshape(H, W).astype(np.float32)
    out = cv2.remap(image, mx, my, cv2.INTER_LANCZOS4, borderMode=cv2.BORDER_REPLICATE)
    inside = cv2.remap(np.full((h, w), 255, np.uint8), mx, my, cv2.INTER_NEAREST,
                       borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    return out, inside > 0, offset


def undistorted_match(cal, left, right, lam) -> tuple[int, int]:
    """(on lines, matches) of ``match_stereo(rectified=False)`` on the pair undistorted by
    ``lam``, the matches distorted back to the raw images."""
    centre, scale = frame_of(left.shape)
    ul, ml, off = undistorted_image(left, lam, centre, scale)
    ur, mr, _ = undistorted_image(right, lam, centre, scale)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = hopmatch.match_stereo(ul, ur, rectified=False, mask_left=ml, mask_right=mr)
    back = [division_distort(p - off, lam, centre, scale)
            for p in (res.matched_left, res.matched_right)]
    return on_lines(cal, *back, undistorted=False)


def distortion_row(folder, cal, i, lam_cal, totals) -> str:
    left = cv2.imread(str(folder / f"left{i}.jpg"), cv2.IMREAD_GRAYSCALE)
    right = cv2.imread(str(folder / f"right{i}.jpg"), cv2.IMREAD_GRAYSCALE)
    lam, gain = estimate_division(left, right)
    used = lam if abs(lam) >= MIN_LAMBDA and gain >= MIN_GAIN else 0.0
    cells = [f"{lam:+.2f} ({gain:.3f})", f"{used:+.2f}"]
    for k, value in enumerate((0.0, used, lam_cal)):
        good, n = undistorted_match(cal, left, right, value)
        totals[k] = (totals[k][0] + good, totals[k][1] + n)
        cells.append(f"{good / n:.1%} of {n}" if n else "0 of 0")
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
    lam_cal = calibrated_division(cal)
    print("## Raw chessboard pairs: one lens-distortion parameter estimated from the pair\n")
    print(f"lam fitted to the calibration (mean of both cameras): {lam_cal:+.3f}\n")
    print("| pair | lam estimated (gain) | lam used | on lines, raw | undistorted by the "
          "estimate | by the calibration's lam |")
    print("|---|---:|---:|---:|---:|---:|")
    totals = [(0, 0)] * 3
    for i in pairs:
        print(distortion_row(folder, cal, i, lam_cal, totals), flush=True)
    print("\npooled: " + "; ".join(
        f"{name} {g / max(n, 1):.1%} of {n}" for name, (g, n) in
        zip(("raw", "estimated lam", "calibration's lam"), totals)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
