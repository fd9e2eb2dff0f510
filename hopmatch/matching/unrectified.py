"""Matching an unrectified pair whose geometry nobody gave: ``match_stereo(...,
rectified=False)``.

1. Epipolar geometry from the pair (:func:`~hopmatch.matching.geometry.estimate_geometry`:
   SIFT bootstrap, MAGSAC fundamental matrix, checks).
2. The right image is brought into the left one's frame by the similarity (rotation,
   scale, shift) that best aligns the rows of the bootstrap inliers
   (:func:`~hopmatch.matching.geometry.row_alignment`), and the right points are detected
   there. The network's lengths (the disparity ``d`` of eq. 6 and the length-invariance
   ``ΔD`` of eq. 10) compare positions in the two images: they only mean what SPEC
   section 2 says once rotation and scale between the images are gone, and the detector's
   four Moravec directions (eq. 1) only find the same points when both images face the
   same way.
3. The sharper image is blurred towards the other's sharpness
   (:func:`~hopmatch.feature.sharpness.equalise_sharpness`, ``sharpness_ratio``): the warp
   smooths the right image, and the similarity of eqs. 7-9 compares windows.
4. The network searches rows (of the aligned pair, or of a rectification close to the
   identity) or else the epipolar band of F (:func:`search_frame`), over the disparity
   range a coarse pass finds there (:func:`network_range`). F is refitted on the
   network's matches (the F reported).
5. On the aligned rows or the rows of the rectification, the guided second pass and the
   sub-pixel refinement of a rectified pair follow
   (``hopmatch.matching.stereo_match.unrectified_beyond_network``), on the images of
   :func:`shared_frame` or :func:`rectified_canvas`.

What the images show nothing of (outside the right image, its mask, :func:`black_padding`)
holds the median grey level of the rest (:func:`warp_right`, :func:`fill_padding`).

Points are reported in the coordinates of the images given. The choices were measured on
perturbed shared scenes and the chessboard photos (``benchmarks/unrectified.py``;
docs/pipelines.md, "Which call for which pair").
"""

from __future__ import annotations

import dataclasses
import time

import cv2
import numpy as np

from .._validate import as_mask, check_coordinate_range
from .._warnings import deferring
from ..errors import InvalidArgumentError
from ..feature.descriptor import cut_windows
from ..feature.padding import black_padding, fill_padding
from ..feature.sharpness import SharpnessMatch, equalise_sharpness
from .disparity_range import DisparityRange, coarse_extent
from .geometry import (
    EpipolarGeometry,
    estimate_geometry,
    given_geometry,
    quasi_euclidean_homographies,
    rectifying_homographies,
    refit_fundamental,
    row_alignment,
    symmetric_epipolar_error,
    transform_points,
)
from .network import NetworkResult, PairInfo, match_pair, run_hopfield_network
from .tone import ToneMap, rematch_through_map
from .vertical import robust_fit, row_plane_residual

