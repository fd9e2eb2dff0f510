"""Unrectified pairs and self-finding disparity ranges (issue 18): the figures of its goals.

Run: ``python benchmarks/unrectified.py [--sections perturbed chessboards large ranges
truth fundamental]
[--verge DEG] [--defaults] [--params JSON] [--scenes NAME ...] [--refine-radius N]
[--large-scene NAME --large-factor F] [--large-params JSON]``
(single thread; needs ``../shared/data`` or ``$HOPMATCH_SHARED_DATA`` for every section but
``large``).

- ``perturbed``: every shared scene with ground truth, its right image warped by
  :data:`PERTURBATIONS` (rotation about the centre in degrees, vertical shift in px, scale;
  ``cv2.warpAffine``, bilinear), matched by ``match_stereo(left, right, rectified=False)``
  with no other parameter. A match is correct when its right point is within 1 px (2-D,
  Euclidean) of the truth ``A (xl - d, yl)``; ``ref`` is what the defaults find on the
  rectified pair with its range given (``min/max_disparity`` = ground-truth range +- 1 px,
  correct@1px as ``hopmatch eval`` scores it), ``bound`` the share of those reference
  matches whose right point stays in the warped image. ``F err`` is the distance of 2000
  true correspondences (from the ground truth) to the epipolar lines of the returned F:
  median and 95th percentile, px; ``search`` how the pair was searched (``rows``: as a
  rectified pair). ``--defaults``: ``match_stereo(left, right)`` with no parameter instead
  (the rectification check decides whether the pair is matched as unrectified), over
  :data:`DEFAULTS_PERTURBATIONS` (smaller ones too). ``--verge DEG``: every perturbation
  after the right camera turned by DEG degrees about its vertical axis (a homography,
  ``K R K^-1`` with a focal length of the image's width: a verged rig, whose rows no
  similarity aligns). ``--params JSON``: more ``match_stereo`` parameters for this
  section's calls and the chessboards' (``'{"both_features": true}'``); ``ref`` keeps the
  defaults.
- ``chessboards``: OpenCV's 13 chessboard pairs, raw and undistorted with their
  calibration (:func:`hopmatch.stereo.calibrate_from_corners` of the chessboard corners,
  as ``examples/stereo_calibration.py`` does: intrinsics by ``cv2.calibrateCamera``,
  extrinsics by ``cv2.stereoCalibrate``, in one OpenCV thread so that every process
  undistorts the images alike); the share of
  matches within 1 px of the calibrated epipolar lines (points undistorted first), for
  ``match_stereo(..., rectified=False)`` and for the cv2 path
  (``HopfieldMatcher.estimateFundamentalMatrix`` then ``match``).
- ``large``: motorcycle upsampled to 2964 x 2000 (as ``benchmarks/scale.py``), rectified,
  ``match_stereo(left, right)`` with no parameter, in a fresh process: time (best of
  three calls, and the stages of the last), peak memory, the range found, precision at 1
  and 2 px of the upsampled ground truth, and SIFT ``detectAndCompute`` on both images for
  scale (best of three); then precision at 1 px by where the
  matches lie (the spread of the original ground truth over the 5 x 5 original pixels
  around each: flat below 0.5 px, slanted 0.5-5, a depth edge from 5 px) and the mean
  signed disparity error of the matches within 2 px; last, the same mean error of
  ``match_stereo`` on the original pair (within 2 / factor px), times the factor. The
  truth of a match is :func:`upsampled_truth` (the original map read bilinearly at the
  pixel-centre position of ``cv2.resize``); "nearest" figures read the nearest original
  pixel instead (``cv2.INTER_NEAREST`` of the map, as before this reading).
  ``--large-scene NAME --large-factor F``: that shared scene upsampled F times instead
  (e.g. ``middlebury2014/ArtL`` and 8: a full-size pair whose widened range exceeds the
  candidate budget), and any warning ``match_stereo`` gave. ``--large-params JSON``: those
  ``match_stereo`` parameters in both calls (e.g. ``'{"rectified": false}'``: the pair
  matched as an unrectified one, its geometry estimated).
- ``truth``: how well each scene's ground truth fits its own images, without a matcher
  (:func:`truth_fit`): the offset ``c`` and the gradient terms ``sx gx + sy gy`` that,
  added to the ground truth, give the lowest photometric error of the right image warped
  into the left (locally normalised, cubic B-spline sampling), and the vertical offset;
  then ``match_stereo``'s defaults against the ground truth as given (median signed
  disparity error, wrong matches too large and too small, precision at 1 px) and their
  precision against it plus ``c`` (how much of a scene's precision its truth's offset
  costs). ``--scenes`` replaces :data:`TRUTH_SCENES` (any scene with dense ground truth).
- ``ranges``: the range ``max_disparity=None`` finds on every shared scene against its
  ground truth (share of ground-truth pixels inside).
- ``fundamental``: a pair whose geometry is known: every shared scene, its right image
  warped by :data:`FUNDAMENTAL_PERTURBATION`, matched by ``match_stereo(left, right,
  fundamental_matrix=F)`` with the true ``F`` of the warp, once with the ground truth's
  range widened by :data:`FUNDAMENTAL_MARGIN` (the epipolar band of
  ``hopmatch._kernels.candidates.epipolar_candidates``; with the candidate pairs of the
  network) and once with no range (the rows lined up by F, or the band when too few
  correspondences agree with F; how it searched): matches, correct (within 1 px, 2-D),
  precision and the time (best of three, one thread). Run it in two checkouts to compare
  them.

``--refine-radius N``: refine with that window half-side instead of the size rule of
``hopmatch.matching.stereo_match.refine_radius`` (every section; docs/parameters.md,
"Refinement window and image size").

``--smoke``: motorcycle (centre crop) and tsukuba, one perturbation, two chessboard pairs,
a 1000 x 675 large pair, ``truth`` on a crop of motorcycle: a check that the script works
(figures meaningless).
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
import warnings
from pathlib import Path

import cv2
import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _common import (  # noqa: E402
    add_refine_radius_option,
    add_smoke_option,
    force_refine_radius,
    single_thread,
    smoke_scene,
    smoke_scenes,
)

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.evaluate import score_matches  # noqa: E402
from hopmatch.matching.geometry import symmetric_epipolar_error  # noqa: E402
from hopmatch.stereo import calibrate_from_corners, epipolar_distances  # noqa: E402

#: (rotation in degrees, vertical shift in px, scale) of the right image: the extremes of
#: the issue's range both ways, and the pair of its "where it stands" paragraph.
PERTURBATIONS = ((5.0, 30.0, 1.03), (-5.0, -30.0, 0.97), (2.0, 8.0, 1.0))
#: ``--defaults``: also smaller perturbations, which a rectification check may let pass.
DEFAULTS_PERTURBATIONS = ((0.5, 2.0, 1.0), (1.0, 4.0, 1.0), (-3.0, -15.0, 0.99)) + PERTURBATIONS
SECTIONS = ("perturbed", "chessboards", "large", "ranges", "truth", "fundamental")
#: The ``fundamental`` section's perturbation: rotation (degrees), vertical shift (px), scale.
FUNDAMENTAL_PERTURBATION = (2.0, 8.0, 1.0)
#: ... and how far its disparity range reaches beyond the ground truth's (px): the
#: rotation moves the columns too.
FUNDAMENTAL_MARGIN = 20.0
PATTERN = (9, 6)
#: The scenes of the ``truth`` section by default: the large pair's and Middlebury 2014's.
TRUTH_SCENES = ("motorcycle", "middlebury2014/MotorcycleE", "middlebury2014/Teddy",
                "middlebury2014/ArtL")
LARGE = (2964, 2000)
SMOKE_LARGE = (1000, 675)


def perturbation(size, angle, dy, scale, verge=0.0) -> np.ndarray:
    """The map of the right image: the 2 x 3 affine map of a rotation about the centre, a
    scale and a vertical shift; with ``verge`` (degrees), the 3 x 3 homography of that
    map after the right camera turned by ``verge`` about its vertical axis (``K R K^-1``,
    ``K`` a focal length of the image's width, centred: a verged rig)."""
    w, h = size
    A = cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), angle, scale)
    A[1, 2] += dy
    if not verge:
        return A
    K = np.array([[w, 0.0, (w - 1) / 2], [0.0, w, (h - 1) / 2], [0.0, 0.0, 1.0]])
    R = cv2.Rodrigues(np.array([0.0, np.radians(verge), 0.0]))[0]
    return np.vstack([A, [0.0, 0.0, 1.0]]) @ K @ R @ np.linalg.inv(K)


