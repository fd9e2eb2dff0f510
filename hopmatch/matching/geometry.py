"""Epipolar geometry of an unrectified pair, found from the pair itself.

Bootstrap correspondences (OpenCV SIFT on a pyramid level of at most
:data:`BOOTSTRAP_SIDE` pixels, or the matcher's own descriptors compared in a
two-dimensional window when only keypoints are known), a robust fundamental matrix
(``cv2.findFundamentalMat`` with ``cv2.USAC_MAGSAC``), guided rounds that match the SIFT
keypoints again along its epipolar lines and fit F again (:data:`BOOTSTRAP_ROUNDS`), checks
that refuse an F the correspondences do not support (:class:`GeometryWarning`), a refit of
F on the final matches, the similarity that lines up the rows of the two images
(:func:`row_alignment`) and a row rectification close to the identity
(:func:`rectifying_homographies`). ``F`` follows OpenCV's convention everywhere:
``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import BudgetExceededError, GeometryWarning  # noqa: F401 (re-exported)
from .candidates import candidate_pairs, clear_best_look_alikes
from .disparity_range import thin_points
from .similarity import similarity_distance

#: The bootstrap runs on the pyramid level whose longer side is at most this (``pyrDown``).
BOOTSTRAP_SIDE = 800
#: SIFT keypoints kept per image at that level, SIFT's contrast threshold (a quarter of
#: OpenCV's default: low-texture scenes give too few correspondences with the default), and
#: Lowe's ratio of the bootstrap matches (which must also be mutual nearest neighbours).
BOOTSTRAP_FEATURES = 1500
BOOTSTRAP_CONTRAST = 0.01
BOOTSTRAP_RATIO = 0.8
#: MAGSAC's threshold (pixels of the full-resolution image, per pyramid level of the
#: bootstrap: the bootstrap points are that much coarser), confidence and iterations.
F_THRESHOLD = 1.0
F_CONFIDENCE = 0.9999
F_ITERATIONS = 10000
#: An F is refused unless at least MIN_INLIERS bootstrap correspondences support it, at
#: least MIN_INLIER_RATIO of them (repetitive texture, a chessboard, makes consistent false
#: correspondences that agree on a wrong F, but not so many), and at least CHANCE_FACTOR
#: times as many as support the best F of the same correspondences with their right
#: points shuffled (a permutation test: what MAGSAC finds by chance in point sets of that
#: size and spread), plus CHANCE_MARGIN.
MIN_INLIERS = 30
MIN_INLIER_RATIO = 0.25
CHANCE_FACTOR = 2.0
CHANCE_MARGIN = 10
#: Guided rounds of the SIFT bootstrap (not the guided pass of
#: :mod:`hopmatch.matching.guided`): once an F is accepted, every SIFT keypoint of the
#: left image is matched again among the right keypoints within BOOTSTRAP_BAND px (symmetric
#: epipolar distance, full-resolution pixels per pyramid level) of its epipolar line, with
#: the ratio test among those only (and mutual), and F is fitted again on those matches;
#: the refit is kept when it is accepted too. Along one epipolar line a keypoint has fewer
#: look-alikes than in the whole image (a repeated texture, a board's corners), so more
#: keypoints pass the ratio test there, some at depths the first matches missed, which
#: constrain the epipole (docs/pipelines.md, "Guided bootstrap rounds").
BOOTSTRAP_ROUNDS = 2
BOOTSTRAP_BAND = 8.0
#: The refit on the final matches: MAGSAC threshold (full-resolution pixels).
REFIT_THRESHOLD = 1.0
#: Points compared in the descriptor bootstrap, the half-height of its window (fraction of
#: the image height, at least :data:`WINDOW_MIN` px), its ratio test, and the most pairs it
#: compares.
DESCRIPTOR_POINTS = 1500
WINDOW_FRACTION = 0.12
WINDOW_MIN = 32.0
DESCRIPTOR_RATIO = 0.8
DESCRIPTOR_MAX_PAIRS = 6_000_000


@dataclass(frozen=True)
class EpipolarGeometry:
    """What :func:`estimate_geometry` found.

    Attributes
    ----------
    fundamental : (3, 3) float64 ndarray or None
        ``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``; None when the pair did not support one
        (``reason`` says why).
    left_points, right_points : (N, 2) float32 ndarrays
        The bootstrap correspondences, in full-resolution pixels.
    inliers : (N,) bool ndarray
        Which of them agree with ``fundamental``.
    median_error : float
        Median symmetric epipolar distance of the inliers, in pixels (NaN without F).
    source : str
        ``'sift'`` or ``'descriptors'``: where the correspondences came from (``'refit'``:
        the final matches, F refitted on them; ``'given'``: F was given, the SIFT
        correspondences are those that agree with it, :func:`given_geometry`).
    reason : str or None
        Why no F was accepted.
    search : str or None
        How the network searched the pair (``hopmatch.matching.unrectified``): ``'aligned'``
        (rows of the right image aligned by a similarity), ``'rectified'`` (rows of a
        projective rectification) or ``'epipolar'`` (the band of F).
    """

    fundamental: np.ndarray | None
    left_points: np.ndarray
    right_points: np.ndarray
    inliers: np.ndarray
    median_error: float
    source: str
    reason: str | None = None
    search: str | None = None

    @property
    def n_correspondences(self) -> int:
        """Number of bootstrap correspondences."""
        return len(self.left_points)

    @property
    def n_inliers(self) -> int:
        """Number of them that agree with ``fundamental``."""
        return int(self.inliers.sum())

    @property
    def inlier_ratio(self) -> float:
        """``n_inliers / n_correspondences`` (0 without correspondences)."""
        return self.n_inliers / self.n_correspondences if self.n_correspondences else 0.0


def symmetric_epipolar_error(F, left, right) -> np.ndarray:
    """Mean of the two point-to-epipolar-line distances of each correspondence, pixels."""
    hl = np.c_[left.astype(np.float64), np.ones(len(left))]
    hr = np.c_[right.astype(np.float64), np.ones(len(right))]
    lr = hl @ F.T          # lines in the right image
    ll = hr @ F            # lines in the left image
    num = np.abs(np.einsum("ij,ij->i", hr, lr))
    with np.errstate(divide="ignore", invalid="ignore"):
        d = 0.5 * (num / np.hypot(lr[:, 0], lr[:, 1]) + num / np.hypot(ll[:, 0], ll[:, 1]))
    return np.where(np.isfinite(d), d, np.inf)


#: :func:`to_uint8` stretches float images whose levels span less than this in float64.
TINY_SPAN = 1e-30


def to_uint8(gray: np.ndarray) -> np.ndarray:
    """A grey image as uint8 for OpenCV's feature detectors (16-bit and float images are
    stretched from their minimum to their maximum)."""
    if gray.dtype == np.uint8:
        return gray
    g = gray.astype(np.float32)
    lo, hi = float(g.min()), float(g.max())
    if hi <= lo:
        return np.zeros(g.shape, np.uint8)
    if hi - lo < TINY_SPAN:  # levels near float32's smallest: OpenCV's gain would overflow
        stretched = (gray.astype(np.float64) - lo) * (255.0 / (hi - lo))
        return np.clip(np.rint(stretched), 0, 255).astype(np.uint8)
    return cv2.convertScaleAbs(g, alpha=255.0 / (hi - lo), beta=-255.0 * lo / (hi - lo))


def bootstrap_level(shape, max_side: int) -> int:
    """How many times :func:`pyramid_level` halves an image of ``shape`` ((H, W, ...)):
    until its longer side is at most ``max_side`` (``cv2.pyrDown`` rounds up), or a side
    is below 32."""
    h, w = shape[:2]
    level = 0
    while max(h, w) > max_side and min(h, w) >= 32:
        h, w = (h + 1) // 2, (w + 1) // 2
        level += 1
    return level


def pyramid_level(gray: np.ndarray, max_side: int):
    """``(image, level)``: ``gray`` reduced by ``cv2.pyrDown`` :func:`bootstrap_level`
    times; a point ``p`` of the reduced image is ``(p + 0.5) * 2**level - 0.5`` in
    ``gray``."""
    level = bootstrap_level(gray.shape, max_side)
    for _ in range(level):
        gray = cv2.pyrDown(gray)
    return gray, level


def sift_features(left_gray, right_gray):
    """``(left keypoint positions, left descriptors, right positions, right descriptors,
    level)``: OpenCV SIFT (:data:`BOOTSTRAP_FEATURES`, :data:`BOOTSTRAP_CONTRAST`) on the
    pyramid levels of two grey images whose longer side is at most
    :data:`BOOTSTRAP_SIDE`, positions in full-resolution pixels (float64); descriptors None
    when an image has fewer than two keypoints."""
    a, level = pyramid_level(to_uint8(left_gray), BOOTSTRAP_SIDE)
    b, _ = pyramid_level(to_uint8(right_gray), BOOTSTRAP_SIDE)
    sift = cv2.SIFT_create(nfeatures=BOOTSTRAP_FEATURES, contrastThreshold=BOOTSTRAP_CONTRAST)
    ka, da = sift.detectAndCompute(a, None)
    kb, db = sift.detectAndCompute(b, None)
    s = float(2 ** level)

    def positions(kps):
        if len(kps) == 0:  # KeyPoint_convert gives () for no keypoint
            return np.zeros((0, 2))
        return (np.asarray(cv2.KeyPoint_convert(kps), np.float64).reshape(-1, 2) + 0.5) * s - 0.5

    if da is None or db is None or len(ka) < 2 or len(kb) < 2:
        da = db = None
    return positions(ka), da, positions(kb), db, level


def ratio_pairs(da, db, ratio: float, mask=None) -> tuple[np.ndarray, np.ndarray]:
    """``(left indices, right indices)``: the mutual nearest neighbours (L2) of two
    descriptor sets that pass Lowe's ``ratio`` test, among the pairs ``mask`` allows
    ((N, M) uint8, or None: all)."""
    bf = cv2.BFMatcher(cv2.NORM_L2)
    fwd = bf.knnMatch(da, db, k=2, mask=mask) if mask is not None else bf.knnMatch(da, db, k=2)
    back_raw = (bf.knnMatch(db, da, k=1, mask=np.ascontiguousarray(mask.T))
                if mask is not None else bf.knnMatch(db, da, k=1))
    back = {m[0].queryIdx: m[0].trainIdx for m in back_raw if m}
    pairs = [(p[0].queryIdx, p[0].trainIdx) for p in fwd
             if p and (len(p) == 1 or p[0].distance < ratio * p[1].distance)
             and back.get(p[0].trainIdx) == p[0].queryIdx]
    if not pairs:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    qi, ti = np.array(pairs, dtype=np.intp).T
    return qi, ti


def sift_correspondences(left_gray, right_gray):
    """``(left_points, right_points, level)``: SIFT matches (Lowe's ratio test
    :data:`BOOTSTRAP_RATIO`, mutual) between the pyramid levels of two grey images whose
    longer side is at most :data:`BOOTSTRAP_SIDE`, in full-resolution pixels."""
    pa, da, pb, db, level = sift_features(left_gray, right_gray)
    empty = np.zeros((0, 2), np.float32)
    if da is None:
        return empty, empty, level
    qi, ti = ratio_pairs(da, db, BOOTSTRAP_RATIO)
    return pa[qi].astype(np.float32), pb[ti].astype(np.float32), level


def epipolar_band(F, left, right, band: float) -> np.ndarray:
    """(N, M) uint8: 1 where right point m lies within ``band`` px of left point n's
    epipolar line and n within ``band`` px of m's (``[xr, yr, 1] @ F @ [xl, yl, 1] ==
    0``)."""
    hl = np.c_[left, np.ones(len(left))]
    hr = np.c_[right, np.ones(len(right))]
    lines_r = hl @ F.T  # in the right image, one per left point
    lines_l = hr @ F  # in the left image, one per right point
    with np.errstate(divide="ignore", invalid="ignore"):
        d_r = np.abs(lines_r @ hr.T) / np.hypot(lines_r[:, :1], lines_r[:, 1:2])
        d_l = (np.abs(lines_l @ hl.T) / np.hypot(lines_l[:, :1], lines_l[:, 1:2])).T
        return ((d_r <= band) & (d_l <= band)).astype(np.uint8)


def descriptor_correspondences(q_pts, t_pts, qd, td, size, *, min_disparity=None,
                               max_disparity=None, n_points: int = DESCRIPTOR_POINTS,
                               ratio: float = DESCRIPTOR_RATIO,
                               max_pairs: int = DESCRIPTOR_MAX_PAIRS):
    """``(left_points, right_points)``: the clear best look-alikes (by the network's
    similarity distance, eqs. 7-9, ratio test) of a thinned set of left points among the
    right points of a two-dimensional window: ``xl - xr`` within the disparity range (by
    default plus or minus a quarter of the width) and ``|yl - yr|`` within
    :data:`WINDOW_FRACTION` of the height. Fewer points are compared when the window would
    hold more than ``max_pairs`` pairs."""
    empty = np.zeros((0, 2), np.float32)
    if len(q_pts) < 2 or len(t_pts) < 2:
        return empty, empty
    width, height = size
    hi = 0.25 * width if max_disparity is None else float(max_disparity)
    lo = -0.25 * width if min_disparity is None else float(min_disparity)
    band = max(WINDOW_MIN, WINDOW_FRACTION * height)
    keep = thin_points(q_pts, n_points)
    while True:
        left = np.ascontiguousarray(q_pts[keep])
        try:
            ni, nk = candidate_pairs(left, t_pts, lo, hi, band, max_pairs, sort=False)
            break
        except BudgetExceededError:
            if len(keep) <= 2 * MIN_INLIERS:
                return empty, empty
            keep = keep[::2]
    if len(ni) == 0:
        return empty, empty
    sim = similarity_distance(np.ascontiguousarray(qd[keep]), td, ni, nk)
    lefts, best = clear_best_look_alikes(ni, nk, sim, ratio)
    return left[lefts], np.ascontiguousarray(t_pts[nk[best]])


def magsac(left, right, threshold):
    """``(F, mask)`` of ``cv2.findFundamentalMat`` with ``cv2.USAC_MAGSAC`` (None, None when
    OpenCV finds none)."""
    try:
        F, mask = cv2.findFundamentalMat(left.astype(np.float64), right.astype(np.float64),
                                         cv2.USAC_MAGSAC, threshold, F_CONFIDENCE,
                                         F_ITERATIONS)
    except cv2.error:
        return None, None
    if F is None or F.shape != (3, 3) or not np.isfinite(F).all():
        return None, None
    return F, mask


def chance_inliers(left, right, threshold) -> int:
    """Inliers of the best F (:func:`magsac`) of ``left`` with ``right`` shuffled (a fixed
    permutation): the support a fundamental matrix finds in unrelated points."""
    perm = np.random.default_rng(0).permutation(len(right))
    F, mask = magsac(left, right[perm], threshold)
    return 0 if F is None or mask is None else int((mask.ravel() != 0).sum())


def robust_fundamental(left, right, threshold: float = F_THRESHOLD, source: str = "sift",
                       *, min_inliers: int = MIN_INLIERS) -> EpipolarGeometry:
    """F of correspondences by MAGSAC (``cv2.USAC_MAGSAC``), refused (``fundamental`` None,
    ``reason`` set) when fewer than ``min_inliers`` or than :data:`MIN_INLIER_RATIO` of
    them agree, or not clearly more than agree by chance (:func:`chance_inliers`,
    :data:`CHANCE_FACTOR`)."""
    left = np.ascontiguousarray(left, np.float32).reshape(-1, 2)
    right = np.ascontiguousarray(right, np.float32).reshape(-1, 2)
    n = len(left)
    none = np.zeros(n, bool)
    if n < max(8, min_inliers):
        return EpipolarGeometry(None, left, right, none, float("nan"), source, (
            f"only {n} bootstrap correspondences were found between the images (at least "
            f"{max(8, min_inliers)} are needed): the images have too little texture, or "
            "do not show the same scene"))
    F, mask = magsac(left, right, threshold)
    if F is None:
        return EpipolarGeometry(None, left, right, none, float("nan"), source, (
            f"no fundamental matrix fits the {n} bootstrap correspondences (a degenerate "
            "configuration: points on a line, or a plane seen without parallax)"))
    F = np.ascontiguousarray(F / np.linalg.norm(F), np.float64)
    err = symmetric_epipolar_error(F, left, right)
    inliers = err <= threshold if mask is None else (mask.ravel() != 0) & (err <= 2 * threshold)
    k = int(inliers.sum())
    median = float(np.median(err[inliers])) if k else float("nan")
    chance = chance_inliers(left, right, threshold) if k >= min_inliers else 0
    need = max(min_inliers, int(np.ceil(CHANCE_FACTOR * chance)) + CHANCE_MARGIN,
               int(np.ceil(MIN_INLIER_RATIO * n)))
    if k < need:
        return EpipolarGeometry(None, left, right, inliers, median, source, (
            f"only {k} of {n} bootstrap correspondences agree on a fundamental matrix "
            f"({need} are needed; {chance} agree on one when the correspondences are "
            "shuffled): the images do not seem to show the same scene from two "
            "viewpoints, or too little of it"))
    return EpipolarGeometry(F, left, right, inliers, median, source)


def estimate_geometry(left_gray, right_gray) -> EpipolarGeometry:
    """SIFT bootstrap correspondences of two grey images (:func:`sift_correspondences`),
    then :func:`robust_fundamental`; once that accepts an F, :data:`BOOTSTRAP_ROUNDS` guided
    rounds: the SIFT keypoints matched again within :data:`BOOTSTRAP_BAND` px (per pyramid
    level) of each other's epipolar lines (:func:`epipolar_band`, :func:`ratio_pairs`) and F
    fitted on those matches (:func:`robust_fundamental`, which must accept it, else the F
    before is kept). The correspondences returned stay the unguided ones, with the inliers
    of the last F among them (the guided matches include look-alikes slid along the lines,
    which agree with F but would mislead the row alignment and the disparity range); when
    fewer than half as many of them agree with it as with the first F, the first is
    returned."""
    pa, da, pb, db, level = sift_features(left_gray, right_gray)
    threshold = F_THRESHOLD * 2 ** level
    if da is None:
        empty = np.zeros((0, 2), np.float32)
        return robust_fundamental(empty, empty, threshold, "sift")
    qi, ti = ratio_pairs(da, db, BOOTSTRAP_RATIO)
    geometry = robust_fundamental(pa[qi], pb[ti], threshold, "sift")
    F = geometry.fundamental
    for _ in range(BOOTSTRAP_ROUNDS if F is not None else 0):
        gi, gt = ratio_pairs(da, db, BOOTSTRAP_RATIO,
                             epipolar_band(F, pa, pb, BOOTSTRAP_BAND * 2 ** level))
        guided = robust_fundamental(pa[gi], pb[gt], threshold, "sift")
        if guided.fundamental is None:
            break
        F = guided.fundamental
    if F is None or F is geometry.fundamental:
        return geometry
    # the guided matches along the lines include look-alikes slid along them (consistent
    # with F, but not correspondences): the correspondences stay the unguided ones
    left, right = geometry.left_points, geometry.right_points
    err = symmetric_epipolar_error(F, left, right)
    inliers = err <= threshold
    if inliers.sum() < geometry.inliers.sum() // 2:
        return geometry
    return EpipolarGeometry(F, left, right, inliers, float(np.median(err[inliers])), "sift")


def given_geometry(fundamental, left_gray, right_gray) -> EpipolarGeometry:
    """The given ``fundamental`` (3 x 3, checked) with the SIFT bootstrap correspondences
    of two grey images (:func:`sift_correspondences`) within ``F_THRESHOLD x 2**level`` px
    of its lines (symmetric) as its inliers, source ``'given'``: what the unrectified path
    needs to line up the rows (:func:`row_alignment`) of a pair whose F is known. Refused
    (``fundamental`` None, ``reason`` set) when fewer than :data:`MIN_INLIERS` agree."""
    pl, pr, level = sift_correspondences(left_gray, right_gray)
    threshold = F_THRESHOLD * 2 ** level
    F = np.ascontiguousarray(fundamental, np.float64)
    err = symmetric_epipolar_error(F, pl, pr) if len(pl) else np.zeros(0)
    inliers = err <= threshold
    k = int(inliers.sum())
    median = float(np.median(err[inliers])) if k else float("nan")
    if k < MIN_INLIERS:
        return EpipolarGeometry(None, pl, pr, inliers, median, "given", (
            f"only {k} of {len(pl)} bootstrap correspondences lie within {threshold:g} px of "
            f"the given fundamental matrix's epipolar lines (at least {MIN_INLIERS} are "
            "needed to line up the rows)"))
    return EpipolarGeometry(F, pl, pr, inliers, median, "given")


def estimate_geometry_of_points(q_pts, t_pts, qd, td, size) -> EpipolarGeometry:
    """The matcher's own descriptors compared in a two-dimensional window
    (:func:`descriptor_correspondences`; ``size`` is the left image's ``(width, height)``,
    or None for the keypoints' extent), then :func:`robust_fundamental`."""
    if size is None:
        both = np.concatenate([q_pts, t_pts]) if len(q_pts) + len(t_pts) else np.zeros((1, 2))
        size = (float(both[:, 0].max()) + 1.0, float(both[:, 1].max()) + 1.0)
    pl, pr = descriptor_correspondences(q_pts, t_pts, qd, td, size)
    return robust_fundamental(pl, pr, F_THRESHOLD, "descriptors")


def refit_fundamental(geometry: EpipolarGeometry, left, right,
                      threshold: float = REFIT_THRESHOLD) -> EpipolarGeometry:
    """F of the final matches (``left[i]`` <-> ``right[i]``) by MAGSAC, or ``geometry``
    unchanged when they do not support one better (fewer than :data:`MIN_INLIERS`)."""
    refit = robust_fundamental(left, right, threshold, "refit")
    return geometry if refit.fundamental is None else refit


def transform_points(points, H) -> np.ndarray:
    """``(N, 2)`` points through the 3 x 3 homography ``H``, float32."""
    if len(points) == 0:
        return np.zeros((0, 2), np.float32)
    p = np.c_[np.asarray(points, np.float64), np.ones(len(points))] @ np.asarray(H).T
    return np.ascontiguousarray(p[:, :2] / p[:, 2:3], dtype=np.float32)


def rectifying_homographies(F, left, right, size):
    """``(H1, H2)``: projective maps of the left and right image onto one frame where every
    epipolar line of ``F`` is a row, as close to the images' own coordinates as possible.

    ``cv2.stereoRectifyUncalibrated`` (on the correspondences ``left``, ``right``, ideally
    inliers of F) gives one such pair, which :func:`closest_row_maps` brings nearest the
    images' coordinates. None when OpenCV finds no rectification."""
    pl = np.asarray(left, np.float64).reshape(-1, 2)
    pr = np.asarray(right, np.float64).reshape(-1, 2)
    try:
        ok, H1, H2 = cv2.stereoRectifyUncalibrated(pl, pr, F, (int(size[0]), int(size[1])))
    except cv2.error:
        return None
    if not ok or H1 is None or H2 is None or not (np.isfinite(H1).all()
                                                   and np.isfinite(H2).all()):
        return None
    return closest_row_maps(H1, H2, pl, pr, size)


def closest_row_maps(H1, H2, left, right, size):
    """``(H1', H2')``: the rectifying maps ``H1``, ``H2`` (rows of one frame) followed by the
    maps that keep rows as rows and bring the rectified correspondences closest to the given
    ones: the same ``y -> e y + f`` for both images, and for each image its own ``x -> a x
    + b y + c``, fitted by least squares so that the rectified coordinates of ``left`` (and
    ``right``) stay closest to the given ones (the network's lengths then keep their meaning
    in pixels). Each map is scaled so that its ``w`` is positive at the image's centre."""
    pl = np.asarray(left, np.float64).reshape(-1, 2)
    pr = np.asarray(right, np.float64).reshape(-1, 2)
    ql = transform_points(pl, H1).astype(np.float64)
    qr = transform_points(pr, H2).astype(np.float64)
    ey, fy = np.linalg.lstsq(np.c_[ql[:, 1], np.ones(len(ql))], pl[:, 1], rcond=None)[0]
    centre = np.array([(size[0] - 1) / 2, (size[1] - 1) / 2, 1.0])
    out = []
    for q, p, H in ((ql, pl, H1), (qr, pr, H2)):
        a, b, c = np.linalg.lstsq(np.c_[q, np.ones(len(q))], p[:, 0], rcond=None)[0]
        M = np.array([[a, b, c], [0.0, ey, fy], [0.0, 0.0, 1.0]]) @ H
        # a homography is defined up to scale, and OpenCV's may come with a negative one
        # (w < 0 at every point): the same map, scaled so that w > 0 at the image's centre
        out.append(-M if (M @ centre)[2] < 0 else M)
    return out[0], out[1]


#: Quasi-Euclidean rectification (:func:`quasi_euclidean_homographies`): most
#: Levenberg-Marquardt iterations, and the rounds that drop the correspondences beyond
#: QUASI_EUCLIDEAN_TRIM x the median Sampson error before fitting again.
QUASI_EUCLIDEAN_ITERATIONS = 100
QUASI_EUCLIDEAN_ROUNDS = 2
QUASI_EUCLIDEAN_TRIM = 4.0
#: The focal length stays within 3**-QUASI_EUCLIDEAN_ZOOM to 3**QUASI_EUCLIDEAN_ZOOM times
#: ``w + h`` (the 3**a of the parametrisation).
QUASI_EUCLIDEAN_ZOOM = 2.0
#: Weight (px per unit: per radian of each turn, per unit of the focal length's exponent)
#: of the ridge that keeps the fit's parameters small (:func:`_levenberg_marquardt`).
QUASI_EUCLIDEAN_RIDGE = 1e-3


def _inverse_intrinsics(K) -> np.ndarray:
    """The inverse of ``[[f, 0, cx], [0, f, cy], [0, 0, 1]]`` (f > 0), in closed form."""
    f, cx, cy = K[0, 0], K[0, 2], K[1, 2]
    return np.array([[1.0 / f, 0.0, -cx / f], [0.0, 1.0 / f, -cy / f], [0.0, 0.0, 1.0]])


def _rotation(ax, ay, az) -> np.ndarray:
    """``Rx(ax) @ Ry(ay) @ Rz(az)``."""
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return rx @ ry @ rz


def _quasi_euclidean_maps(params, size):
    """``(K, R_left, R_right)`` of the 6 parameters of :func:`quasi_euclidean_homographies`."""
    w, h = float(size[0]), float(size[1])
    f = (w + h) * 3.0 ** float(np.clip(params[0], -QUASI_EUCLIDEAN_ZOOM, QUASI_EUCLIDEAN_ZOOM))
    K = np.array([[f, 0.0, (w - 1) / 2], [0.0, f, (h - 1) / 2], [0.0, 0.0, 1.0]])
    return K, _rotation(0.0, params[1], params[2]), _rotation(*params[3:6])


def _sampson(params, hl, hr, size) -> np.ndarray:
    """Sampson distances of the correspondences (homogeneous rows ``hl``, ``hr``) to the
    fundamental matrix of :func:`_quasi_euclidean_maps`."""
    K, rl, rr = _quasi_euclidean_maps(params, size)
    Ki = _inverse_intrinsics(K)
    F = Ki.T @ rr.T @ np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]) @ rl @ Ki
    fl = hl @ F.T
    fr = hr @ F
    num = np.einsum("ij,ij->i", hr, fl)
    den = np.sqrt(fl[:, 0] ** 2 + fl[:, 1] ** 2 + fr[:, 0] ** 2 + fr[:, 1] ** 2)
    return num / np.maximum(den, 1e-300)


