"""What the matcher tells the user about the pair: the geometry warnings, the
rectification check and the stereo-pair check (docs/robustness.md, "Warnings")."""

from __future__ import annotations

import numpy as np

from .._warnings import warn
from ..errors import (
    BudgetExceededError,
    DisparityRangeWarning,
    FewMatchesWarning,
    ImageSizeWarning,
    NotStereoPairWarning,
    UnrectifiedPairWarning,
)
from ..feature.padding import black_padding
from .candidates import best_two_look_alikes, candidate_pairs, clear_best_look_alikes
from .neighbourhood import median_neighbours
from .similarity import similarity_distance, window_contrasts

# Rectification check (docs/robustness.md): how many left points are sampled, the band
# searched around them, and when the pair is called unrectified.
RECTIFICATION_SAMPLE = 300
RECTIFICATION_MIN_EVIDENCE = 20
RECTIFICATION_RATIO = 0.6
RECTIFICATION_MAX_PAIRS = 300_000
#: ... and only if fewer than this fraction of the clear look-alikes lie in the band: on
#: rectified low-texture pairs (the chessboards) half of the look-alikes are wrong, which
#: can push the median offset past 2 px, but 19-65 % still sit in the band; on pairs shifted
#: by 3 px at most 15 % do (benchmarks/rectification_check.py).
RECTIFICATION_MAX_IN_BAND = 0.15
#: The check runs only when the matches are fewer than this fraction of the keypoints (on
#: the 13 shared scenes with ground truth the defaults keep 4.5 % (KITTI) to 48 %).
RECTIFICATION_SUSPICIOUS = 0.03

#: ``match_stereo(..., rectified=None)`` matches a pair that kept few matches as
#: unrectified when fewer than this share of its clear look-alikes within STEREO_WINDOW rows
#: lie in the band (rectified shared scenes: 86-100 %, rotated 5 degrees and shifted 30 px:
#: 0-6 %; benchmarks/rectification_check.py --wide).
UNRECTIFIED_MAX_IN_BAND = 0.5
#: ... checked (in a band of STEREO_WINDOW rows) when the network kept fewer matches than
#: this share of the keypoints (the rectified shared scenes keep 5.0 % (KITTI) to 48.5 %).
UNRECTIFIED_SUSPICIOUS = 0.10
#: ... when fewer than this share of the row-offset prior's clear look-alikes (within 4 rows)
#: lie within max(1, max_vertical) px of their row (rectified shared scenes: 0.70 (KITTI) to
#: 0.98; rotated 5 degrees and shifted 30 px: at most 0.38; rectification_check.py --wide).
UNRECTIFIED_ROWS_SHARE = 0.5

# Stereo-pair check: left points sampled, the 2-D window searched around each (rows and
# disparities beyond the range), the distance a look-alike must be within (the default
# similarity gate), and the fractions below which the pair is not called a stereo pair.
# On the 13 shared scenes with ground truth at least 11 % of the sampled points have a clear
# look-alike and 26 % one within the gate; rotated and shifted versions of them, swapped
# pairs and the raw chessboard photos at least 2 % and 34 %; two unrelated scenes, or an
# object beside a scene holding it rotated and scaled (find_obj.py's box pair), at most
# 1 % and 14 %.
STEREO_SAMPLE = 100
STEREO_WINDOW = 64.0
STEREO_LOOK_ALIKE = 0.45
STEREO_MIN_CLEAR = 0.05
STEREO_MIN_CLOSE = 0.2