def warp(image, A, size):
    """``image`` moved by the map ``A`` of :func:`perturbation` (bilinear)."""
    if A.shape[0] == 2:
        return cv2.warpAffine(image, A, size, flags=cv2.INTER_LINEAR)
    return cv2.warpPerspective(image, A, size, flags=cv2.INTER_LINEAR)


def apply(A, points) -> np.ndarray:
    """(N, 2) float64: ``points`` mapped by ``A`` (2 x 3 affine, or 3 x 3 homography)."""
    t = np.c_[np.asarray(points, np.float64).reshape(-1, 2), np.ones(len(points))] @ A.T
    return t[:, :2] / t[:, 2:] if A.shape[0] == 3 else t


def truth(left_pts, disparity, A):
    """``(true right points, known)``: ``A (xl - d, yl)`` of each left point and whether its
    ground truth is known and the point lands inside the warped image."""
    h, w = disparity.shape
    xi = np.floor(left_pts[:, 0] + 0.5).astype(int)
    yi = np.floor(left_pts[:, 1] + 0.5).astype(int)
    ok = (xi >= 0) & (xi < w) & (yi >= 0) & (yi < h)
    d = np.full(len(left_pts), np.nan)
    d[ok] = disparity[yi[ok], xi[ok]]
    with np.errstate(invalid="ignore"):
        t = apply(A, np.c_[left_pts[:, 0] - d, left_pts[:, 1]])
    known = np.isfinite(d) & (t[:, 0] >= 0) & (t[:, 0] <= w - 1) & (t[:, 1] >= 0) & (
        t[:, 1] <= h - 1)
    return t, known


