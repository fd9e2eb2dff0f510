"""hopmatch side by side with OpenCV's matchers, on scenes with ground truth.

Every method is a small function with one signature, ``method(scene) -> MethodResult``:
it takes a :class:`~hopmatch.datasets.StereoScene` and returns the matched points
``left_pts``/``right_pts`` ((M, 2) float32, (x, y), row ``k`` of each forming match ``k``),
the ``seconds`` it took (detection on both images + matching, single thread), and the
keypoint sets the method chose from (for recall). A :class:`MethodResult` unpacks as
``left_pts, right_pts, seconds, keypoints_left, keypoints_right``. :data:`METHODS` maps the
names used by ``hopmatch eval --method`` to these functions.

Every method works on the grey pair (``cv2.COLOR_BGR2GRAY``, converted before the clock
starts) and gets the same disparity range, ``0 .. ceil(1.1 * max finite ground truth)``
(:func:`disparity_range`): what a user with a calibrated rig would set.

:func:`compare` runs methods on scenes and scores them with
:func:`hopmatch.evaluate.score_matches` at 0.5, 1 and 2 px (vertical tolerance = the
threshold); :func:`format_markdown` / :func:`format_csv` (and the atomic ``write_*``) turn
its rows into tables. ``hopmatch eval`` and ``benchmarks/quality.py`` are thin layers on
top; ``hopmatch eval --docs`` regenerates ``docs/results.md``.

Examples
--------
>>> from hopmatch import compare, datasets
>>> rows = compare.compare([datasets.load("motorcycle")], ["hopmatch", "sift-ratio"])
>>> [r["method"] for r in rows]
['hopmatch', 'sift-ratio']
>>> print(compare.format_markdown(rows))              # doctest: +SKIP
"""

from __future__ import annotations

import csv
import io
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import NamedTuple

import cv2
import numpy as np

from .datasets import StereoScene, load
from .errors import InvalidArgumentError, InvalidTypeError
from .evaluate import score_matches
from .feature.detector import DericheMoravecDetector
from .matching.matcher import HopfieldMatcher
from .matching.stereo_match import match_stereo

__all__ = [
    "COLUMNS",
    "METHODS",
    "MethodResult",
    "THRESHOLDS",
    "compare",
    "disparity_range",
    "draw_row",
    "format_csv",
    "format_markdown",
    "run_method",
    "write_csv",
    "write_markdown",
]

#: Disparity tolerances of the scores, in pixels (the vertical tolerance is the same).
THRESHOLDS = (0.5, 1.0, 2.0)

#: Ratio of Lowe's test in the BFMatcher baselines.
RATIO = 0.75

#: Half-side of the NCC window (7 x 7, hopmatch's descriptor window).
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
    if not matches:
        return np.zeros((0, 2), np.float32), np.zeros((0, 2), np.float32)
    q = np.fromiter((m.queryIdx for m in matches), np.intp, len(matches))
    t = np.fromiter((m.trainIdx for m in matches), np.intp, len(matches))
    return kl[q], kr[t]


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
    """hopmatch's default detector on the left image; integer positions inside a margin."""
    pts, _, _ = DericheMoravecDetector().detect_points(gray)
    h, w = gray.shape
    pi = np.rint(pts).astype(np.intp).reshape(-1, 2)
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
    gl, gr = _gray_pair(scene)
    dmax = disparity_range(scene)
    block = 5
    t0 = time.perf_counter()
    num = 16 * int(math.ceil((dmax + 1) / 16))
    sg = cv2.StereoSGBM_create(minDisparity=0, numDisparities=num, blockSize=block,
                               P1=8 * block * block, P2=32 * block * block,
                               disp12MaxDiff=1, uniquenessRatio=10,
                               speckleWindowSize=100, speckleRange=2)
    raw = sg.compute(gl, gr)
    pts, pi = _moravec_left(gl, 0)
    d = raw[pi[:, 1], pi[:, 0]].astype(np.float32) / 16.0
    keep = (d >= 0) & (d <= dmax)
    seconds = time.perf_counter() - t0
    left = pts[keep]
    right = np.column_stack([left[:, 0] - d[keep], left[:, 1]])
    return MethodResult(_f32(left), _f32(right), seconds, _f32(pts),
                        _dense_candidates(pi, dmax, gl.shape[1]))