# Few matches (docs/robustness.md): a pair with at least FEW_MATCHES_MIN_POINTS keypoints a
# side that keeps fewer than max(FEW_MATCHES_FLOOR, FEW_MATCHES_FRACTION of them) matches
# is warned about (the 13 shared scenes keep 4.5 % to 48 %), with its likely cause;
# windows whose median contrasts differ by more than FEW_MATCHES_CONTRAST are one.
FEW_MATCHES_MIN_POINTS = 50
FEW_MATCHES_FLOOR = 5
FEW_MATCHES_FRACTION = 0.01
FEW_MATCHES_CONTRAST = 1.5
#: Rows (at least) of the band in which the few-matches gain test looks for look-alikes.
FEW_MATCHES_BAND = 4.0
#: A network that kept nothing is said to lack neighbours when the median left keypoint
#: has fewer than this many others (or than ``min_neighbours``, when larger) in the
#: neighbour window it ran with (grown or not).
FEW_NEIGHBOURS = 4
#: :func:`exposure_note`: a view is called clipped when at least this share of its pixels
#: sit at its brightest (or darkest) level and that share exceeds the other view's by
#: at least :data:`CLIPPED_LEAD`; the views are sampled every :data:`CLIPPED_STRIDE` px.
CLIPPED_SHARE = 0.10
CLIPPED_LEAD = 0.08
CLIPPED_STRIDE = 4


def clear_look_alikes(q_pts, t_pts, qd, td, min_disparity, max_disparity, band,
                      sample_size):
    """``(sample, best)``: the left points (indices into ``q_pts``) whose best look-alike
    among the right points within the disparity range and ``band`` rows is clearly better
    than their second (distance ratio below :data:`RECTIFICATION_RATIO`), and that
    look-alike; up to ``sample_size`` left points, evenly spaced in the keypoint order, are
    compared by the network's similarity distance (eq. 7). None when there is too little
    to judge (fewer than 2 x RECTIFICATION_MIN_EVIDENCE points on a side, fewer than
    RECTIFICATION_MIN_EVIDENCE clear ones, or more than RECTIFICATION_MAX_PAIRS pairs to
    compare)."""
    if min(len(q_pts), len(t_pts)) < 2 * RECTIFICATION_MIN_EVIDENCE:
        return None
    n = min(len(q_pts), sample_size)
    sample = np.unique(np.linspace(0, len(q_pts) - 1, n).astype(np.int64))
    left = np.ascontiguousarray(q_pts[sample])
    try:
        ni, nk = candidate_pairs(left, t_pts, min_disparity, max_disparity, band,
                                 RECTIFICATION_MAX_PAIRS, sort=False)
    except BudgetExceededError:
        return None
    if len(ni) == 0:
        return None
    sim = similarity_distance(np.ascontiguousarray(qd[sample]), td, ni, nk)
    lefts, best = clear_best_look_alikes(ni, nk, sim, RECTIFICATION_RATIO)
    if len(best) < RECTIFICATION_MIN_EVIDENCE:
        return None
    return sample[lefts], nk[best]


def rectification_evidence(q_pts, t_pts, qd, td, min_disparity, max_disparity, max_vertical):
    """Median ``|y_left - y_right|`` of unambiguous best look-alikes in a generous band.

    Up to :data:`RECTIFICATION_SAMPLE` left points are compared with every right point
    within the disparity range and ``band = max(16, 4 * max_vertical)`` rows
    (:func:`clear_look_alikes`). Returns ``(median |dy|, number of points counted,
    fraction of them with |dy| <= max(1, max_vertical))``, or None when there is too little
    to judge.
    """
    found = clear_look_alikes(q_pts, t_pts, qd, td, min_disparity, max_disparity,
                              max(16.0, 4.0 * max_vertical), RECTIFICATION_SAMPLE)
    if found is None:
        return None
    qi, ti = found
    dy = np.abs(q_pts[qi, 1].astype(np.float64) - t_pts[ti, 1])
    return (float(np.median(dy)), int(len(qi)),
            float(np.mean(dy <= max(1.0, max_vertical))))


def wide_rectification_evidence(q_pts, t_pts, qd, td, min_disparity, max_disparity,
                                max_vertical, sample_sizes=(STEREO_SAMPLE,)):
    """:func:`rectification_evidence` in a band of :data:`STEREO_WINDOW` rows: wide enough
    for the shifts (tens of px) and rotations (a few degrees) of a pair that was never
    rectified, which the narrower band misses or sees only where the rotation brings the
    rows together. Up to ``sample_sizes[0]`` left points, then (too few clear look-alikes
    among them) the next size."""
    for sample_size in sample_sizes:
        found = clear_look_alikes(q_pts, t_pts, qd, td, min_disparity, max_disparity,
                                  max(STEREO_WINDOW, 4.0 * max_vertical), sample_size)
        if found is not None:
            qi, ti = found
            dy = np.abs(q_pts[qi, 1].astype(np.float64) - t_pts[ti, 1])
            return (float(np.median(dy)), int(len(qi)),
                    float(np.mean(dy <= max(1.0, max_vertical))))
    return None