def upsampled_truth(disparity, points, factor, surface=1.0):
    """(N,) float64: the ground truth of the pair upsampled ``factor`` times by
    ``cv2.resize`` at its ``points`` (N x 2, x y of the upsampled image), in upsampled px.

    ``disparity`` (the original map) is read at the original position ``((x + 0.5) /
    factor - 0.5, (y + 0.5) / factor - 0.5)`` (``cv2.resize``'s pixel centres), bilinearly
    where the 2 x 2 original pixels around it are known and within ``surface`` px of one
    another (one surface), else at the nearest original pixel (NaN where unknown or
    outside); times ``factor``. ``surface < 0``: the nearest pixel everywhere (what
    ``cv2.INTER_NEAREST`` of the map gives at an integer factor)."""
    g = np.asarray(disparity, dtype=np.float64)
    h, w = g.shape
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    xs, ys = (pts[:, 0] + 0.5) / factor - 0.5, (pts[:, 1] + 0.5) / factor - 0.5
    xn, yn = np.floor(xs + 0.5).astype(int), np.floor(ys + 0.5).astype(int)
    inside = (xn >= 0) & (xn < w) & (yn >= 0) & (yn < h)
    out = np.full(len(pts), np.nan)
    out[inside] = g[yn[inside], xn[inside]]
    x0 = np.clip(np.floor(xs).astype(int), 0, w - 2)
    y0 = np.clip(np.floor(ys).astype(int), 0, h - 2)
    tx, ty = np.clip(xs - x0, 0.0, 1.0), np.clip(ys - y0, 0.0, 1.0)
    q = np.stack([g[y0, x0], g[y0, x0 + 1], g[y0 + 1, x0], g[y0 + 1, x0 + 1]])
    with np.errstate(invalid="ignore"):
        one = inside & np.isfinite(q).all(axis=0) & (q.max(axis=0) - q.min(axis=0) <= surface)
    bil = ((1 - ty) * ((1 - tx) * q[0] + tx * q[1]) + ty * ((1 - tx) * q[2] + tx * q[3]))
    out[one] = bil[one]
    return out * factor


def truth_fit(scene, samples=200_000, seed=0):
    """``(c, sx, sy, dy)``: the ground truth of ``scene`` fitted to its own images: the
    right image (locally normalised over 7 x 7 pixels, cubic B-spline) sampled at ``(x -
    (d + c + sx gx + sy gy), y - dy)`` is closest (mean squared difference) to the left at
    ``samples`` known pixels (x, y) on smooth ground truth, d the ground truth there and
    (gx, gy) its central-difference gradient; coordinate search on 0.01 px (offsets) and
    0.02 (gradient terms) grids, three rounds."""
    import scipy.ndimage as ndi

    def norm(image):
        i = (cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image)
        i = i.astype(np.float64)
        mu = cv2.blur(i, (7, 7))
        sd = np.sqrt(np.maximum(cv2.blur(i * i, (7, 7)) - mu * mu, 0.0))
        return (i - mu) / (sd + 2.0)

    left, coef = norm(scene.left), ndi.spline_filter(norm(scene.right), order=3)
    g = scene.disparity.astype(np.float64)
    gx = np.full_like(g, np.nan)
    gy = np.full_like(g, np.nan)
    gx[:, 1:-1] = (g[:, 2:] - g[:, :-2]) / 2
    gy[1:-1] = (g[2:] - g[:-2]) / 2
    ok = np.isfinite(g) & (np.abs(gx) < 1) & (np.abs(gy) < 1)
    ok &= np.arange(g.shape[1])[None, :] - np.nan_to_num(g) > 10
    ys, xs = np.nonzero(ok)
    k = np.random.default_rng(seed).choice(len(xs), min(samples, len(xs)), replace=False)
    ys, xs = ys[k], xs[k]
    d, a, gxk, gyk = g[ys, xs], left[ys, xs], gx[ys, xs], gy[ys, xs]

    def error(c, sx, sy, dy):
        v = ndi.map_coordinates(coef, [ys - dy, xs - (d + c + sx * gxk + sy * gyk)], order=3,
                                prefilter=False, mode="nearest")
        return float(np.mean((a - v) ** 2))

    p = dict(c=0.0, sx=0.0, sy=0.0, dy=0.0)
    grids = dict(c=np.arange(-100, 101) / 100, sx=np.arange(-40, 41) / 50,
                 sy=np.arange(-40, 41) / 50, dy=np.arange(-50, 51) / 100)
    for _ in range(3):
        for key, grid in grids.items():
            p[key] = float(grid[int(np.argmin([error(**dict(p, **{key: v})) for v in grid]))])
    return p["c"], p["sx"], p["sy"], p["dy"]