#: Method names -> functions ``(scene) -> MethodResult``, in table order.
METHODS: dict[str, Callable[[StereoScene], MethodResult]] = {
    "hopmatch": _hopmatch(),
    "hopmatch-paper": _hopmatch(preset="paper"),
    "hopmatch-intensity": _hopmatch(on="intensity"),
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
    "hopmatch": "hopmatch.match_stereo, defaults (Moravec on the Deriche gradient + Hopfield "
                "network)",
    "hopmatch-paper": "match_stereo(preset='paper'): the paper's section 4 settings (its "
                      "+-15 px vertical window kept; disparity range as for every method)",
    "hopmatch-intensity": "match_stereo(on='intensity'): detector and descriptors on grey "
                          "levels instead of the gradient",
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


# --------------------------------------------------------------------------------------
# The runner
# --------------------------------------------------------------------------------------

#: Columns of :func:`format_csv`, in order (``format_markdown`` shows a subset).
COLUMNS = (
    "scene", "method", "keypoints_left", "keypoints_right", "matches", "scored",
    *(f"{k}@{t:g}" for t in THRESHOLDS for k in ("correct", "precision", "matchable",
                                                 "recall")),
    "mean_abs_error", "median_abs_error", "max_disparity", "time_ms",
)

#: Columns of :func:`format_markdown`: (row key, header, format).
MARKDOWN_COLUMNS = (
    ("scene", "scene", "{}"),
    ("method", "method", "{}"),
    ("matches", "matches", "{}"),
    ("correct@1", "correct@1", "{}"),
    ("precision@1", "precision@1", "{:.3f}"),
    ("recall@1", "recall@1", "{:.3f}"),
    ("time_ms", "time ms", "{:.0f}"),
)


def _scene(item) -> StereoScene:
    if isinstance(item, StereoScene):
        return item
    if isinstance(item, str):
        return load(item)
    raise InvalidTypeError(
        f"`scenes` must hold scene names or StereoScene objects, got {type(item).__name__}"
    )


def _method(item) -> tuple[str, Callable]:
    if isinstance(item, str):
        if item not in METHODS:
            raise InvalidArgumentError(
                f"unknown method {item!r}; valid methods are {list(METHODS)}"
            )
        return item, METHODS[item]
    if callable(item):
        return getattr(item, "__name__", repr(item)), item
    raise InvalidTypeError(
        f"`methods` must hold method names or callables, got {type(item).__name__}"
    )


def run_method(method, scene) -> MethodResult:
    """Run one method (a name of :data:`METHODS` or a callable) on one scene, one thread."""
    _, fn = _method(method)
    old = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        out = fn(_scene(scene))
    finally:
        cv2.setNumThreads(old)
    return MethodResult(*out)


def _warm_scene() -> StereoScene:
    rng = np.random.default_rng(0)
    left = cv2.GaussianBlur((rng.random((96, 128)) * 255).astype(np.uint8), (3, 3), 0)
    right = np.roll(left, -4, axis=1)
    disp = np.full(left.shape, 4.0, np.float32)
    return StereoScene("warm-up", left, right, disp, None, "")


def _score_row(scene: StereoScene, name: str, res: MethodResult, dmax: int) -> dict:
    s = score_matches(res.left_pts, res.right_pts, scene.disparity, thresholds=THRESHOLDS,
                      right_keypoints=res.keypoints_right, left_keypoints=res.keypoints_left)
    rec = s.as_dict()
    row = {
        "scene": scene.name, "method": name,
        "keypoints_left": int(len(res.keypoints_left)),
        "keypoints_right": int(len(res.keypoints_right)),
        "matches": rec["n_matches"], "scored": rec["n_scored"],
    }
    for t in THRESHOLDS:
        for k in ("correct", "precision", "matchable", "recall"):
            row[f"{k}@{t:g}"] = rec[f"{k}@{t:g}"]
    row.update(mean_abs_error=rec["mean_abs_error"], median_abs_error=rec["median_abs_error"],
               max_disparity=dmax, time_ms=res.seconds * 1e3)
    row["result"] = res
    row["score"] = s
    return row


def compare(scenes, methods=None, *, progress: Callable[[str], None] | None = None,
            warmup: bool = True, repeat: int = 1) -> list[dict]:
    """Run ``methods`` on ``scenes`` and score them: one row per (scene, method).

    Parameters
    ----------
    scenes : sequence of str or StereoScene
        Scene names (:func:`hopmatch.datasets.list_scenes`) or loaded scenes.
    methods : sequence of str or callable, optional
        Names of :data:`METHODS` (default: all of them, in its order) or functions
        ``(scene) -> MethodResult``.
    progress : callable, optional
        Called with a short message (``"motorcycle: sift-ratio (5/12)"``) before each run.
    warmup : bool
        First run every method once, untimed, on a tiny synthetic pair (Numba kernels,
        OpenCV's first-call set-up), so the times are steady-state.
    repeat : int
        Run each method this many times per scene and report the shortest time (the
        matches are those of the last run; every method is deterministic).

    Returns
    -------
    rows : list of dict
        The :data:`COLUMNS` (``time_ms``: this run, one OpenCV thread), plus ``"result"``
        (the :class:`MethodResult`) and ``"score"`` (the
        :class:`~hopmatch.evaluate.MatchScore`) for pictures.
    """
    if isinstance(scenes, (str, StereoScene)):
        scenes = [scenes]
    chosen = [_method(m) for m in (list(METHODS) if methods is None else methods)]
    if not chosen:
        raise InvalidArgumentError("`methods` is empty; give at least one method")
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise InvalidArgumentError(f"`repeat` must be a positive integer, got {repeat!r}")
    loaded = [_scene(s) for s in scenes]
    old = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        if warmup:
            from . import warmup as compile_kernels

            compile_kernels()
            warm = _warm_scene()
            for name, fn in chosen:
                if progress:
                    progress(f"warming up {name}")
                fn(warm)
        rows = []
        total = len(loaded) * len(chosen)
        for scene in loaded:
            dmax = disparity_range(scene)
            for name, fn in chosen:
                if progress:
                    progress(f"{scene.name}: {name} ({len(rows) + 1}/{total})")
                runs = [MethodResult(*fn(scene)) for _ in range(repeat)]
                best = min(r.seconds for r in runs)
                rows.append(_score_row(scene, name, runs[-1]._replace(seconds=best), dmax))
    finally:
        cv2.setNumThreads(old)
    return rows


# --------------------------------------------------------------------------------------
# Tables and pictures
# --------------------------------------------------------------------------------------


def _cell(value, fmt: str) -> str:
    if isinstance(value, float) and math.isnan(value):
        return "–"
    return fmt.format(value)


def format_markdown(rows: Sequence[Mapping]) -> str:
    """A Markdown table: scene, method, matches, correct@1, precision@1, recall@1, time ms.

    Numbers are right-aligned; NaN (e.g. precision without any scored match) shows as "–".
    """
    lines = ["| " + " | ".join(h for _, h, _ in MARKDOWN_COLUMNS) + " |",
             "|" + "|".join("---" if k in ("scene", "method") else "---:"
                            for k, _, _ in MARKDOWN_COLUMNS) + "|"]
    for row in rows:
        lines.append("| " + " | ".join(_cell(row[k], f) for k, _, f in MARKDOWN_COLUMNS)
                     + " |")
    return "\n".join(lines) + "\n"


def format_csv(rows: Sequence[Mapping]) -> str:
    """CSV with a header of :data:`COLUMNS`; floats at full precision, NaN as ``nan``."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    for row in rows:
        writer.writerow([_csv_value(row.get(c, "")) for c in COLUMNS])
    return buf.getvalue()


def _csv_value(value):
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(round(value, 6))
    return value


def write_markdown(rows: Sequence[Mapping], path):
    """Write :func:`format_markdown` to ``path`` atomically; return the path."""
    from .viz import write_text_atomic

    return write_text_atomic(path, format_markdown(rows))


def write_csv(rows: Sequence[Mapping], path):
    """Write :func:`format_csv` to ``path`` atomically; return the path."""
    from .viz import write_text_atomic

    return write_text_atomic(path, format_csv(rows))


def correct_flags(row: Mapping, tolerance: float = 1.0):
    """(correct, known) bool arrays of a row's matches at ``tolerance`` px (as scored)."""
    res, score = row["result"], row["score"]
    known = np.asarray(score.scored, bool)
    correct = np.zeros(len(known), bool)
    idx = np.flatnonzero(known)
    dy = np.abs(res.left_pts[idx, 1] - res.right_pts[idx, 1])
    correct[idx] = (np.abs(score.errors) <= tolerance) & (dy <= tolerance)
    return correct, known


def draw_row(row: Mapping, scene: StereoScene, tolerance: float = 1.0) -> np.ndarray:
    """The matches of one row drawn with ``cv2.drawMatches``: green correct at
    ``tolerance`` px, red wrong, grey without ground truth. Returns a BGR image."""
    from .viz import draw_matches

    res = row["result"]
    correct, known = correct_flags(row, tolerance)
    pairs = np.repeat(np.arange(len(res.left_pts))[:, None], 2, axis=1)
    return draw_matches(scene.left, scene.right, res.left_pts, res.right_pts, pairs,
                        correct, known=known)


def errors_by_method(rows: Iterable[Mapping], scene: str | None = None) -> dict:
    """``{method: signed disparity errors}`` of the rows (of one scene, or pooled)."""
    out: dict = {}
    for row in rows:
        if scene is None or row["scene"] == scene:
            out.setdefault(row["method"], []).append(row["score"].errors)
    return {k: np.concatenate(v) for k, v in out.items()}


# --------------------------------------------------------------------------------------
# docs/results.md
# --------------------------------------------------------------------------------------

#: The command that regenerates ``docs/results.md`` and ``docs/img/*.png``.
DOCS_COMMAND = "hopmatch eval --docs"

#: Matches drawn for the docs: (scene, method).
DOC_DRAWINGS = (
    ("motorcycle", "hopmatch"),
    ("motorcycle", "sift-ratio"),
    ("motorcycle", "ncc-wta"),
    ("motorcycle", "sgbm"),
    ("middlebury/tsukuba", "hopmatch"),
)


def docs_scenes(available: Sequence[str]) -> list[str]:
    """The scenes of ``docs/results.md``: motorcycle, the Middlebury ones, then the others."""
    mid = [s for s in available if s.startswith("middlebury/")]
    rest = [s for s in available if s != "motorcycle" and s not in mid]
    return ["motorcycle", *mid, *rest]


def machine_description() -> dict:
    """CPU, cores, memory, OS and library versions of this machine."""
    import os
    import platform

    import numba

    from . import __version__

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem = ""
    try:
        with open("/proc/meminfo") as fh:
            kb = int(fh.readline().split()[1])
            mem = f"{kb / 2**20:.0f} GiB"
    except (OSError, ValueError, IndexError):
        pass
    return {
        "cpu": cpu, "cores": os.cpu_count(), "memory": mem,
        "os": platform.platform(), "python": platform.python_version(),
        "hopmatch": __version__, "opencv": cv2.__version__, "numpy": np.__version__,
        "numba": numba.__version__,
        "load": " / ".join(f"{v:.2f}" for v in os.getloadavg()) if hasattr(os, "getloadavg")
        else "",
    }


def summary_rows(rows: Sequence[Mapping]) -> list[dict]:
    """Per method over all scenes: summed matches and correct@1, pooled precision@1 (summed
    correct / summed scored), median recall@1 and the summed time."""
    out = []
    for method in dict.fromkeys(r["method"] for r in rows):
        mine = [r for r in rows if r["method"] == method]
        scored = sum(r["scored"] for r in mine)
        correct = sum(r["correct@1"] for r in mine)
        recalls = [r["recall@1"] for r in mine if not math.isnan(r["recall@1"])]
        out.append({
            "method": method, "scenes": len(mine),
            "matches": sum(r["matches"] for r in mine), "correct@1": correct,
            "precision@1": correct / scored if scored else math.nan,
            "recall@1": float(np.median(recalls)) if recalls else math.nan,
            "time_ms": sum(r["time_ms"] for r in mine),
        })
    return out


def _summary_markdown(rows: Sequence[Mapping]) -> str:
    lines = ["| method | scenes | matches | correct@1 | precision@1 (pooled) | "
             "recall@1 (median) | total time ms |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for r in summary_rows(rows):
        lines.append(
            f"| {r['method']} | {r['scenes']} | {r['matches']} | {r['correct@1']} | "
            f"{_cell(r['precision@1'], '{:.3f}')} | {_cell(r['recall@1'], '{:.3f}')} | "
            f"{r['time_ms']:.0f} |")
    return "\n".join(lines) + "\n"


def _cite_lines(scenes: Sequence[StereoScene]) -> list[str]:
    seen = dict.fromkeys(s.source for s in scenes if s.source)
    return [f"- {c}" for c in seen]


def format_results_doc(rows: Sequence[Mapping], scenes: Sequence[StereoScene], *,
                       pictures: Mapping[str, str], machine: Mapping, created: str,
                       elapsed: float, repeat: int = 1) -> str:
    """The text of ``docs/results.md`` (``pictures``: file name relative to ``docs/`` ->
    caption)."""
    by_scene: dict = {}
    for r in rows:
        by_scene.setdefault(r["scene"], []).append(r)
    methods = list(dict.fromkeys(r["method"] for r in rows))
    out = [
        "# Results: hopmatch side by side with OpenCV's matchers",
        "",
        f"<!-- Generated by `{DOCS_COMMAND}` (hopmatch/compare.py, hopmatch/cli.py); "
        "do not edit by hand. -->",
        "",
        f"Generated by **`{DOCS_COMMAND}`** on {created} (whole run: {elapsed:.0f} s); run it "
        "again to regenerate this page and the pictures in `docs/img/`. "
        "`hopmatch eval --scene NAME --method NAME --out DIR` runs any subset and writes "
        "`results.md`, `results.csv` and the plots to DIR; `python benchmarks/quality.py` "
        "prints the same table.",
        "",
        "## Machine",
        "",
        f"{machine['cpu']}, {machine['cores']} cores, {machine['memory']} RAM; "
        f"{machine['os']}; Python {machine['python']}, hopmatch {machine['hopmatch']}, "
        f"OpenCV {machine['opencv']}, NumPy {machine['numpy']}, Numba {machine['numba']}."
        + (f" Load average at the end of the run (1 / 5 / 15 min): {machine['load']}."
           if machine.get("load") else ""),
        "",
        "## How the methods were run and scored",
        "",
        "- Every method gets the grey pair (`cv2.COLOR_BGR2GRAY`) and the same disparity "
        "range, **0 .. ceil(1.1 × the largest finite ground-truth disparity)** of the scene "
        "(column `max_disparity` of the CSV): what a user with a calibrated rig would set. "
        "hopmatch gets it as `max_disparity`; the band baselines, NCC and SGBM search it.",
        "- Time: wall time of detection on both images + matching, one OpenCV thread "
        "(`cv2.setNumThreads(1)`; hopmatch's Numba kernels are single-threaded), measured "
        f"in this run: the shortest of {repeat} run{'s' if repeat != 1 else ''} per method "
        "and scene, after an untimed warm-up of every method "
        "on a small synthetic pair (Numba kernels loaded, OpenCV's first-call set-up done).",
        "- Scoring: `hopmatch.evaluate.score_matches` against the scene's ground truth "
        "(left image; pixels without ground truth are not scored). A match is **correct@t** "
        "when its disparity is within t px of the ground truth and its vertical offset at "
        "most t px; **precision@t** = correct / scored matches. **recall@t** = correct / "
        "matchable, where a left keypoint is matchable when the method's own right keypoint "
        "set holds a point within t px of its true correspondent: recall is relative to "
        "each method's keypoints. For the dense searches (NCC, SGBM) the right keypoint "
        "set is every pixel they looked at, so nearly every left point with ground truth "
        "is matchable.",
        "- Ground truth: Middlebury 2001 maps include occluded pixels (they are scored); "
        "KITTI is scored on `disp_noc` (sparse LiDAR, non-occluded).",
        "",
        "| method | what it runs |",
        "|---|---|",
        *[f"| {m} | {DESCRIPTIONS.get(m, '')} |" for m in methods],
        "",
        "## Summary over all scenes",
        "",
        _summary_markdown(rows),
        "## Per scene",
        "",
    ]
    scene_info = {s.name: s for s in scenes}
    for name, mine in by_scene.items():
        s = scene_info.get(name)
        what = f" — {s.dataset}" if s is not None and s.dataset else ""
        w, h = s.image_size if s is not None else ("?", "?")
        dmax = mine[0]["max_disparity"]
        out += [f"### {name}", "",
                f"{w}×{h}{what}; disparity range 0..{dmax} px.", "",
                format_markdown(mine)]
    if pictures:
        out += ["## Pictures", ""]
        for file, caption in pictures.items():
            out += [f"**{caption}**", "", f"![{caption}]({file})", ""]
    out += ["## Data", "", "Scenes from `../shared/data` and scikit-image; please cite:", "",
            *_cite_lines(scenes), ""]
    return "\n".join(out)