def stereo_pair_evidence(q_pts, t_pts, qd, td, min_disparity, max_disparity):
    """How much of the left image has a look-alike in the right one, searched in 2-D.

    Up to :data:`STEREO_SAMPLE` left points (evenly spaced in the keypoint order) are
    compared by the network's similarity distance with every right point within
    :data:`STEREO_WINDOW` px of their row and of the disparity range (a window wide enough
    for a pair that is not rectified). Returns ``(fraction with a clear best look-alike,
    distance ratio to the second below RECTIFICATION_RATIO; fraction whose best look-alike
    is within STEREO_LOOK_ALIKE; points sampled)``, or None when there is too little to
    judge (fewer than 2 x RECTIFICATION_MIN_EVIDENCE points on a side, or more than
    RECTIFICATION_MAX_PAIRS pairs to compare).
    """
    if min(len(q_pts), len(t_pts)) < 2 * RECTIFICATION_MIN_EVIDENCE:
        return None
    sample = np.unique(np.linspace(0, len(q_pts) - 1, min(len(q_pts), STEREO_SAMPLE))
                       .astype(np.int64))
    try:
        ni, nk = candidate_pairs(np.ascontiguousarray(q_pts[sample]), t_pts,
                                 min_disparity - STEREO_WINDOW, max_disparity + STEREO_WINDOW,
                                 STEREO_WINDOW, RECTIFICATION_MAX_PAIRS, sort=False)
    except BudgetExceededError:
        return None
    if len(ni) == 0:
        return 0.0, 0.0, len(sample)
    sim = similarity_distance(np.ascontiguousarray(qd[sample]), td, ni, nk)
    _, best, second = best_two_look_alikes(ni, nk, sim)
    two = second >= 0
    clear = sim[best[two]] < RECTIFICATION_RATIO * sim[second[two]]
    close = sim[best] <= STEREO_LOOK_ALIKE
    return float(clear.sum()) / len(sample), float(close.sum()) / len(sample), len(sample)


def warn_geometry(query_size, train_size, fundamental, config) -> None:
    """Warn (:class:`~hopmatch.errors.ImageSizeWarning`) when a rectified pair's images
    differ in size, and (:class:`~hopmatch.errors.DisparityRangeWarning`) when the
    disparity range of ``config`` (resolved) does not fit the left image's width."""
    if fundamental is None and query_size is not None and train_size is not None \
            and query_size != train_size:
        warn(f"the query image is {query_size[0]} x {query_size[1]} and the train image "
             f"{train_size[0]} x {train_size[1]} (width x height): a rectified pair has images "
             "of one size; rectify the pair first or call setFundamentalMatrix(F)",
             ImageSizeWarning)
    if query_size is not None and (config.max_disparity >= query_size[0]
                                   or -config.min_disparity >= query_size[0]):
        warn(f"the disparity range [{config.min_disparity:g}, {config.max_disparity:g}] does "
             f"not fit the left image's width ({query_size[0]} px): disparities beyond it can "
             "never occur and only add candidates; narrow the range (max_disparity)",
             DisparityRangeWarning)


class LooksUnrectifiedError(Exception):
    """Raised by :func:`warn_if_unrectified` (``raise_unrectified=True``) instead of its
    :class:`~hopmatch.errors.UnrectifiedPairWarning`, for a caller that matches such a pair
    another way (``match_stereo`` with ``rectified=None``). ``evidence``: what the check
    found, as a phrase ("the clearest look-alikes of ... lie a median ... px above or
    below them (max_vertical=...)")."""

    def __init__(self, evidence: str):
        super().__init__(evidence)
        self.evidence = evidence