def truth_fits(names, smoke: bool) -> None:
    print("## Ground truth against its own images (photometric fit, no matcher)\n")
    print("Then `match_stereo(left, right)` (defaults) against the ground truth as given: the "
          "median signed disparity error of its scored matches, its wrong matches (beyond "
          "1 px) whose disparity is too large and too small, and its precision at 1 px; "
          "last, that precision against the ground truth plus the offset c.\n")
    print("| scene | offset c | sx (gx) | sy (gy) | vertical | median error | wrong: too "
          "large / small | precision | precision, truth + c |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for name in names:
        scene = datasets.load(name)
        if smoke:
            scene = smoke_scene(scene)
        c, sx, sy, dy = truth_fit(scene, samples=20_000 if smoke else 200_000)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", hopmatch.errors.HopmatchWarning)
            r = hopmatch.match_stereo(scene.left, scene.right)
        given, shifted = (score_matches(r.matched_left, r.matched_right, truth,
                                        thresholds=(1.0,))
                          for truth in (scene.disparity, scene.disparity + c))
        e = given.errors
        med = float(np.median(e)) if len(e) else float("nan")
        print(f"| {name} | {c:+.2f} | {sx:+.2f} | {sy:+.2f} | {dy:+.2f} | {med:+.3f} | "
              f"{int(np.sum(e > 1.0))} / {int(np.sum(e < -1.0))} | "
              f"{given.precision[1.0]:.3f} | {shifted.precision[1.0]:.3f} |", flush=True)
    print()


def reference(scene):
    """(correct@1px, matches) of the defaults on the rectified pair, its range given."""
    v = scene.disparity[np.isfinite(scene.disparity)]
    r = hopmatch.match_stereo(scene.left, scene.right, min_disparity=float(np.floor(v.min())) - 1,
                              max_disparity=float(np.ceil(v.max())) + 1)
    s = score_matches(r.matched_left, r.matched_right, scene.disparity, thresholds=(1.0,))
    ok = np.zeros(len(r.query_idx), bool)
    ok[np.flatnonzero(s.scored)[np.abs(s.errors) <= 1.0]] = True
    ok &= np.abs(r.matched_left[:, 1] - r.matched_right[:, 1]) <= 1.0
    return s.correct[1.0], r.matched_right[ok]


def f_error(F, scene, A, rng) -> tuple[float, float]:
    """Median and 95th percentile distance of 2000 true correspondences to F's lines."""
    ys, xs = np.nonzero(np.isfinite(scene.disparity))
    k = rng.choice(len(xs), min(2000, len(xs)), replace=False)
    left = np.c_[xs[k], ys[k]].astype(np.float64)
    right, known = truth(left, scene.disparity, A)
    e = symmetric_epipolar_error(F, left[known], right[known, :2])
    return float(np.median(e)), float(np.percentile(e, 95))


def perturbed(names, perturbations, verge=0.0, defaults=False, params=None) -> None:
    params = dict(params or {})
    given = "".join(f", {k}={v!r}" for k, v in params.items())
    call = (f"match_stereo(left, right{given})" if defaults
            else f"match_stereo(left, right, rectified=False{given})")
    print(f"## Perturbed pairs: {call}"
          + (f", the right camera also verged by {verge:g} degrees" if verge else "") + "\n")
    print("| scene | rotation, shift, scale | matches | correct | precision | ref | ratio | "
          "bound | F err median / p95 | search | s |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---|---:|")
    rng = np.random.default_rng(0)
    tot_c = tot_n = tot_ref = 0
    ratios, precisions, f_medians = [], [], []
    for name in names:
        scene = datasets.load(name)
        if name == "motorcycle" and len(names) <= 2:  # --smoke
            scene = smoke_scene(scene)
        ref, ref_right = reference(scene)
        for angle, dy, scale in perturbations:
            A = perturbation(scene.image_size, angle, dy, scale, verge)
            right = warp(scene.right, A, scene.image_size)
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = hopmatch.match_stereo(scene.left, right, **params,
                                          **({} if defaults else {"rectified": False}))
            seconds = time.perf_counter() - t0
            t, known = truth(r.matched_left, scene.disparity, A)
            ok = known & (np.hypot(*(r.matched_right - t[:, :2]).T) <= 1.0)
            n, c = int(known.sum()), int(ok.sum())
            moved = apply(A, ref_right)
            h, w = scene.shape
            bound = float(np.mean((moved[:, 0] >= 7) & (moved[:, 0] <= w - 8) & (moved[:, 1] >= 7)
                                  & (moved[:, 1] <= h - 8))) if len(moved) else float("nan")
            fe = f_error(r.fundamental_matrix, scene, A, rng) if r.fundamental_matrix is not None \
                else (float("nan"), float("nan"))
            p = c / n if n else float("nan")
            ratio = c / ref if ref else float("nan")
            tot_c, tot_n, tot_ref = tot_c + c, tot_n + n, tot_ref + ref
            ratios.append(ratio)
            precisions.append(p)
            f_medians.append(fe[0])
            print(f"| {name} | {angle:+g} deg, {dy:+g} px, x{scale:g} | {len(r.query_idx)} | {c} | "
                  f"{p:.3f} | {ref} | {ratio:.2f} | {bound:.2f} | {fe[0]:.2f} / {fe[1]:.2f} | "
                  f"{r.geometry.search if r.geometry else 'rows'} | {seconds:.2f} |",
                  flush=True)
    print(f"\nAll pairs: {tot_c} correct of {tot_n} scored (pooled precision {tot_c / tot_n:.4f}), "
          f"{tot_c / tot_ref:.3f}x the reference's {tot_ref} correct; per pair: ratio mean "
          f"{np.nanmean(ratios):.3f}, min {np.nanmin(ratios):.2f}; precision min "
          f"{np.nanmin(precisions):.3f}; F error median of medians "
          f"{np.nanmedian(f_medians):.2f} px, max {np.nanmax(f_medians):.2f} px\n")


def board_corners(gray):
    """The chessboard's inner corners in the grey image (``cv2.findChessboardCorners``,
    refined by ``cv2.cornerSubPix``): (N, 1, 2) float32, or None when not found."""
    found, c = cv2.findChessboardCorners(gray, PATTERN)
    if not found:
        return None
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3)
    return cv2.cornerSubPix(gray, c, (11, 11), (-1, -1), crit)