#: A range in the search frame: an extent widened on each side by this fraction of its
#: span, plus 1 % of the width and 2 px ...
RANGE_SPAN = 0.5
#: ... and shifted so that it starts at this disparity: the network's disparity (eq. 6) is
#: a length, so the aligned disparities must keep one sign.
RANGE_START = 2.0
#: Percentiles of the inliers' disparities taken as their extent (false inliers slide
#: along the epipolar lines and would stretch it).
RANGE_PERCENTILES = (1.0, 99.0)
#: Interpolation of the right image's warp into the left frame.
INTERPOLATION = cv2.INTER_LANCZOS4
#: ``vertical_threshold`` of ``match_stereo(..., rectified=False)`` unless given: a match of
#: an unrectified pair is right when its right point is within 1 px of the truth in both
#: directions, and the aligned right image is resampled, so its rows are less certain
#: than a rectified pair's (docs/pipelines.md, "Which call for which pair").
UNRECTIFIED_VERTICAL = 0.75
#: Passes of the network: after each but the last, F is refitted on its matches and the
#: search frame rebuilt from it.
PASSES = 1
#: Refit F on the final matches (the F reported; the matches are those of the last pass).
REFITS = True
#: How the network searches the aligned pair (:func:`search_frame`, in SEARCH_ORDER): the
#: aligned rows when they line up the inliers nearly as well as F does (median |dy| within
#: ROW_FACTOR x F's median epipolar error, or ROW_PIXELS, within the network's
#: :data:`UNRECTIFIED_VERTICAL`: a near-degenerate F, from a scene close to one plane,
#: fits its inliers worse than the rows do), else the rows of a
#: projective rectification of both point sets
#: (:func:`~hopmatch.matching.geometry.rectifying_homographies`), unless it moves a point
#: of the image by more than RECTIFY_LIMIT of its diagonal (:func:`near_identity`; a
#: near-degenerate F gives wild rectifications): then the epipolar band of F (slower: the
#: candidate search cannot index rows; and the guided pass and the refinement, which
#: read the images along rows, do not follow).
ROW_FACTOR = 1.5
ROW_PIXELS = 0.5
RECTIFY_LIMIT = 0.1
SEARCH_ORDER = ("aligned", "rectified", "epipolar")
#: ... and the plane vertical model the network fits (``dy = a + b x + c y``, robustly) must
#: leave the inliers within ROW_PLANE_FACTOR x F's epipolar error of them, or
#: ROW_PLANE_PIXELS, at the 90th percentile, and bend from that plane by at most
#: ROW_CURVE_PIXELS (:func:`rows_fit`): a verged rig's rows converge (keystone), which
#: neither a similarity nor that plane takes out, though the median |dy| may stay small.
#: The rows of a quasi-Euclidean rectification pass the same.
ROW_PLANE_FACTOR = 1.5
ROW_PLANE_PIXELS = 0.5
ROW_CURVE_PIXELS = 0.6
#: Where OpenCV's rectification moves the image too far, try the quasi-Euclidean one
#: (:func:`rectification`).
QUASI_EUCLIDEAN = True
#: ... and the aligned rows also need an offset that drifts by at most this many px with
#: the disparity across the inliers, beyond a plane in their position (:func:`row_drift`):
#: when the left view is the one turned, or both are, ``dy`` grows with the disparity
#: (``d sin(angle)``), which a similarity of the right image cannot take out and a
#: median hides. Rows that drift more are searched only when no rectification near the
#: identity is found (docs/pipelines.md, "A left view turned").
ROW_DRIFT = 0.5
#: OpenCV's warps (``cv2.warpAffine``, ``cv2.warpPerspective``) take images, given and
#: made, of fewer than this many pixels a side (``SHRT_MAX``).
WARP_LIMIT = 32767


def warpable(*shapes) -> bool:
    """Whether images of these ``(H, W, ...)`` shapes fit OpenCV's warps
    (:data:`WARP_LIMIT`); shapes that are not of an image count as fitting (the
    validation of the images refuses them)."""
    for shape in shapes:
        if len(shape) >= 2 and max(int(shape[0]), int(shape[1])) >= WARP_LIMIT:
            return False
    return True


def check_warpable(image: np.ndarray, name: str) -> None:
    """Raise :class:`~hopmatch.errors.InvalidArgumentError` when the grey image ``image``
    (``name``) is too large a side for OpenCV's warps, which the unrectified path needs."""
    if not warpable(np.shape(image)):
        h, w = np.shape(image)[:2]
        raise InvalidArgumentError(
            f"`{name}` is {w} x {h} px: an unrectified pair is brought into one frame by "
            f"OpenCV's warps, which take images of at most {WARP_LIMIT - 1} px a side; crop "
            f"or downscale the pair, or rectify it and pass rectified=True"
        )


def shift_x(shift: float) -> np.ndarray:
    """The 3 x 3 map ``x -> x + shift``."""
    return np.array([[1.0, 0.0, shift], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])


def inlier_range(left, right, width: float):
    """``(lo, hi, shift)``: the disparity range ``xl - xr`` of inlier correspondences
    (:data:`RANGE_PERCENTILES`, widened by :data:`RANGE_SPAN`) after moving the right
    points by ``shift`` in x, the shift that makes it start at :data:`RANGE_START`."""
    d = np.asarray(left, np.float64)[:, 0] - np.asarray(right, np.float64)[:, 0]
    lo, hi = np.percentile(d, RANGE_PERCENTILES)
    pad = RANGE_SPAN * (hi - lo) + 0.01 * width + 2.0
    lo, hi = lo - pad, hi + pad
    shift = lo - RANGE_START  # xr + shift - ... : d - (lo - start) starts at start
    return RANGE_START, hi - shift, shift