def warn_about_pair(diagnosis, few_matches_check, q_pts, t_pts, *,
                    kept: int | None = None, exposure: str = "") -> bool:
    """The one warning about a matched pair: :func:`pair_diagnosis`'s ``diagnosis``
    (``(message, category)`` or None), or else ``few_matches_check``
    (:func:`warn_if_few_matches` with its pair bound, called with ``kept`` and
    ``exposure``). ``kept``: the matches kept in the end when passes after the network
    added some (None: the network's); the diagnosis then stands only while they are still
    few (:func:`still_few`). ``exposure``: :func:`exposure_note` of the pair's images, for
    a caller that has them; when it says a view clips, a diagnosis that the images are no
    stereo pair gives way to the few-matches check, which names the clipping as the cause
    (an overexposed view has few look-alikes near its rows either). Returns whether it
    warned."""
    if (diagnosis is not None and (kept is None or still_few(kept, q_pts, t_pts))
            and not (exposure and issubclass(diagnosis[1], NotStereoPairWarning))):
        warn(*diagnosis)
        return True
    return few_matches_check(kept=kept, exposure=exposure)


def exposure_note(gray_left: np.ndarray, gray_right: np.ndarray) -> str:
    """Words on a view that clips: at least :data:`CLIPPED_SHARE` of its pixels at its
    brightest level (or its darkest), :data:`CLIPPED_LEAD` more than the other view's
    share at that view's own extreme (both views of a white sky clip alike), or "" (also
    for a view of one level: no keypoint, which :func:`no_keypoints_cause` explains).
    Shares are read every :data:`CLIPPED_STRIDE` pixels of each axis, outside the view's
    :func:`~hopmatch.feature.padding.black_padding` (a warped view's black corners are no
    exposure)."""
    shares = []
    for gray in (gray_left, gray_right):
        gray = np.asarray(gray)
        if gray.ndim != 2 or gray.size == 0:
            return ""
        s = np.s_[::CLIPPED_STRIDE, ::CLIPPED_STRIDE]
        pad = black_padding(gray)[s]
        g = gray[s][~pad] if pad.any() else gray[s]
        if g.size == 0 or not np.isfinite(g).all():
            return ""
        lo, hi = g.min(), g.max()
        if lo == hi:
            return ""
        shares.append((float(np.mean(g == hi)), float(np.mean(g == lo))))
    for k, (name, other) in enumerate((("left", "right"), ("right", "left"))):
        for end, word, fix in ((0, "brightest", "overexposed"), (1, "darkest",
                                                                 "underexposed")):
            mine, theirs = shares[k][end], shares[1 - k][end]
            if mine >= CLIPPED_SHARE and mine - theirs >= CLIPPED_LEAD:
                return (f"the {name} image has {mine:.0%} of its pixels at its {word} level "
                        f"(the {other} image {theirs:.0%}): it looks {fix}, and where it "
                        "clips no texture is left to match; give both views one exposure "
                        "(or a lower gain) if you can")
    return ""


def still_few(kept: int, q_pts, t_pts) -> bool:
    """Whether ``kept`` matches are few enough for :func:`pair_diagnosis`'s warning to
    stand: below :data:`RECTIFICATION_SUSPICIOUS` of the smaller keypoint set. For a caller
    whose later passes add matches (``match_stereo``'s guided pass): a pair whose network
    kept few matches but whose final matches are many is two views of one scene on their
    rows after all (an overexposed right view, say), and is not told otherwise."""
    return kept < RECTIFICATION_SUSPICIOUS * min(len(q_pts), len(t_pts))