def calibration(folder):
    """The stereo calibration of the chessboard pairs in ``folder``
    (:func:`hopmatch.stereo.calibrate_from_corners`) and their ids."""
    ids = sorted(m.group(1) for p in folder.glob("left*.jpg")
                 if (m := re.fullmatch(r"left(\d+)\.jpg", p.name)))
    grid = np.zeros((PATTERN[0] * PATTERN[1], 3), np.float32)
    grid[:, :2] = np.mgrid[0:PATTERN[0], 0:PATTERN[1]].T.reshape(-1, 2)
    obj, lp, rp, used, size = [], [], [], [], None
    for i in ids:
        gl = cv2.imread(str(folder / f"left{i}.jpg"), cv2.IMREAD_GRAYSCALE)
        gr = cv2.imread(str(folder / f"right{i}.jpg"), cv2.IMREAD_GRAYSCALE)
        cl, cr = board_corners(gl), board_corners(gr)
        if cl is not None and cr is not None:
            obj.append(grid)
            lp.append(cl)
            rp.append(cr)
            used.append(i)
        size = gl.shape[::-1]
    # the library's calibration: OpenCV's calibrateCamera in several threads gives a
    # slightly different calibration in each process, and then different undistorted images
    cal, _ = calibrate_from_corners(obj, lp, rp, size)
    return cal, used


def undistorted_points(cal, left, right):
    """``(left, right)`` raw image points of the calibrated pair ``cal`` undistorted, (N, 2)
    float64 each, in the pixels of its camera matrices (what the calibrated F relates)."""
    return tuple(cv2.undistortPoints(np.float64(p).reshape(-1, 1, 2), k, d, P=k).reshape(-1, 2)
                 for p, k, d in ((left, cal.K1, cal.D1), (right, cal.K2, cal.D2)))


def on_lines(cal, left, right, undistorted) -> tuple[int, int]:
    """(matches within 1 px of the calibrated epipolar lines, matches)."""
    if len(left) == 0:
        return 0, 0
    if not undistorted:
        left, right = undistorted_points(cal, left, right)
    d = epipolar_distances(np.reshape(left, (-1, 2)), np.reshape(right, (-1, 2)),
                           cal.fundamental_matrix())
    return int((d <= 1.0).sum()), len(d)


def cv2_path(left, right):
    """The cv2 classes: detectAndCompute, setPairInfo, estimateFundamentalMatrix, match."""
    det = hopmatch.DericheMoravecDetector.create()
    kl, dl = det.detectAndCompute(left, None)
    kr, dr = det.detectAndCompute(right, None)
    m = hopmatch.HopfieldMatcher.create()
    m.setPairInfo(kl, kr, left.shape[1::-1], right.shape[1::-1])
    if m.estimateFundamentalMatrix(dl, dr).fundamental is None:
        return np.zeros((0, 2)), np.zeros((0, 2))
    ms = m.match(dl, dr)
    return (cv2.KeyPoint_convert(kl)[[x.queryIdx for x in ms]].reshape(-1, 2),
            cv2.KeyPoint_convert(kr)[[x.trainIdx for x in ms]].reshape(-1, 2))