def aligned_frame(geometry: EpipolarGeometry, size, right_size):
    """The 3 x 3 map from the right image (``right_size``, ``(W, H)``) to the left image's
    frame (``size``): the similarity of :func:`~hopmatch.matching.geometry.row_alignment`,
    then the whole-pixel x shift that brings the right image's centre to the column of the
    left one's (:func:`warp_right` keeps the left image's size).

    Where the right image sits in x does not matter to the network (:func:`search` shifts
    the points by the range it finds), but it decides which right pixels the frame keeps:
    at its own place every right pixel that can show a point of the left image stays
    inside, whatever the disparities' sign or size. (A shift read from the inliers'
    disparities would push the image out of the frame when false inliers stretch them.)"""
    S = row_alignment(geometry)
    to_aligned = np.linalg.inv(S)
    cx, cy = 0.5 * (right_size[0] - 1), 0.5 * (right_size[1] - 1)
    moved = to_aligned[0, 0] * cx + to_aligned[0, 1] * cy + to_aligned[0, 2]
    return shift_x(float(np.floor(0.5 * (size[0] - 1) - moved + 0.5))) @ to_aligned


def warp_right(right_gray, mask_right, to_aligned, size, margin: int):
    """``(warped, valid)``: the right image in the left frame (:data:`INTERPOLATION`) and
    where it holds right pixels (and ``mask_right``) at least ``margin`` pixels inside
    (bool), so that no point is detected on the warp's edge.

    Outside the right image (and ``mask_right``) the warped image holds the median of the
    grey levels inside: the detector scales each image by the spread of its grey levels
    (:func:`~hopmatch.feature.gradient.normalised_intensity`), and replicated border
    pixels (the black corners of a rotated photo...) would set the right image's scale
    instead of what it shows, and the similarity would then take the two images for
    unrelated (eqs. 7-9). The :func:`black_padding` of the right image counts as outside.
    """
    w, h = int(size[0]), int(size[1])
    warped = cv2.warpAffine(right_gray, to_aligned[:2], (w, h), flags=INTERPOLATION,
                            borderMode=cv2.BORDER_REPLICATE)
    inside = np.full(right_gray.shape, 255, np.uint8)
    if mask_right is not None:
        inside[~mask_right] = 0
    inside[black_padding(right_gray)] = 0
    inside = cv2.warpAffine(inside, to_aligned[:2], (w, h), flags=cv2.INTER_NEAREST,
                            borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    seen = inside > 0
    if seen.any() and not seen.all():
        warped[~seen] = np.median(warped[seen])
    valid = cv2.erode(inside, np.ones((2 * margin + 1, 2 * margin + 1), np.uint8)) > 0
    return warped, valid


def near_identity(maps, size) -> bool:
    """Whether each 3 x 3 map moves every point of a 9 x 9 grid over the image by at most
    :data:`RECTIFY_LIMIT` of its diagonal (and keeps it in front: positive w)."""
    w, h = size
    gx, gy = np.meshgrid(np.linspace(0, w - 1, 9), np.linspace(0, h - 1, 9))
    grid = np.c_[gx.ravel(), gy.ravel(), np.ones(gx.size)]
    for H in maps:
        p = grid @ np.asarray(H).T
        if not (p[:, 2] > 0).all():
            return False
        moved = np.hypot(p[:, 0] / p[:, 2] - grid[:, 0], p[:, 1] / p[:, 2] - grid[:, 1])
        if not moved.max() <= RECTIFY_LIMIT * float(np.hypot(w, h)):
            return False
    return True


def row_drift(points: np.ndarray, disparity: np.ndarray, dy: np.ndarray) -> float:
    """How much ``dy`` changes with the disparity across the points (px), beyond what a
    plane in their position explains: the disparity's coefficient ``e`` of ``dy = a + b x
    + c y + e d``, fitted robustly (:func:`~hopmatch.matching.vertical.robust_fit`, as
    the vertical model is: a few gross outliers among
    correspondences must not make a drift), times the span from the 5th to the 95th
    percentile of the disparities less their own least-squares plane in (x, y) (0 for
    fewer than 8 points, or disparities that are such a plane: a slanted surface's,
    whose ``dy`` the plane vertical model follows anyway)."""
    n = len(disparity)
    if n < 8:
        return 0.0
    position = np.c_[np.ones(n), points - points.mean(axis=0)]
    rd = disparity - position @ np.linalg.lstsq(position, disparity, rcond=None)[0]
    if not float(rd @ rd) > 1e-9 * n:
        return 0.0
    coef = robust_fit(np.c_[position, rd], dy, np.array([float(np.median(dy)), 0.0, 0.0, 0.0]))
    if coef is None:
        return 0.0
    lo, hi = np.percentile(rd, [5.0, 95.0])
    return float(coef[3]) * float(hi - lo)


def rows_fit(geometry, points: np.ndarray, dy: np.ndarray) -> bool:
    """Whether rows offset by ``dy`` (``yl - yr`` of the inliers, left points ``points``,
    in some frame) line the inliers up about as well as F does
    (:func:`row_plane_residual`): their residual within :data:`ROW_PLANE_FACTOR` x the
    90th percentile of F's symmetric epipolar error of the inliers, or
    :data:`ROW_PLANE_PIXELS`, and their curve within :data:`ROW_CURVE_PIXELS`."""
    epipolar = float(np.percentile(symmetric_epipolar_error(
        geometry.fundamental, geometry.left_points[geometry.inliers],
        geometry.right_points[geometry.inliers]), 90.0))
    residual, curve = row_plane_residual(np.asarray(points, np.float64), dy)
    return (residual <= max(ROW_PLANE_FACTOR * epipolar, ROW_PLANE_PIXELS)
            and curve <= ROW_CURVE_PIXELS)


def usable_rectification(H, size) -> bool:
    """Whether the maps ``H`` (or None) rectify near the identity (:func:`near_identity`)
    onto a canvas OpenCV can warp (:data:`WARP_LIMIT`)."""
    return H is not None and near_identity(H, size) and max(canvas(H, size)[1]) < WARP_LIMIT


def rectification(geometry, F, left, right, size):
    """``(H1, H2)`` rectifying the inliers ``left`` and the aligned ``right`` (F relates
    them), or None: OpenCV's (:func:`~hopmatch.matching.geometry.rectifying_homographies`)
    when :func:`usable_rectification`, else, with :data:`QUASI_EUCLIDEAN`, the
    quasi-Euclidean maps (:func:`~hopmatch.matching.geometry.quasi_euclidean_homographies`)
    when usable and their rows fit the inliers (:func:`rows_fit`). OpenCV's choice sends
    the epipole to infinity by a projective map that, for a nearly planar scene's ill-placed
    epipole, moves the image far; the rotations of a verged rig move it little."""
    H = rectifying_homographies(F, left, right, size)
    if usable_rectification(H, size):
        return H
    if not QUASI_EUCLIDEAN:
        return None
    H = quasi_euclidean_homographies(left, right, size)
    if not usable_rectification(H, size):
        return None
    rl, rr = transform_points(left, H[0]), transform_points(right, H[1])
    return H if rows_fit(geometry, rl, rl[:, 1].astype(np.float64) - rr[:, 1]) else None


def search_frame(geometry, to_aligned, size):
    """``(H1, H2, (lo, hi), mode)``: where the network searches (see :data:`SEARCH_ORDER`).

    ``H1`` maps left points and ``H2`` aligned right points into the search frame (``H1``
    None in ``'epipolar'`` mode, where the band of the aligned F is searched), ``(lo,
    hi)`` the inliers' disparity range there (starting at :data:`RANGE_START`), ``mode``
    one of ``'rectified'``, ``'aligned'``, ``'epipolar'``."""
    il = geometry.left_points[geometry.inliers]
    ia = transform_points(geometry.right_points[geometry.inliers], to_aligned)
    drifting = False  # aligned rows that line the inliers up but drift with the disparity
    for mode in SEARCH_ORDER:
        if mode == "rectified":
            to_right = np.linalg.inv(to_aligned)
            F = to_right.T @ geometry.fundamental
            H = rectification(geometry, F / np.linalg.norm(F), il, ia, size)
            if H is None:
                continue
            H1, H2 = H
            rl, ra = transform_points(il, H1), transform_points(ia, H2)
        elif mode == "aligned":
            dy = il[:, 1].astype(np.float64) - ia[:, 1]
            if float(np.median(np.abs(dy))) > max(ROW_FACTOR * geometry.median_error,
                                                  ROW_PIXELS):
                continue
            if abs(row_drift(il.astype(np.float64), il[:, 0].astype(np.float64) - ia[:, 0],
                             dy)) > ROW_DRIFT:
                drifting = True
                continue
            if not rows_fit(geometry, il, dy):
                continue
            H1, H2, rl, ra = np.eye(3), np.eye(3), il, ia
        elif drifting:  # no rectification near the identity: the drifting rows still, as
            # the band would lose the guided pass and the refinement
            H1, H2, rl, ra, mode = np.eye(3), np.eye(3), il, ia, "aligned"
        else:
            H1, H2, rl, ra = None, np.eye(3), il, ia
        lo, hi, shift = inlier_range(rl, ra, size[0])
        return H1, shift_x(shift) @ H2, (lo, hi), mode
    raise AssertionError("SEARCH_ORDER must end with 'epipolar'")  # pragma: no cover


#: Words for the budget warnings (:func:`~hopmatch.matching.disparity_range.run_in_range`)
#: on where the disparities of the network's range are measured.
SEARCH_FRAME_WORDS = "(along the estimated epipolar geometry, in its search frame)"


def network_range(config, q_l, q_r, desc_l, desc_r, width, fundamental, inlier_hi):
    """``(found, shift)``: the disparity range in the search frame measured by the coarse
    pass of the network (:func:`~hopmatch.matching.disparity_range.coarse_extent`, as for a
    rectified pair with ``max_disparity=None``), widened by :data:`RANGE_SPAN`, as a
    :class:`~hopmatch.matching.disparity_range.DisparityRange` (``'coarse'``, its ``found``
    the coarse matches' extent, so that a range beyond a budget is narrowed towards it as a
    rectified pair's is), and the x shift of the right points that makes it start at
    :data:`RANGE_START` (the range is in the frame after that shift).

    The inliers' range is ``[RANGE_START, inlier_hi]`` in the search frame; the coarse pass
    searches half the width around its middle, shifted to positive disparities (the
    network's disparity is a length). When it keeps too few matches, the full pass searches
    that window (``'fallback'``)."""
    c = 0.5 * (RANGE_START + inlier_hi) - 0.25 * width   # coarse d = d - c
    F = None if fundamental is None else shift_x(-c).T @ fundamental
    found = coarse_extent(config, q_l, transform_points(q_r, shift_x(c)), desc_l, desc_r,
                          0.0, 0.5 * width, width, run_hopfield_network, fundamental=F)
    if found is None:
        return (DisparityRange(RANGE_START, RANGE_START + 0.5 * width, "fallback",
                               frame=SEARCH_FRAME_WORDS), c - RANGE_START)
    lo, hi = found[0] + c, found[1] + c
    pad = RANGE_SPAN * (hi - lo) + 0.01 * width + 2.0
    shift = lo - pad - RANGE_START
    return (DisparityRange(RANGE_START, hi + pad - shift, "coarse", (lo - shift, hi - shift),
                           found[2], SEARCH_FRAME_WORDS), shift)


def moved_range(found: DisparityRange, by: float) -> DisparityRange:
    """``found`` with every disparity (its range and the coarse matches' extent) plus
    ``by``."""
    extent = None if found.found is None else (found.found[0] + by, found.found[1] + by)
    return found._replace(min_disparity=found.min_disparity + by,
                          max_disparity=found.max_disparity + by, found=extent)


@dataclasses.dataclass(frozen=True)
class SearchFrame:
    """Where the network of :func:`match_unrectified` searched, for the steps after it.

    Attributes
    ----------
    mode : str
        ``'aligned'``, ``'rectified'`` or ``'epipolar'`` (:func:`search_frame`).
    to_aligned : (3, 3) float64 ndarray
        Right image -> left image's frame (:func:`aligned_frame`).
    shift : int or None
        ``'aligned'`` only: the whole-pixel x shift ``s`` of the aligned right points in the
        network's frame (``q_r = x_a + s``, ``q_l = x_l``), None otherwise.
    right_points : (N, 2) float32 ndarray
        The right points in the left image's frame, as detected there.
    grays, gradients, descriptors : tuples of (left, aligned right)
        The images the points were detected on (the right one warped into the left frame,
        both after :func:`~hopmatch.feature.sharpness.equalise_sharpness`) and the points'
        windows.
    right_shape : tuple of int
        ``(H, W)`` of the right image as given.
    maps : tuple of two (3, 3) float64 ndarrays, or None
        ``'rectified'`` only: the maps of the left points and of the aligned right points
        into the network's frame (``q_l = H1 x_l``, ``q_r = H2 x_a``), None otherwise.
    sharpness : SharpnessMatch or None
        What :func:`~hopmatch.feature.sharpness.equalise_sharpness` measured and did to the
        left image and the aligned right one.
    tone_map : ToneMap or None
        The map between their grey levels read off the network's matches
        (:func:`~hopmatch.matching.tone.tone_map`); when its second match was kept
        (``tone_map.used``), the right points, windows and images are those of the aligned
        right view mapped through it.
    bootstrap : EpipolarGeometry or None
        The geometry estimated from the bootstrap correspondences, before any refit on the
        matches (its inliers judge where F holds: ``hopmatch.matching.epipolar_support``).
    """

    mode: str
    to_aligned: np.ndarray
    shift: int | None
    right_points: np.ndarray
    grays: tuple
    gradients: tuple
    descriptors: tuple
    right_shape: tuple
    maps: tuple | None = None
    sharpness: SharpnessMatch | None = None
    tone_map: ToneMap | None = None
    bootstrap: EpipolarGeometry | None = None


def match_unrectified(left, right, detector, config, *, mask_left=None, mask_right=None,
                      record_energy=False, few_matches_later: list | None = None,
                      fundamental=None):
    """The pipeline of this module's docstring.

    Returns ``(pts_l, resp_l, pts_r, resp_r, network, geometry, timings, frame)``: points
    in the given images' coordinates, the :class:`~hopmatch.matching.network.NetworkResult`
    (or None when no geometry was accepted: ``geometry.reason`` says why), the
    :class:`~hopmatch.matching.geometry.EpipolarGeometry` used, the seconds spent in
    ``geometry``, ``align``, ``detect_left``, ``detect_right`` and ``match``, and the
    :class:`SearchFrame` of the network (None without geometry). ``few_matches_later``:
    as :func:`~hopmatch.matching.network.match_pair`'s, for the network of the last pass.
    ``fundamental``: a known F (checked) to line the rows up with instead of one estimated
    (:func:`~hopmatch.matching.geometry.given_geometry`); it is kept, not refitted.
    """
    t0 = time.perf_counter()
    left_gray = detector.gray_image(left, "left")
    right_gray = detector.gray_image(right, "right")
    check_warpable(left_gray, "left")
    check_warpable(right_gray, "right")
    m_l = as_mask(mask_left, left_gray.shape, "mask_left")
    m_r = as_mask(mask_right, right_gray.shape, "mask_right")
    size = left_gray.shape[::-1]
    geometry = (estimate_geometry(left_gray, right_gray) if fundamental is None
                else given_geometry(fundamental, left_gray, right_gray))
    t1 = time.perf_counter()
    timings = {"geometry": t1 - t0}
    if geometry.fundamental is None:
        pts_l, resp_l, _, _ = detector.detect_and_describe(left_gray, m_l, name="left")
        timings.update(align=0.0, detect_left=time.perf_counter() - t1, detect_right=0.0,
                       match=0.0)
        empty = np.zeros((0, 2), np.float32)
        return (pts_l, resp_l, empty, np.zeros(0, np.float32), None, geometry, timings,
                None)
    to_aligned = aligned_frame(geometry, size, right_gray.shape[::-1])
    left_gray = fill_padding(left_gray)
    margin = detector.getDescriptorSize() // 2 + detector.getWindowSize() // 2 + 2
    warped, valid = warp_right(right_gray, m_r, to_aligned, size, margin)
    left_img, warped, sharpness = equalise_sharpness(left_gray, warped,
                                                     config.sharpness_ratio, valid)
    t2 = time.perf_counter()
    pts_l, resp_l, desc_l, g_l, gray_l = detector.detect_and_describe(
        left_img, m_l, name="left", keep_gray=True)
    t3 = time.perf_counter()
    pts_a, resp_r, desc_r, g_r, gray_r = detector.detect_and_describe(
        warped, valid, name="right", keep_gray=True)
    t4 = time.perf_counter()
    pts_r = transform_points(pts_a, np.linalg.inv(to_aligned))
    bootstrap = geometry
    for round_ in range(PASSES):
        pending = None if few_matches_later is None else []  # the last network's only
        net, mode, shift, maps = search(geometry, to_aligned, pts_l, pts_a, desc_l, desc_r,
                                        size, config, record_energy,
                                        few_matches_later=pending)
        if fundamental is None and (round_ + 1 < PASSES or REFITS):
            refit = refit_fundamental(geometry, pts_l[net.query_idx], pts_r[net.train_idx])
            if refit is geometry:
                break
            geometry = refit

    def rematch(gray_right):  # the aligned right view mapped through the pair's tone map,
        # detected and searched again along the same geometry (docs/method.md 4.7)
        found = detector.detect_and_describe(gray_right, valid, name="right", keep_gray=True)
        again = None if few_matches_later is None else []
        searched = search(geometry, to_aligned, pts_l, found[0], desc_l, found[2], size,
                          config, record_energy, few_matches_later=again)
        return (pts_l[searched[0].query_idx], found[0][searched[0].train_idx],
                (found, again, searched))

    tone, second = rematch_through_map(gray_l, gray_r, pts_l[net.query_idx],
                                       pts_a[net.train_idx], config.tone_tolerance,
                                       config.gain_field_tolerance, rematch)
    if second is not None:
        (pts_a, resp_r, desc_r, g_r, gray_r), pending, (net, mode, shift, maps) = second
        pts_r = transform_points(pts_a, np.linalg.inv(to_aligned))
    if pending:
        few_matches_later.extend(pending)
    timings.update(align=t2 - t1, detect_left=t3 - t2, detect_right=t4 - t3,
                   match=time.perf_counter() - t4)
    geometry = dataclasses.replace(geometry, search=mode)
    frame = SearchFrame(mode=mode, to_aligned=to_aligned, shift=shift, right_points=pts_a,
                        grays=(gray_l, gray_r), gradients=(g_l, g_r),
                        descriptors=(desc_l, desc_r), maps=maps,
                        right_shape=tuple(right_gray.shape[:2]), sharpness=sharpness,
                        tone_map=tone, bootstrap=bootstrap)
    return pts_l, resp_l, pts_r, resp_r, net, geometry, timings, frame


def search(geometry, to_aligned, pts_l, pts_a, desc_l, desc_r, size, config, record_energy,
           few_matches_later: list | None = None):
    """``(network result, mode, shift, maps)``: the network on the left points and the
    aligned right points ``pts_a``, in the frame of :func:`search_frame`, over the range of
    :func:`network_range` (or of the inliers). In ``'aligned'`` mode the right points are
    moved by a whole number of pixels, ``shift`` (the range is moved by what rounding
    left), so that the images can be moved with them (:class:`SearchFrame`); ``shift``
    is None in the other modes. ``maps``: in ``'rectified'`` mode, ``(H1, H2)``, the maps
    of the left and the aligned right points into the network's frame; None in the
    others. ``few_matches_later``: passed to
    :func:`~hopmatch.matching.network.match_pair`, and the warnings it gives itself (the
    range's) are appended to it too."""
    H1, H2, (lo, hi), mode = search_frame(geometry, to_aligned, size)
    if H1 is None:  # the epipolar band of F, in the aligned frame shifted by H2
        F = np.linalg.inv(H2).T @ np.linalg.inv(to_aligned).T @ geometry.fundamental
        fundamental = np.ascontiguousarray(F / np.linalg.norm(F))
        q_l, q_r = pts_l, transform_points(pts_a, H2)
    else:
        fundamental = None
        q_l, q_r = transform_points(pts_l, H1), transform_points(pts_a, H2)
    check_coordinate_range(q_l, "left")
    check_coordinate_range(q_r, "right")
    found, shift = network_range(config, q_l, q_r, desc_l, desc_r, size[0], fundamental, hi)
    whole, maps = None, None
    if mode == "aligned":  # H1 = I, H2 = a shift in x
        total = float(H2[0, 2]) + shift
        whole = int(np.floor(total + 0.5))
        found = moved_range(found, total - whole)  # d = xl - xa - whole
        q_r = transform_points(pts_a, shift_x(whole))
    else:
        q_r = transform_points(q_r, shift_x(shift))
        if fundamental is not None:
            fundamental = shift_x(-shift).T @ fundamental
        else:
            maps = (H1, shift_x(shift) @ H2)
    cfg, derived = config, None
    if config.max_disparity is None:  # the range found, narrowed if beyond a budget
        cfg = dataclasses.replace(config, min_disparity=found.min_disparity,
                                  max_disparity=found.max_disparity)
        derived = found
    with deferring(few_matches_later):  # the range's warnings too
        net = match_pair(PairInfo(q_l, q_r, size, size), desc_l, desc_r, cfg,
                         fundamental=fundamental, record_energy=record_energy,
                         descriptors_checked=True, few_matches_later=few_matches_later,
                         fundamental_given=geometry.source == "given", range_found=derived)
    return net, mode, whole, maps


def pad_columns(image: np.ndarray, before: int, after: int) -> np.ndarray:
    """``image`` with ``before`` columns of zeros added on the left and ``after`` on the
    right (float32, C-contiguous)."""
    return np.ascontiguousarray(cv2.copyMakeBorder(
        np.asarray(image, np.float32), 0, 0, int(before), int(after), cv2.BORDER_CONSTANT,
        value=0.0))


def shared_frame(frame: SearchFrame, pts_l, pts_a):
    """``(left points, right points, grays, gradients, (a, b))`` of an ``'aligned'`` frame
    in one canvas where the network's disparities are ``x_l' - x_r'``: left points moved
    by ``a`` and aligned right points by ``b`` pixels in x (``b - a`` is the frame's
    ``shift``; one of them is 0), the images padded to match (both ``|shift|`` columns
    wider), so that the steps that read images at the points (the guided pass, the
    refinement) see the pair as a rectified one of one size."""
    s = int(frame.shift)
    a, b = max(0, -s), max(0, s)
    grays = (pad_columns(frame.grays[0], a, b), pad_columns(frame.grays[1], b, a))
    grads = (pad_columns(frame.gradients[0], a, b), pad_columns(frame.gradients[1], b, a))
    left = (np.asarray(pts_l, np.float32) + np.float32([a, 0])).astype(np.float32)
    right = (np.asarray(pts_a, np.float32) + np.float32([b, 0])).astype(np.float32)
    return left, right, grays, grads, (a, b)


def canvas(maps, size):
    """``(T, (W, H))``: the whole-pixel translation ``T`` that brings to (0, 0) the corner
    of the box holding a ``size`` (``(w, h)``) frame mapped by each 3 x 3 map of ``maps``,
    and that box's size (the canvas of :func:`rectified_canvas`)."""
    w, h = size
    corners = np.array([[0, 0], [w - 1, 0], [0, h - 1], [w - 1, h - 1]], np.float64)
    both = np.concatenate([transform_points(corners, H) for H in maps])
    x0, y0 = np.floor(both.min(axis=0))
    x1, y1 = np.ceil(both.max(axis=0))
    T = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]])
    return T, (int(x1 - x0) + 1, int(y1 - y0) + 1)