def pair_diagnosis(n_matches, q_pts, t_pts, qd, td, fundamental, config,
                   raise_unrectified: bool = False,
                   rows_share: float | None = None) -> tuple[str, type] | None:
    """``(message, category)`` of the warning about the pair, or None:
    :class:`~hopmatch.errors.UnrectifiedPairWarning` when the network kept few
    matches (below :data:`RECTIFICATION_SUSPICIOUS` of the keypoints) and the clearest
    look-alikes of the left points lie off their rows (:func:`rectification_evidence`), or
    (:class:`NotStereoPairWarning`) when almost no left point has a look-alike anywhere
    near its row (:func:`stereo_pair_evidence`): the images are not two views of one
    scene. One warning at most; rectified pairs with many matches do not pay for either
    check.

    With ``raise_unrectified`` (``match_stereo(..., rectified=None)``) a pair without
    ``fundamental`` that kept fewer matches than :data:`RECTIFICATION_SUSPICIOUS` of the
    keypoints, or fewer than :data:`UNRECTIFIED_SUSPICIOUS` when fewer than
    :data:`UNRECTIFIED_ROWS_SHARE` of the row-offset prior's look-alikes lie on their rows
    (``rows_share``, :func:`~hopmatch.matching.vertical.rows_share_of`), is also checked
    in a band of :data:`STEREO_WINDOW` rows
    (:func:`wide_rectification_evidence`: fewer than :data:`UNRECTIFIED_MAX_IN_BAND` of
    its look-alikes in the band, and their median offset above ``max(2, 2 max_vertical)``
    px, as for the warning; up to :data:`STEREO_SAMPLE` points, and
    :data:`RECTIFICATION_SAMPLE` below :data:`RECTIFICATION_SUSPICIOUS`), and a pair
    found off its rows that passes the stereo-pair check raises
    :class:`LooksUnrectifiedError` instead of the warning."""
    n_points = min(len(q_pts), len(t_pts))
    few = n_matches < RECTIFICATION_SUSPICIOUS * n_points
    may_raise = (raise_unrectified and fundamental is None
                 and (few or (n_matches < UNRECTIFIED_SUSPICIOUS * n_points
                              and rows_share is not None
                              and rows_share < UNRECTIFIED_ROWS_SHARE)))
    if not (few or may_raise) or not len(qd) or not len(td):
        return None
    off_rows = None
    if fundamental is None and few:
        ev = rectification_evidence(q_pts, t_pts, qd, td, config.min_disparity,
                                    config.max_disparity, config.max_vertical)
        if (ev is not None and ev[0] > max(2.0, 2.0 * config.max_vertical)
                and ev[2] < RECTIFICATION_MAX_IN_BAND):
            off_rows = (f"the clearest look-alikes of {ev[1]} sampled left points lie a "
                        f"median {ev[0]:.1f} px above or below them "
                        f"(max_vertical={config.max_vertical:g})")
    if may_raise and off_rows is None:
        # a pair that kept very few matches may look further (the rectified shared scenes
        # keep 5 % or more, and pay for the first 100 points only)
        sizes = (STEREO_SAMPLE, RECTIFICATION_SAMPLE) if few else (STEREO_SAMPLE,)
        wide = wide_rectification_evidence(q_pts, t_pts, qd, td, config.min_disparity,
                                           config.max_disparity, config.max_vertical, sizes)
        if (wide is not None and wide[2] < UNRECTIFIED_MAX_IN_BAND
                and wide[0] > max(2.0, 2.0 * config.max_vertical)):
            off_rows = (f"of the clearest look-alikes of {wide[1]} sampled left points within "
                        f"{STEREO_WINDOW:g} rows, {wide[2]:.0%} lie within "
                        f"max(1, max_vertical={config.max_vertical:g}) px of their row (a "
                        f"median {wide[0]:.1f} px off it)")
    if off_rows is not None and not raise_unrectified:
        return (f"the pair does not look rectified: {off_rows}, so few true matches can be "
                "found; rectify the pair (hopmatch.stereo.rectify), call "
                "setFundamentalMatrix(F), or let match_stereo estimate its geometry "
                "(rectified=False)", UnrectifiedPairWarning)
    if off_rows is None and not few:
        return None
    ratio = contrast_ratio(qd, td)
    gain = "" if ratio is None or 1 / FEW_MATCHES_CONTRAST <= ratio <= FEW_MATCHES_CONTRAST \
        else (f" (the right image's windows have {ratio:.3g} times the contrast of the left "
              "image's: if both show one scene, they differ in gain or exposure, or in "
              "dtype; give both images the same scale first)")
    st = stereo_pair_evidence(q_pts, t_pts, qd, td, config.min_disparity,
                              config.max_disparity)
    if st is not None and st[0] < STEREO_MIN_CLEAR and st[1] < STEREO_MIN_CLOSE:
        return (f"the pair does not look like a stereo pair: of {st[2]} sampled left points "
                f"{st[1]:.0%} have a look-alike within {STEREO_WINDOW:g} px of their row in "
                f"the right image ({st[0]:.0%} a clear one; two views of one scene give 25 % "
                f"or more), and {n_matches} matches were found; check that the two images "
                "show the same scene from side by side, left image first. For two such views "
                "that are not rectified, rectify them (hopmatch.stereo.rectify or "
                "rectify_uncalibrated) or give their fundamental matrix "
                "(setFundamentalMatrix(F)); to find an object in a scene (find_obj.py), use "
                f"SIFT or ORB with cv2.findHomography instead{gain}", NotStereoPairWarning)
    if off_rows is not None:  # raise_unrectified: two views of one scene, off their rows
        raise LooksUnrectifiedError(off_rows)
    return None