def chessboards(smoke: bool, params=None) -> None:
    folder = datasets.shared_data_dir() / "opencv_stereo_calib"
    cal, used = calibration(folder)
    if smoke:
        used = used[:2]
    print("## Chessboard pairs: matches within 1 px of the calibrated epipolar lines\n")
    print("| pair | images | match_stereo(rectified=False) | cv2 path "
          "(estimateFundamentalMatrix) |")
    print("|---|---|---:|---:|")
    totals = {}
    for undistorted in (False, True):
        for i in used:
            left = cv2.imread(str(folder / f"left{i}.jpg"))
            right = cv2.imread(str(folder / f"right{i}.jpg"))
            if undistorted:
                left = cv2.undistort(left, cal.K1, cal.D1)
                right = cv2.undistort(right, cal.K2, cal.D2)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = hopmatch.match_stereo(left, right, rectified=False, **(params or {}))
                cells = [on_lines(cal, r.matched_left, r.matched_right, undistorted),
                         on_lines(cal, *cv2_path(left, right), undistorted)]
            label = "undistorted" if undistorted else "raw"
            for k, (c, n) in enumerate(cells):
                a, b = totals.get((label, k), (0, 0))
                totals[label, k] = (a + c, b + n)
            print(f"| {i} | {label} | " + " | ".join(
                f"{c} of {n}" + (f" ({c / n:.1%})" if n else "") for c, n in cells) + " |",
                flush=True)
    print()
    for label in ("raw", "undistorted"):
        print(f"All pairs, {label}: " + "; ".join(
            f"{name} {c} of {n} ({c / max(n, 1):.1%})" for name, (c, n) in
            (("match_stereo", totals[label, 0]), ("cv2 path", totals[label, 1]))))
    print()


LARGE_CHILD = r"""
import json, resource, sys, time
sys.path.insert(0, {here!r})
import cv2, numpy as np
from _common import force_refine_radius, motorcycle_bgr, single_thread
from unrectified import upsampled_truth
single_thread()
force_refine_radius(None if sys.argv[4] == "None" else int(sys.argv[4]))
import hopmatch
from hopmatch.evaluate import score_matches
params = json.loads(sys.argv[6])
if sys.argv[5] == "motorcycle":
    left, right, gt0 = motorcycle_bgr()
else:
    from hopmatch import datasets
    scene = datasets.load(sys.argv[5])
    left, right, gt0 = scene.left, scene.right, scene.disparity
def gray(image):
    return image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
left0, right0 = left, right
size = (int(sys.argv[1]), int(sys.argv[2]))
left = cv2.resize(gray(left), size, interpolation=cv2.INTER_CUBIC)
right = cv2.resize(gray(right), size, interpolation=cv2.INTER_CUBIC)
def best_of(call, runs=3):
    best = float("inf")
    for _ in range(runs):
        t0 = time.perf_counter()
        got = call()
        best = min(best, time.perf_counter() - t0)
    return best, got
if sys.argv[3] == "sift":
    sift = cv2.SIFT_create()
    seconds, _ = best_of(lambda: (sift.detectAndCompute(left, None),
                                  sift.detectAndCompute(right, None)))
    out = dict(seconds=seconds)
else:
    hopmatch.warmup()
    import warnings
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        seconds, r = best_of(lambda: hopmatch.match_stereo(left, right, **params))
    warned = sorted(set(str(w.message) for w in caught))
    stages = dict(r.timings, **r.match_timings)
    out = dict(seconds=seconds, keypoints=len(r.points_left),
               matches=len(r.query_idx), lo=r.network.config.min_disparity,
               hi=r.network.config.max_disparity, neurons=len(r.network.neuron_left),
               stages=dict((k, stages[k]) for k in ("detect_left", "detect_right",
                                                    "network", "guided", "refine")))
    f = size[0] / gt0.shape[1]
    ml, mr = r.matched_left, r.matched_right
    def errors(ml, mr, factor, surface=1.0):
        e = (ml[:, 0] - mr[:, 0]) - upsampled_truth(gt0, ml, factor, surface)
        known = np.isfinite(e)
        dy = np.abs(ml[:, 1] - mr[:, 1])[known]
        return e[known], dy, known
    e, dy, known = errors(ml, mr, f)
    out.update(p1=float(np.mean((np.abs(e) <= 1) & (dy <= 1))),
               p2=float(np.mean((np.abs(e) <= 2) & (dy <= 2))),
               c1=int(np.sum((np.abs(e) <= 1) & (dy <= 1))))
    en, dyn, _ = errors(ml, mr, f, surface=-1.0)
    out.update(p1_nearest=float(np.mean((np.abs(en) <= 1) & (dyn <= 1))),
               bias_nearest=float(np.mean(en[np.abs(en) <= 2.0])))
    ml = ml[known]
    xo = np.clip(np.floor((ml[:, 0] + 0.5) / f).astype(int), 0, gt0.shape[1] - 1)
    yo = np.clip(np.floor((ml[:, 1] + 0.5) / f).astype(int), 0, gt0.shape[0] - 1)
    g = np.nan_to_num(gt0, nan=0.0).astype(np.float32)
    k = np.ones((5, 5), np.uint8)
    spread = (cv2.dilate(g, k) - cv2.erode(g, k))[yo, xo]
    good = (np.abs(e) <= 1.0) & (dy <= 1.0)
    for name, lo, hi in (("flat", 0.0, 0.5), ("slanted", 0.5, 5.0), ("edge", 5.0, np.inf)):
        m = (spread >= lo) & (spread < hi)
        out[name] = [int(m.sum()), float(good[m].mean()) if m.any() else float("nan")]
        w = m & (np.abs(e) <= 2.0)
        out[name + "_bias"] = float(e[w].mean()) if w.any() else float("nan")
    out["bias"] = float(np.mean(e[np.abs(e) <= 2.0]))
    r0 = hopmatch.match_stereo(gray(left0), gray(right0), **params)
    e0, _, _ = errors(r0.matched_left, r0.matched_right, 1.0)
    out["bias_original"] = float(np.mean(e0[np.abs(e0) <= 2.0 / f])) * f
    out["f_inv"] = 1.0 / f
    out["warnings"] = warned
out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(out))
"""