def rectified_canvas(frame: SearchFrame, pts_l, pts_a):
    """``(left points, right points, grays, gradients, descriptors, to_right)`` of a
    ``'rectified'`` frame: the left image warped by ``T H1`` and the aligned right image by
    ``T H2`` (``frame.maps``, bilinear; beyond them the grey images hold their median and
    the feature images 0) onto one canvas that holds both,
    ``T`` the whole-pixel translation that brings the canvas's corner to (0, 0) (the same
    for both: disparities ``x_l' - x_r'`` are the network's); the points mapped alike,
    their windows cut again from the warped feature images (the steps after the network
    compare windows of one frame); ``to_right`` the 3 x 3 map from the canvas back to the
    right image (through the alignment). The steps that read images at the points (the
    guided pass, the refinement) then see a rectified pair."""
    H1, H2 = frame.maps
    h, w = np.shape(frame.grays[0])[:2]
    T, size = canvas((H1, H2), (w, h))

    def warp(image, H, fill):
        return np.ascontiguousarray(cv2.warpPerspective(
            np.asarray(image, np.float32), T @ H, size, flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT, borderValue=float(fill)))

    # beyond the images: their median grey level (flat, as :func:`warp_right` fills), no
    # gradient
    grays = tuple(warp(g, H, np.median(np.asarray(g)[::4, ::4]))
                  for g, H in zip(frame.grays, (H1, H2)))
    grads = (warp(frame.gradients[0], H1, 0.0), warp(frame.gradients[1], H2, 0.0))
    left = transform_points(pts_l, T @ H1).astype(np.float32)
    right = transform_points(pts_a, T @ H2).astype(np.float32)
    side = int(round(np.sqrt(np.shape(frame.descriptors[0])[1])))
    descriptors = (cut_windows(grads[0], left, side), cut_windows(grads[1], right, side))
    to_right = np.linalg.inv(frame.to_aligned) @ np.linalg.inv(T @ H2)
    return left, right, grays, grads, descriptors, to_right


def empty_network_result(config) -> NetworkResult:
    """A :class:`~hopmatch.matching.network.NetworkResult` with no neuron (and ``config``)."""
    i32, f64 = np.zeros(0, np.int32), np.zeros(0, np.float64)
    return NetworkResult(query_idx=i32, train_idx=i32, distances=np.zeros(0, np.float32),
                         neuron_left=i32, neuron_right=i32, state=np.zeros(0, bool),
                         fields=f64, similarity=f64, n_interactions=0, iterations=0,
                         sweeps=0, converged=True, energy=0.0, config=config)
