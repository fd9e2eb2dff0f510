"""The methods compared: hopmatch and OpenCV's matchers, each ``method(scene) -> MethodResult``.

Every method takes a :class:`~hopmatch.datasets.StereoScene` and returns the matched points
``left_pts``/``right_pts`` ((M, 2) float32, (x, y), row ``k`` of each forming match ``k``),
the ``seconds`` it took (detection on both images + matching, single thread), and the
keypoint sets the method chose from (for recall). Every method works on the grey pair
(``cv2.COLOR_BGR2GRAY``, converted before the clock starts) and gets the same disparity
range, ``0 .. disparity_range(scene)``. :data:`METHODS` maps the names used by
``hopmatch eval --method`` to these functions, :data:`DESCRIPTIONS` says what each runs.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import NamedTuple

import cv2
import numpy as np

from .._validate import as_match_indices
from ..datasets import StereoScene
from ..errors import InvalidArgumentError
from ..feature.detector import DericheMoravecDetector
from ..matching import both_features
from ..matching.matcher import HopfieldMatcher
from ..matching.stereo_match import match_stereo

__all__ = ["DESCRIPTIONS", "METHODS", "MethodResult", "NCC_HALF", "RATIO", "disparity_range",
           "hopfield_on_sift", "hopmatch_scored", "ncc_wta", "orb_gms", "sgbm",
           "sgbm_uniqueness", "sift_cross_check", "sift_ratio_scored"]

#: Ratio of Lowe's test in the BFMatcher baselines.
RATIO = 0.75

#: Half-side of the NCC window of ``ncc-wta`` (7 x 7).
NCC_HALF = 3


class MethodResult(NamedTuple):
    """What a method returns: matches, time, and the keypoints it chose from.

    Attributes
    ----------
    left_pts, right_pts : (M, 2) float32 ndarray
        Matched points, (x, y); row ``k`` of each forms match ``k``.
    seconds : float
        Wall time of detection on both images + matching.
    keypoints_left, keypoints_right : (K, 2) float32 ndarray
        The points the method chose from (for dense searches: every right pixel it looked
        at), for ``score_matches``' recall.
    """

    left_pts: np.ndarray
    right_pts: np.ndarray
    seconds: float
    keypoints_left: np.ndarray
    keypoints_right: np.ndarray


# --------------------------------------------------------------------------------------
# Scene helpers
# --------------------------------------------------------------------------------------


def disparity_range(scene: StereoScene) -> int:
    """``ceil(1.1 * max finite ground-truth disparity)``: the top of every method's range.

    The range is ``0 .. disparity_range(scene)`` for every method.
    """
    d = scene.disparity[np.isfinite(scene.disparity)]
    if d.size == 0:
        raise InvalidArgumentError(f"scene {scene.name!r} has no finite ground truth")
    return max(1, int(math.ceil(float(d.max()) * 1.1)))


def _gray(image: np.ndarray) -> np.ndarray:
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGRA2GRAY if image.shape[2] == 4
                            else cv2.COLOR_BGR2GRAY)
    return image


def _gray_pair(scene: StereoScene):
    return _gray(scene.left), _gray(scene.right)


def _f32(points) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(points, dtype=np.float32).reshape(-1, 2))


def _kp_array(keypoints) -> np.ndarray:
    if not keypoints:
        return np.zeros((0, 2), np.float32)
    return _f32(cv2.KeyPoint_convert(list(keypoints)))


def _from_dmatches(kl: np.ndarray, kr: np.ndarray, matches) -> tuple[np.ndarray, np.ndarray]:
    """The matched points of ``matches`` (cv2.DMatch, queryIdx into ``kl``, trainIdx into
    ``kr``)."""
    idx = as_match_indices(list(matches), n_query=len(kl), n_train=len(kr))
    return kl[idx[:, 0]], kr[idx[:, 1]]

def _band_pairs(kl: np.ndarray, kr: np.ndarray, max_disparity: float):
    """Index pairs ``(i, j)`` with ``|yl - yr| <= 1`` and ``0 <= xl - xr <= max_disparity``
    (found through the right points sorted by y; no (Nl, Nr) temporaries)."""
    order = np.argsort(kr[:, 1], kind="stable")
    ys = kr[order, 1]
    lo = np.searchsorted(ys, kl[:, 1] - 1.0, side="left")
    hi = np.searchsorted(ys, kl[:, 1] + 1.0, side="right")
    counts = hi - lo
    i = np.repeat(np.arange(len(kl)), counts)
    starts = np.repeat(lo - np.cumsum(counts) + counts, counts)
    j = order[np.arange(counts.sum()) + starts]
    d = kl[i, 0] - kr[j, 0]
    ok = (d >= 0) & (d <= max_disparity)
    return i[ok], j[ok]


def _band_mask(kl: np.ndarray, kr: np.ndarray, max_disparity: float) -> np.ndarray:
    """(Nl, Nr) uint8: 1 where ``|yl - yr| <= 1`` and ``0 <= xl - xr <= max_disparity``."""
    mask = np.zeros((len(kl), len(kr)), np.uint8)
    i, j = _band_pairs(kl, kr, max_disparity)
    mask[i, j] = 1
    return mask


def _dense_candidates(left_int: np.ndarray, max_disparity: int, width: int,
                      half: int = 0) -> np.ndarray:
    """Every right pixel ``(x - d, y)``, ``d`` in ``0..max_disparity``, of integer left points
    (inside ``[half, width - half)``): the "keypoints" a dense search chooses from."""
    if left_int.shape[0] == 0:
        return np.zeros((0, 2), np.float32)
    ds = np.arange(max_disparity + 1)
    xs = left_int[:, None, 0] - ds[None, :]
    ys = np.broadcast_to(left_int[:, None, 1], xs.shape)
    ok = (xs >= half) & (xs < width - half)
    flat = np.unique(ys[ok].astype(np.int64) * (width + 1) + xs[ok])
    return _f32(np.column_stack([flat % (width + 1), flat // (width + 1)]))


# --------------------------------------------------------------------------------------
# The methods: (scene) -> MethodResult
# --------------------------------------------------------------------------------------


def _hopmatch(**params) -> Callable[[StereoScene], MethodResult]:
    def run(scene: StereoScene) -> MethodResult:
        gl, gr = _gray_pair(scene)
        extra = {"min_disparity": 0.0} if params.get("preset") == "paper" else {}
        t0 = time.perf_counter()
        res = match_stereo(gl, gr, max_disparity=disparity_range(scene), **extra, **params)
        seconds = time.perf_counter() - t0
        return MethodResult(res.matched_left, res.matched_right, seconds,
                            res.points_left, res.points_right)

    return run


def hopfield_on_sift(scene: StereoScene) -> MethodResult:
    """HopfieldMatcher (defaults) on SIFT keypoints and descriptors."""
    gl, gr = _gray_pair(scene)
    t0 = time.perf_counter()
    sift = cv2.SIFT_create()
    k1, d1 = sift.detectAndCompute(gl, None)
    k2, d2 = sift.detectAndCompute(gr, None)
    matcher = HopfieldMatcher.create(max_disparity=disparity_range(scene))
    matcher.setPairInfo(k1, k2, gl.shape[::-1], gr.shape[::-1])
    matches = matcher.match(d1, d2) if len(k1) and len(k2) else ()
    seconds = time.perf_counter() - t0
    kl, kr = _kp_array(k1), _kp_array(k2)
    return MethodResult(*_from_dmatches(kl, kr, matches), seconds, kl, kr)


def _ratio(feature: Callable[[], cv2.Feature2D], norm: int, band: bool):
    def run(scene: StereoScene) -> MethodResult:
        gl, gr = _gray_pair(scene)
        t0 = time.perf_counter()
        det = feature()
        k1, d1 = det.detectAndCompute(gl, None)
        k2, d2 = det.detectAndCompute(gr, None)
        kl, kr = _kp_array(k1), _kp_array(k2)
        good = []
        if d1 is not None and d2 is not None and len(k1) and len(k2) >= 2:
            mask = _band_mask(kl, kr, disparity_range(scene)) if band else None
            pairs = cv2.BFMatcher(norm).knnMatch(d1, d2, k=2, mask=mask)
            good = [p[0] for p in pairs
                    if len(p) == 1 or (len(p) == 2 and p[0].distance < RATIO * p[1].distance)]
        seconds = time.perf_counter() - t0
        return MethodResult(*_from_dmatches(kl, kr, good), seconds, kl, kr)

    return run


def sift_cross_check(scene: StereoScene) -> MethodResult:
    """SIFT + ``BFMatcher(NORM_L2, crossCheck=True)`` (mutual nearest neighbours)."""
    gl, gr = _gray_pair(scene)
    t0 = time.perf_counter()
    sift = cv2.SIFT_create()
    k1, d1 = sift.detectAndCompute(gl, None)
    k2, d2 = sift.detectAndCompute(gr, None)
    matches = ()
    if d1 is not None and d2 is not None:
        matches = cv2.BFMatcher(cv2.NORM_L2, crossCheck=True).match(d1, d2)
    seconds = time.perf_counter() - t0
    kl, kr = _kp_array(k1), _kp_array(k2)
    return MethodResult(*_from_dmatches(kl, kr, matches), seconds, kl, kr)


def orb_gms(scene: StereoScene) -> MethodResult:
    """ORB (10000 points, FAST threshold 0) + BFMatcher + ``cv2.xfeatures2d.matchGMS``
    (no rotation, no scale, threshold factor 6), as in the GMS paper's sample."""
    gl, gr = _gray_pair(scene)
    t0 = time.perf_counter()
    orb = cv2.ORB_create(10000, fastThreshold=0)
    k1, d1 = orb.detectAndCompute(gl, None)
    k2, d2 = orb.detectAndCompute(gr, None)
    good = ()
    if d1 is not None and d2 is not None:
        raw = cv2.BFMatcher(cv2.NORM_HAMMING).match(d1, d2)
        good = cv2.xfeatures2d.matchGMS(gl.shape[::-1], gr.shape[::-1], k1, k2, raw,
                                        withRotation=False, withScale=False,
                                        thresholdFactor=6.0)
    seconds = time.perf_counter() - t0
    kl, kr = _kp_array(k1), _kp_array(k2)
    return MethodResult(*_from_dmatches(kl, kr, good), seconds, kl, kr)