def contrast_ratio(qd, td, look_alikes=None) -> float | None:
    """Window contrast (``mean |row|``, eq. 7's normaliser) of the right descriptors over
    that of the left ones: with ``look_alikes`` (``(left indices, right indices)`` of pairs
    that show the same point, :func:`clear_look_alikes`), the median of the pairs' own
    ratios when there are at least :data:`RECTIFICATION_MIN_EVIDENCE` of them; else the
    median right contrast over the median left one. The latter also measures what each
    image shows (two views that see different amounts of a flat wall differ there in any
    gain), the former only the gain. None for binary descriptors or empty sides."""
    if not len(qd) or not len(td):
        return None
    contrasts = window_contrasts(qd, td)
    if contrasts is None:
        return None
    if look_alikes is not None and len(look_alikes[0]) >= RECTIFICATION_MIN_EVIDENCE:
        s_l, s_r = contrasts[0][look_alikes[0]], contrasts[1][look_alikes[1]]
        both = (s_l > 0) & (s_r > 0)
        if both.sum() >= RECTIFICATION_MIN_EVIDENCE:
            return float(np.median(s_r[both] / s_l[both]))
    left, right = (float(np.median(c)) for c in contrasts)
    if not left > 0 or not right > 0:
        return None
    return right / left


def lines_missing_image(fundamental, q_pts, train_size) -> int:
    """How many of the left points ``q_pts`` have an epipolar line ``F x_l`` that misses
    the right image (``train_size`` = (width, height)): the line ``a x + b y + c = 0`` is on
    one side of all four corners of ``[0, width - 1] x [0, height - 1]``, or ``a = b = 0``
    (a matrix that is not this pair's fundamental matrix: a homography, the identity...)."""
    p = np.asarray(q_pts, dtype=np.float64).reshape(-1, 2)
    if not len(p):
        return 0
    lines = np.c_[p, np.ones(len(p))] @ np.asarray(fundamental, dtype=np.float64).T
    w, h = (float(v) - 1.0 for v in train_size)
    corners = np.array([[0.0, 0.0, 1.0], [w, 0.0, 1.0], [0.0, h, 1.0], [w, h, 1.0]])
    side = lines @ corners.T
    degenerate = (lines[:, 0] == 0) & (lines[:, 1] == 0)
    return int(np.sum(degenerate | (side > 0).all(axis=1) | (side < 0).all(axis=1)))