def quasi_euclidean_homographies(left, right, size):
    """``(H1, H2)``: rectifying maps of two views that are rotations of cameras sharing
    one unknown focal length and a centred principal point (``H = K R K^-1``, Fusiello and
    Irsara's quasi-Euclidean rectification, 2008), fitted to the correspondences ``left``,
    ``right`` (ideally inliers of an F) by Levenberg-Marquardt on their Sampson errors;
    then brought nearest the images' coordinates (:func:`closest_row_maps`).

    Six parameters: the focal length ``(w + h) 3**a``, the left camera's turn about its
    vertical and optical axes, and the right camera's about all three (the left's about
    its horizontal axis is left out: turning both views about the baseline keeps the rows
    rows, so only the right camera's turn relative to the left's can be fitted). Unlike a
    map chosen only to send the epipole to infinity, a rotation moves the image as little
    as the geometry needs: a verged or rolled rig is rectified by turning each view back.
    None for fewer than 8 correspondences or a fit that does not converge to finite
    maps."""
    pl = np.asarray(left, np.float64).reshape(-1, 2)
    pr = np.asarray(right, np.float64).reshape(-1, 2)
    if len(pl) < 8:
        return None
    hl = np.c_[pl, np.ones(len(pl))]
    hr = np.c_[pr, np.ones(len(pr))]
    params = np.zeros(6)
    keep = np.ones(len(pl), bool)
    for _ in range(QUASI_EUCLIDEAN_ROUNDS):
        params = _levenberg_marquardt(params, hl[keep], hr[keep], size)
        err = np.abs(_sampson(params, hl, hr, size))
        keep = err <= QUASI_EUCLIDEAN_TRIM * max(float(np.median(err)), 1e-6)
        if keep.sum() < 8:
            return None
    K, rl, rr = _quasi_euclidean_maps(params, size)
    Ki = _inverse_intrinsics(K)
    H1, H2 = K @ rl @ Ki, K @ rr @ Ki
    if not (np.isfinite(H1).all() and np.isfinite(H2).all()):
        return None
    return closest_row_maps(H1, H2, pl, pr, size)