def _ncc_wta(left: np.ndarray, right: np.ndarray, pts_int: np.ndarray, max_disparity: int,
             half: int = NCC_HALF):
    """Disparity of each integer left point by NCC winner-take-all over ``0..max_disparity``
    along its row, refined by a parabola through the best score and its neighbours.

    Returns ``(keep, disparity)``: the points that had at least one full window in range,
    and their (float) disparity. Vectorised: one gather of an (N, D+1) array per window
    pixel; the right windows' sums come from ``cv2.boxFilter``.
    """
    L = left.astype(np.float32)
    R = right.astype(np.float32)
    n = float((2 * half + 1) ** 2)
    xi, yi = pts_int[:, 0], pts_int[:, 1]
    offsets = [(dy, dx) for dy in range(-half, half + 1) for dx in range(-half, half + 1)]
    patch = np.stack([L[yi + dy, xi + dx] for dy, dx in offsets], axis=1)
    patch -= patch.mean(axis=1, keepdims=True)
    norm_l = np.sqrt((patch * patch).sum(axis=1))
    ksize = (2 * half + 1, 2 * half + 1)
    r_sum = cv2.boxFilter(R, cv2.CV_32F, ksize, normalize=False, borderType=cv2.BORDER_REFLECT)
    r_sq = cv2.boxFilter(R * R, cv2.CV_32F, ksize, normalize=False,
                         borderType=cv2.BORDER_REFLECT)
    ds = np.arange(max_disparity + 1)
    xs = xi[:, None] - ds[None, :]
    valid = xs >= half
    xs_c = np.maximum(xs, half)
    ys = np.broadcast_to(yi[:, None], xs.shape)
    cross = np.zeros(xs.shape, np.float32)
    for k, (dy, dx) in enumerate(offsets):
        cross += patch[:, k, None] * R[ys + dy, xs_c + dx]
    var_r = np.maximum(r_sq[ys, xs_c] - r_sum[ys, xs_c] ** 2 / n, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        ncc = cross / (norm_l[:, None] * np.sqrt(var_r) + 1e-6)
    ncc[~valid] = -np.inf
    best = np.argmax(ncc, axis=1)
    rows = np.arange(len(best))
    keep = np.isfinite(ncc[rows, best])
    # sub-pixel: parabola through (best - 1, best, best + 1) when both neighbours are valid
    lo, hi = np.maximum(best - 1, 0), np.minimum(best + 1, ds[-1])
    c0, c1, c2 = ncc[rows, lo], ncc[rows, best], ncc[rows, hi]
    inner = (best > 0) & (best < ds[-1]) & np.isfinite(c0) & np.isfinite(c2)
    denom = c0 - 2 * c1 + c2
    shift = np.zeros(len(best), np.float64)
    ok = inner & (denom < 0)
    shift[ok] = np.clip(0.5 * (c0[ok] - c2[ok]) / denom[ok], -0.5, 0.5)
    return keep, (best + shift).astype(np.float32)


def _moravec_left(gray: np.ndarray, half: int):
    """The left points of ``match_stereo``'s defaults (``both_features``): the default
    detector's on the gradient, and its points on grey levels farther than
    :data:`~hopmatch.matching.both_features.SEPARATION` px from every one of those;
    integer positions inside a margin."""
    pts, _, _ = DericheMoravecDetector().detect_points(gray)
    grey, _, _ = DericheMoravecDetector(on="intensity").detect_points(gray)
    return _inside(both_features.points_of_both(pts, grey), gray.shape, half)


def _inside(points: np.ndarray, shape: tuple, half: int = 0):
    """``(points, their pixels)`` of the (x, y) ``points`` whose nearest pixel lies at
    least ``half`` px inside an image of ``shape``."""
    pts = np.asarray(points, dtype=np.float32).reshape(-1, 2)
    h, w = shape[:2]
    pi = np.rint(pts).astype(np.intp)
    inside = (pi[:, 0] >= half) & (pi[:, 0] < w - half) & (pi[:, 1] >= half) & (pi[:, 1] < h - half)
    return pts[inside], pi[inside]


def ncc_wta(scene: StereoScene) -> MethodResult:
    """NCC (7 x 7) winner-take-all along the epipolar line at hopmatch's Moravec points."""
    gl, gr = _gray_pair(scene)
    dmax = disparity_range(scene)
    t0 = time.perf_counter()
    pts, pi = _moravec_left(gl, NCC_HALF)
    keep, disp = _ncc_wta(gl, gr, pi, dmax)
    seconds = time.perf_counter() - t0
    left = pts[keep]
    right = np.column_stack([left[:, 0] - disp[keep], left[:, 1]])
    return MethodResult(_f32(left), _f32(right), seconds, _f32(pts),
                        _dense_candidates(pi, dmax, gl.shape[1], NCC_HALF))


def sgbm(scene: StereoScene) -> MethodResult:
    """``cv2.StereoSGBM`` (block 5, P1 = 8*25, P2 = 32*25, uniqueness 10, speckle filter)
    sampled at hopmatch's Moravec points: a left point with a valid disparity ``d`` becomes
    the match ``(xl, yl) -> (xl - d, yl)``."""
    return sgbm_uniqueness(scene, 10)


def sgbm_uniqueness(scene: StereoScene, uniqueness: int,
                    left_points: np.ndarray | None = None) -> MethodResult:
    """:func:`sgbm` with ``uniquenessRatio=uniqueness`` (percent by which the best cost must
    beat the second; 0 keeps every pixel the other filters keep): the parameter
    :func:`~hopmatch.compare.curves.precision_curves` sweeps. ``left_points``: (N, 2) (x,
    y) to sample at instead of hopmatch's Moravec points (rounded to pixels; those outside
    the image dropped)."""
    gl, gr = _gray_pair(scene)
    dmax = disparity_range(scene)
    block = 5
    t0 = time.perf_counter()
    num = 16 * int(math.ceil((dmax + 1) / 16))
    sg = cv2.StereoSGBM_create(minDisparity=0, numDisparities=num, blockSize=block,
                               P1=8 * block * block, P2=32 * block * block,
                               disp12MaxDiff=1, uniquenessRatio=int(uniqueness),
                               speckleWindowSize=100, speckleRange=2)
    raw = sg.compute(gl, gr)
    pts, pi = _moravec_left(gl, 0) if left_points is None else _inside(left_points, gl.shape)
    d = raw[pi[:, 1], pi[:, 0]].astype(np.float32) / 16.0
    keep = (d >= 0) & (d <= dmax)
    seconds = time.perf_counter() - t0
    left = pts[keep]
    right = np.column_stack([left[:, 0] - d[keep], left[:, 1]])
    return MethodResult(_f32(left), _f32(right), seconds, _f32(pts),
                        _dense_candidates(pi, dmax, gl.shape[1]))


def hopmatch_scored(scene: StereoScene) -> tuple[MethodResult, np.ndarray]:
    """The ``hopmatch`` method's result and each match's ``result.distances`` (lower is
    more confident): what :func:`~hopmatch.compare.curves.precision_curves` thresholds."""
    gl, gr = _gray_pair(scene)
    t0 = time.perf_counter()
    res = match_stereo(gl, gr, max_disparity=disparity_range(scene))
    seconds = time.perf_counter() - t0
    return (MethodResult(res.matched_left, res.matched_right, seconds, res.points_left,
                         res.points_right), np.asarray(res.distances, dtype=np.float64))


def sift_ratio_scored(scene: StereoScene) -> tuple[MethodResult, np.ndarray]:
    """SIFT + BFMatcher(NORM_L2) knnMatch k=2 masked to the rectified band (as
    ``sift-ratio-band``) keeping every best match, and each one's Lowe ratio (best distance
    / second; 0 for a point with one candidate): ``sift-ratio-band`` keeps ratio < RATIO."""
    gl, gr = _gray_pair(scene)
    t0 = time.perf_counter()
    det = cv2.SIFT_create()
    k1, d1 = det.detectAndCompute(gl, None)
    k2, d2 = det.detectAndCompute(gr, None)
    kl, kr = _kp_array(k1), _kp_array(k2)
    good, ratios = [], []
    if d1 is not None and d2 is not None and len(k1) and len(k2) >= 2:
        mask = _band_mask(kl, kr, disparity_range(scene))
        for p in cv2.BFMatcher(cv2.NORM_L2).knnMatch(d1, d2, k=2, mask=mask):
            if len(p) == 1:
                good.append(p[0])
                ratios.append(0.0)
            elif len(p) == 2:
                good.append(p[0])
                ratios.append(p[0].distance / max(p[1].distance, 1e-12))
    seconds = time.perf_counter() - t0
    return (MethodResult(*_from_dmatches(kl, kr, good), seconds, kl, kr),
            np.asarray(ratios, dtype=np.float64))


#: Method names -> functions ``(scene) -> MethodResult``, in table order.
METHODS: dict[str, Callable[[StereoScene], MethodResult]] = {
    "hopmatch": _hopmatch(),
    "hopmatch-paper": _hopmatch(preset="paper"),
    "hopmatch-gradient": _hopmatch(both_features=False),
    "hopmatch-intensity": _hopmatch(on="intensity", both_features=False),
    "hopfield-sift": hopfield_on_sift,
    "sift-ratio": _ratio(cv2.SIFT_create, cv2.NORM_L2, band=False),
    "sift-ratio-band": _ratio(cv2.SIFT_create, cv2.NORM_L2, band=True),
    "orb-ratio": _ratio(lambda: cv2.ORB_create(3000), cv2.NORM_HAMMING, band=False),
    "orb-ratio-band": _ratio(lambda: cv2.ORB_create(3000), cv2.NORM_HAMMING, band=True),
    "sift-crosscheck": sift_cross_check,
    "orb-gms": orb_gms,
    "ncc-wta": ncc_wta,
    "sgbm": sgbm,
}

#: One line per method, for tables and ``--help``.
DESCRIPTIONS: dict[str, str] = {
    "hopmatch": "hopmatch.match_stereo, defaults (Moravec on the Deriche gradient and on grey "
                "levels + Hopfield network)",
    "hopmatch-paper": "match_stereo(preset='paper'): the paper's section 4 settings (its "
                      "+-15 px vertical window kept; disparity range as for every method)",
    "hopmatch-gradient": "match_stereo(both_features=False): one run, on the gradient's "
                         "points (the defaults until 2026-12-07)",
    "hopmatch-intensity": "match_stereo(on='intensity', both_features=False): one run, "
                          "detector and descriptors on grey levels instead of the gradient",
    "hopfield-sift": "HopfieldMatcher (defaults) on SIFT keypoints and descriptors",
    "sift-ratio": "SIFT + BFMatcher(NORM_L2) knnMatch k=2, ratio 0.75",
    "sift-ratio-band": "as sift-ratio, knnMatch masked to the rectified band (|yl-yr| <= 1, "
                       "disparity in range)",
    "orb-ratio": "ORB(3000) + BFMatcher(NORM_HAMMING) knnMatch k=2, ratio 0.75",
    "orb-ratio-band": "as orb-ratio, masked to the rectified band",
    "sift-crosscheck": "SIFT + BFMatcher(NORM_L2, crossCheck=True)",
    "orb-gms": "ORB(10000, fastThreshold=0) + BFMatcher + cv2.xfeatures2d.matchGMS",
    "ncc-wta": "NCC 7x7 winner-take-all along the row at hopmatch's Moravec points "
               "(sub-pixel parabola)",
    "sgbm": "cv2.StereoSGBM (block 5) sampled at hopmatch's Moravec points",
}