def few_matches_cause(result, qd, td, config, q_pts=None, t_pts=None, *, fundamental=None,
                      train_size=None, fundamental_given: bool = True) -> str:
    """The likely reason why the network ``result`` kept almost no match, in words. With
    the keypoints ``q_pts``, ``t_pts`` the gain is measured on clear look-alikes within
    the disparity range and ``max(FEW_MATCHES_BAND, 4 max_vertical)`` rows
    (:func:`contrast_ratio`). With ``fundamental`` (the matrix searched along) and
    ``train_size`` (the right image's (width, height)), a search that found no candidate
    says how many left keypoints' epipolar lines miss the right image when half of them or
    more do (:func:`lines_missing_image`), and the words name the caller's
    ``fundamental_matrix``, or with ``fundamental_given=False`` the matrix estimated from
    the pair (``match_stereo(rectified=False)``)."""
    look = None
    if q_pts is not None and t_pts is not None and config.max_disparity is not None:
        look = clear_look_alikes(q_pts, t_pts, qd, td, config.min_disparity or 0.0,
                                 config.max_disparity,
                                 max(FEW_MATCHES_BAND, 4.0 * config.max_vertical),
                                 RECTIFICATION_SAMPLE)
    ratio = contrast_ratio(qd, td, look)
    if ratio is not None and not 1 / FEW_MATCHES_CONTRAST <= ratio <= FEW_MATCHES_CONTRAST:
        return (f"the right image's windows have {ratio:.3g} times the contrast of the left "
                "image's (median): the two images differ in gain or exposure, or in dtype "
                "(uint8 against uint16, or floats in [0, 1]), and the similarity gate "
                "(similarity_gate) rejects their true matches; give both images the same "
                "scale first (e.g. convert both to uint8 with cv2.normalize)")
    matrix = ("`fundamental_matrix`" if fundamental_given
              else "the fundamental matrix estimated from the pair")
    if not len(result.neuron_left) and fundamental is not None:
        band = (f"no candidate pair lies in the epipolar band (within {config.max_vertical:g} "
                f"px of the lines of {matrix}, disparity in "
                f"[{config.min_disparity:g}, {config.max_disparity:g}]) with similar enough "
                "windows")
        if not fundamental_given:
            return (f"{band}: the geometry estimated from the pair (result.geometry) does not "
                    "fit it")
        missing = (lines_missing_image(fundamental, q_pts, train_size)
                   if q_pts is not None and train_size is not None else 0)
        if missing >= 0.5 * len(q_pts):
            return (f"{band}, and the epipolar lines of {missing} of the {len(q_pts)} left "
                    "keypoints miss the right image: check that `fundamental_matrix` is this "
                    "pair's, in pixels, with x_right^T F x_left = 0 (as "
                    "cv2.findFundamentalMat(points_left, points_right) returns it; its "
                    "transpose maps the other way), not a homography or a camera matrix")
        return (f"{band}: check the disparity range (min_disparity/max_disparity) and that "
                "`fundamental_matrix` is this pair's")
    if not len(result.neuron_left):
        return (f"no candidate pair lies in the search window (disparity in "
                f"[{config.min_disparity:g}, {config.max_disparity:g}], |dy| <= "
                f"{config.max_vertical:g}) with similar enough windows: check the disparity "
                "range (min_disparity/max_disparity), that the left image comes first, and "
                "that the pair is rectified")
    if result.n_interactions == 0:
        return (f"no candidate has a neighbour within neighbour_width x neighbour_height "
                f"({config.neighbour_width:g} x {config.neighbour_height:g} px), so nothing "
                "supports any match; widen the neighbourhood")
    given = ("" if fundamental is None or not fundamental_given else
             "; check that `fundamental_matrix` is this pair's: candidates along the lines of "
             "another matrix do not support each other")
    if not result.state.any():
        few = max(FEW_NEIGHBOURS, float(config.min_neighbours))
        sparse = (median_neighbours(q_pts, config.neighbour_width, config.neighbour_height,
                                    int(np.ceil(few))) if q_pts is not None and len(q_pts) > 1
                  else few)
        if sparse < few:
            return (f"the network kept no neuron active: the median left keypoint has "
                    f"{sparse:g} other left keypoints in the neighbour window "
                    f"({config.neighbour_width:g} x {config.neighbour_height:g} px), too few "
                    "to support one another; use denser keypoints (the detector's defaults, "
                    "a smaller nms_size) or a wider window (neighbour_width, "
                    "neighbour_height; min_neighbours grows it at most 4-fold)" + given)
        return ("the network kept no neuron active (input_bias, slope, theta or "
                "uniqueness_weight leave no match enough support); try the defaults" + given)
    return ("the candidates support each other too little: the images may not show the same "
            "scene, the disparity range may miss the true disparities "
            f"([{config.min_disparity:g}, {config.max_disparity:g}]), or the pair may be "
            "misaligned" + given)