def _levenberg_marquardt(params, hl, hr, size) -> np.ndarray:
    """``params`` moved by at most :data:`QUASI_EUCLIDEAN_ITERATIONS` Levenberg-Marquardt
    steps on the sum of squared Sampson errors plus ``(QUASI_EUCLIDEAN_RIDGE params)**2``
    (forward-difference Jacobian), the focal length's exponent kept within
    +-:data:`QUASI_EUCLIDEAN_ZOOM`. The small ridge settles the near-trade between the
    focal length and the turns, which the errors alone leave to drift (to a long focal
    length and turns of 20 degrees that line the points up almost as well)."""

    def residuals(p):
        return np.r_[_sampson(p, hl, hr, size), QUASI_EUCLIDEAN_RIDGE * p]

    lam = 1e-3
    step = 1e-6
    r = residuals(params)
    cost = float(r @ r)
    for _ in range(QUASI_EUCLIDEAN_ITERATIONS):
        J = np.empty((len(r), len(params)))
        for k in range(len(params)):
            moved = params.copy()
            moved[k] += step
            J[:, k] = (residuals(moved) - r) / step
        A = J.T @ J
        g = J.T @ r
        while True:
            try:
                delta = np.linalg.solve(A + lam * np.diag(np.diag(A) + 1e-12), -g)
            except np.linalg.LinAlgError:
                return params
            trial = params + delta
            trial[0] = np.clip(trial[0], -QUASI_EUCLIDEAN_ZOOM, QUASI_EUCLIDEAN_ZOOM)
            rt = residuals(trial)
            ct = float(rt @ rt)
            if np.isfinite(ct) and ct < cost:
                improved = cost - ct
                params, r, cost, lam = trial, rt, ct, max(lam / 10.0, 1e-12)
                break
            lam *= 10.0
            if lam > 1e12:
                return params
        if improved <= 1e-12 * max(cost, 1e-300):
            break
    return params