def large(size, refine_radius=None, scene="motorcycle", params=None) -> None:
    runs = {}
    params = params or {}
    for mode in ("hopmatch", "sift"):
        proc = subprocess.run([sys.executable, "-c", LARGE_CHILD.format(here=str(HERE)),
                               str(size[0]), str(size[1]), mode, str(refine_radius),
                               scene, json.dumps(params)],
                              capture_output=True, text=True)
        if proc.returncode:
            raise RuntimeError(f"the {mode} run failed:\n{proc.stderr}")
        runs[mode] = json.loads(proc.stdout.strip().splitlines()[-1])
    h, s = runs["hopmatch"], runs["sift"]
    given = ", ".join(f"{k}={v!r}" for k, v in params.items())
    print(f"## Large pair: {scene} upsampled to {size[0]} x {size[1]}, "
          + (f"match_stereo(left, right, {given})\n" if params else
             "match_stereo(left, right) with no parameter\n"))
    where = ("" if "rectified" not in params or params["rectified"] is not False else
             " (in the network's search frame)")
    print(f"range found{where}: [{h['lo']:.1f}, {h['hi']:.1f}] px; keypoints "
          f"{h['keypoints']}; neurons {h['neurons']}; matches {h['matches']}")
    print(f"precision: {h['p1']:.3f} at 1 px, {h['p2']:.3f} at 2 px ({h['c1']} correct at 1 px)")
    print(f"time (best of 3): {h['seconds']:.2f} s; peak memory {h['peak_mb']:.0f} MB; SIFT "
          f"detectAndCompute on both images {s['seconds']:.2f} s (ratio "
          f"{h['seconds'] / s['seconds']:.2f})")
    print("stages of the last run: " + ", ".join(f"{k} {v:.2f} s"
                                                 for k, v in h["stages"].items()))
    print("precision at 1 px by ground truth: " + "; ".join(
        f"{name} {h[name][1]:.3f} of {h[name][0]}" for name in ("flat", "slanted", "edge"))
          + f"; mean error within 2 px {h['bias']:+.3f} px")
    print("mean error within 2 px by ground truth: " + "; ".join(
        f"{name} {h[name + '_bias']:+.3f}" for name in ("flat", "slanted", "edge"))
          + f"; on the original pair (within {2 * h['f_inv']:.2f} px) x {1 / h['f_inv']:g}: "
          f"{h['bias_original']:+.3f} px")
    print(f"with the nearest original pixel as truth: precision {h['p1_nearest']:.3f} at 1 px, "
          f"mean error within 2 px {h['bias_nearest']:+.3f} px")
    for message in h["warnings"]:
        print(f"warning: {message}")
    print()


def ranges(names) -> None:
    print("## Ranges found with max_disparity=None (rectified pairs)\n")
    print("| scene | found | ground truth | ground-truth pixels inside |")
    print("|---|---|---|---:|")
    det = hopmatch.DericheMoravecDetector()
    for name in names:
        s = datasets.load(name)
        kl, dl = det.detectAndCompute(s.left, None)
        kr, dr = det.detectAndCompute(s.right, None)
        m = hopmatch.HopfieldMatcher()
        m.setPairInfo(kl, kr, s.image_size, s.image_size)
        c = m.run(dl, dr).config
        v = s.disparity[np.isfinite(s.disparity)]
        inside = np.mean((v >= c.min_disparity) & (v <= c.max_disparity))
        print(f"| {name} | {c.min_disparity:.1f}..{c.max_disparity:.1f} | "
              f"{v.min():.1f}..{v.max():.1f} | {inside:.4f} |")
    print()