def warn_if_few_matches(result, q_pts, t_pts, qd, td, config, *,
                        range_found: bool = True, kept: int | None = None,
                        exposure: str = "", fundamental=None, train_size=None,
                        fundamental_given: bool = True) -> bool:
    """Warn (:class:`~hopmatch.errors.FewMatchesWarning`) when a pair of at least
    :data:`FEW_MATCHES_MIN_POINTS` keypoints a side kept fewer than
    ``max(FEW_MATCHES_FLOOR, FEW_MATCHES_FRACTION * keypoints)`` matches, saying the
    likely cause (:func:`few_matches_cause`, from the network's ``result``), and, when
    ``range_found`` is False, that the disparity range could not be found and the whole
    fallback range was searched. ``kept``: the matches kept in the end, when passes after
    the network added some (None: the network's). ``exposure``: :func:`exposure_note`'s
    words, given as the cause when not empty. ``fundamental``, ``train_size``,
    ``fundamental_given``: as for :func:`few_matches_cause`. Returns whether it warned."""
    n = min(len(q_pts), len(t_pts))
    by_network = len(result.query_idx)
    kept = by_network if kept is None else kept
    if n < FEW_MATCHES_MIN_POINTS or kept >= max(FEW_MATCHES_FLOOR, FEW_MATCHES_FRACTION * n):
        return False
    searched = "" if range_found else (
        f" (max_disparity=None: the coarse pass found no range, so the whole range "
        f"[{config.min_disparity:g}, {config.max_disparity:g}] was searched)")
    network = "" if kept == by_network else f" ({by_network} from the network)"
    cause = exposure or few_matches_cause(result, qd, td, config, q_pts, t_pts,
                                          fundamental=fundamental, train_size=train_size,
                                          fundamental_given=fundamental_given)
    warn(f"only {kept} matches{network} for {len(q_pts)} left and {len(t_pts)} right "
         f"keypoints{searched}: {cause}", FewMatchesWarning)
    return True


def no_keypoints_cause(gray: np.ndarray, mask, window: int) -> str:
    """Why the detector found no point on the grey image ``gray`` (with ``mask``, None or
    the checked boolean mask, and descriptor windows of ``window`` a side): too small for
    the windows, masked out (or all but fewer pixels than a window holds), one grey level,
    or no texture the detector answers to."""
    h, w = gray.shape[:2]
    if min(h, w) < window + 2:
        return (f"it is {w} x {h} px, too small for the detector's {window} x {window} "
                "windows (and their margin)")
    if mask is not None and not np.any(mask):
        return "its mask excludes every pixel"
    if mask is not None and int(np.count_nonzero(mask)) < window * window:
        kept = int(np.count_nonzero(mask))
        return (f"its mask keeps only {kept} pixel{'s' if kept > 1 else ''}, fewer than one "
                f"of the detector's {window} x {window} windows")
    if float(np.min(gray)) == float(np.max(gray)):
        return f"it is flat (every pixel {float(np.min(gray)):g})"
    return ("its texture is too faint for the detector (lower its `threshold`, or check "
            "that the image is not blank or out of focus)")


def warn_if_no_keypoints(sides) -> bool:
    """Warn (:class:`~hopmatch.errors.FewMatchesWarning`) when an image of a pair has no
    keypoint, so no match can be found. ``sides``: ``(name, points, grey, mask,
    window)`` for each image (:func:`no_keypoints_cause`'s arguments). Returns whether it
    warned."""
    empty = [(name, no_keypoints_cause(gray, mask, window))
             for name, points, gray, mask, window in sides if len(points) == 0]
    if not empty:
        return False
    warn("no matches: " + "; ".join(f"the {name} image has no keypoint: {cause}"
                                     for name, cause in empty), FewMatchesWarning)
    return True