def alignment_turn(geometry: EpipolarGeometry) -> tuple[float, float]:
    """``(degrees, scale)`` of :func:`row_alignment`'s similarity: how far the right image
    is turned and by what factor it is scaled relative to the left one (0 and 1 for a
    rectified pair)."""
    S = row_alignment(geometry)
    return float(np.degrees(np.arctan2(S[1, 0], S[0, 0]))), float(np.hypot(S[0, 0], S[1, 0]))


def row_alignment(geometry: EpipolarGeometry, iterations: int = 3) -> np.ndarray:
    """The similarity ``S`` (3 x 3: rotation, scale, translation) with ``right = S @
    aligned`` that best lines up the rows of the inliers: it maps each right inlier to the
    row of its left partner, ``(S^-1 @ right)_y ~ left_y``, by least squares over the
    inliers within ``max(1 px, 3 x the median residual)`` (``iterations`` rounds).

    Only the rows are fitted: the x offsets of the matches hold the disparities, which a
    full fit would fold into a false rotation or scale. The x translation of ``S^-1`` is
    left at 0 (the disparities keep an unknown common offset)."""
    left = geometry.left_points[geometry.inliers].astype(np.float64)
    right = geometry.right_points[geometry.inliers].astype(np.float64)
    X = np.c_[right, np.ones(len(right))]
    keep = np.ones(len(X), bool)
    for _ in range(iterations):
        coef = np.linalg.lstsq(X[keep], left[keep, 1], rcond=None)[0]
        res = np.abs(X @ coef - left[:, 1])
        keep = res <= max(1.0, 3.0 * float(np.median(res)))
    b, a, ty = coef
    # aligned = [[a, -b, 0], [b, a, ty]] @ right: a similarity whose second row is the fit
    to_aligned = np.array([[a, -b, 0.0], [b, a, ty], [0.0, 0.0, 1.0]])
    return np.linalg.inv(to_aligned)