def fundamental(names) -> None:
    """The ``fundamental`` section."""
    angle, dy, scale = FUNDAMENTAL_PERTURBATION
    print(f"## A known fundamental matrix: match_stereo(left, right, fundamental_matrix=F), "
          f"right image {angle:+g} deg, {dy:+g} px, x{scale:g}\n")
    print("with the range: the epipolar band; without: the rows lined up by F\n")
    print("| scene | with the range: matches | correct | precision | candidate pairs | ms "
          "| without: matches | correct | precision | search | ms |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|")
    rectified_f = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    tot = {"band": [0, 0, 0.0], "rows": [0, 0, 0.0]}
    for name in names:
        scene = datasets.load(name)
        if name == "motorcycle" and len(names) <= 2:  # --smoke
            scene = smoke_scene(scene)
        A = perturbation(scene.image_size, angle, dy, scale)
        right = warp(scene.right, A, scene.image_size)
        F = np.linalg.inv(np.vstack([A, [0.0, 0.0, 1.0]])).T @ rectified_f
        v = scene.disparity[np.isfinite(scene.disparity)]
        given_range = dict(min_disparity=float(np.floor(v.min())) - FUNDAMENTAL_MARGIN,
                           max_disparity=float(np.ceil(v.max())) + FUNDAMENTAL_MARGIN)
        cells = []
        for key, extra in (("band", given_range), ("rows", {})):
            seconds = float("inf")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                for _ in range(3):
                    t0 = time.perf_counter()
                    r = hopmatch.match_stereo(scene.left, right, fundamental_matrix=F,
                                              **extra)
                    seconds = min(seconds, time.perf_counter() - t0)
            t, known = truth(r.matched_left, scene.disparity, A)
            ok = known & (np.hypot(*(r.matched_right - t[:, :2]).T) <= 1.0)
            n, c = int(known.sum()), int(ok.sum())
            tot[key] = [tot[key][0] + c, tot[key][1] + n, tot[key][2] + seconds]
            how = (len(r.network.state) if key == "band" else
                   "band" if r.geometry is None else r.geometry.search)
            cells.append(f"{len(r.query_idx)} | {c} | {c / n if n else float('nan'):.3f} | "
                         f"{how} | {1e3 * seconds:.0f}")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    for key, label in (("band", "With the range"), ("rows", "Without")):
        c, n, secs = tot[key]
        print(f"\n{label}: {c} correct of {n} scored ({c / max(n, 1):.4f}), "
              f"{secs:.2f} s in all")
    print()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sections", nargs="*", choices=SECTIONS, default=list(SECTIONS))
    ap.add_argument("--scenes", nargs="*", help="scene names (default: every shared scene)")
    ap.add_argument("--verge", type=float, default=0.0,
                    help="perturbed: the right camera also turned by this many degrees "
                         "about its vertical axis (a verged rig; default 0)")
    ap.add_argument("--defaults", action="store_true",
                    help="perturbed: match_stereo(left, right) with no parameter (the "
                         "rectification check decides), over smaller perturbations too")
    ap.add_argument("--params", type=json.loads, default=None,
                    help="perturbed and chessboards: more match_stereo parameters (JSON "
                         "object; default none), e.g. '{\"both_features\": true}'; the "
                         "reference on the rectified pair keeps the defaults")
    ap.add_argument("--large-scene", default="motorcycle",
                    help="large: the scene upsampled (default motorcycle)")
    ap.add_argument("--large-params", type=json.loads, default=None,
                    help="large: match_stereo parameters (JSON object; default none), e.g. "
                         "'{\"rectified\": false}'")
    ap.add_argument("--large-factor", type=float, default=None,
                    help="large: upsample the scene this many times (default: motorcycle to "
                         f"{LARGE[0]} x {LARGE[1]})")
    args = add_refine_radius_option(add_smoke_option(ap)).parse_args(argv)
    single_thread()
    force_refine_radius(args.refine_radius)
    names = args.scenes or datasets.list_scenes()
    if args.smoke and not args.scenes:
        names = smoke_scenes(names)
    shared = datasets.shared_data_dir(must_exist=False) is not None
    for section in args.sections:
        if section == "large":
            size = SMOKE_LARGE if args.smoke else LARGE
            if args.large_factor is not None:
                w, h = np.shape((datasets.load_motorcycle() if args.large_scene == "motorcycle"
                                 else datasets.load(args.large_scene)).left)[1::-1][-2:]
                size = (round(w * args.large_factor), round(h * args.large_factor))
            large(size, args.refine_radius, args.large_scene, args.large_params)
        elif not shared and section == "chessboards":
            print("## Chessboard pairs: skipped (no shared data)\n")
        elif section == "perturbed":
            chosen = DEFAULTS_PERTURBATIONS if args.defaults else PERTURBATIONS
            perturbed(names, chosen[:1] if args.smoke else chosen, args.verge, args.defaults,
                      args.params)
        elif section == "chessboards":
            chessboards(args.smoke, args.params)
        elif section == "ranges":
            ranges(names)
        elif section == "fundamental":
            fundamental(names)
        elif section == "truth":
            truth_fits(["motorcycle"] if args.smoke else (args.scenes or TRUTH_SCENES),
                       args.smoke)
    return 0


if __name__ == "__main__":
    sys.exit(main())
