"""``match_stereo``: detect on both images and match, in one call."""

from __future__ import annotations

import dataclasses
import functools
import time

import numpy as np

from .._interrupts import keeps_interrupts
from .._threads import resolve_threads, run_both, using_threads
from .._validate import as_fundamental_matrix, check_coordinate_range
from .._warnings import deferring, give_or_defer, warn
from ..errors import (
    ImageSizeWarning,
    InvalidArgumentError,
    InvalidTypeError,
    UnrectifiedPairWarning,
)
from ..feature.detector import DericheMoravecDetector
from ..feature.gradient import measurable_gray, normalised_intensity
from ..feature.sharpness import equalise_sharpness
from . import both_features, guided, halves
from .channels import channels_kept, match_both_greys
from .confidence import confidence_distances, fields_of_distances
from .diagnostics import LooksUnrectifiedError, exposure_note, still_few, warn_if_no_keypoints
from .epipolar_support import support_notes, unsupported
from .geometry import GeometryWarning, transform_points
from .guided import guided_pass, guided_rounds
from .guided_results import GreyFallback, GuidedMatches
from .matcher import HopfieldMatcher
from .network import PairInfo, match_pair
from .params import MatcherConfig, matcher_config
from .refine import REFINE_RADIUS, Refinement, refine_disparities
from .second_try import fallback_if_kept
from .stereo_result import PASS_GUIDED, PASS_NETWORK, StereoMatchResult
from .tone import rematch_through_map
from .unrectified import (
    UNRECTIFIED_VERTICAL,
    empty_network_result,
    match_unrectified,
    rectified_canvas,
    shared_frame,
    warpable,
)
from .vertical import fit_row_offset, median_offset

DETECTOR_NAMES = frozenset(p.name for p in DericheMoravecDetector.PARAMS)
MATCHER_NAMES = frozenset(p.name for p in HopfieldMatcher.PARAMS)

#: Image size (pixels) up to which the refinement keeps its ``REFINE_RADIUS`` window; the
#: window's half-side grows with the fourth root of the pixel count beyond it
#: (:func:`refine_radius`).
REFINE_REFERENCE_PIXELS = 400_000


def split_parameters(params: dict, caller: str = "match_stereo") -> tuple[dict, dict]:
    """``(detector parameters, matcher parameters)`` of ``params``: the one rule by which
    :func:`match_stereo`, the CLI and the plugins share one set of keyword arguments between
    :class:`DericheMoravecDetector` and :class:`HopfieldMatcher` (``preset`` goes to both).

    Unknown names raise :class:`~hopmatch.errors.InvalidArgumentError` naming ``caller`` and
    listing the valid ones; values are not checked here (see :func:`stereo_pipeline`).
    """
    unknown = sorted(set(params) - DETECTOR_NAMES - MATCHER_NAMES)
    if unknown:
        raise InvalidArgumentError(
            f"{caller} got unknown parameter(s) {unknown}; valid parameters are "
            f"{sorted(DETECTOR_NAMES | MATCHER_NAMES)}"
        )
    return ({k: v for k, v in params.items() if k in DETECTOR_NAMES},
            {k: v for k, v in params.items() if k in MATCHER_NAMES})


def stereo_pipeline(params: dict, caller: str = "match_stereo"):
    """``(DericheMoravecDetector, HopfieldMatcher)`` configured from one set of parameters
    (:func:`split_parameters`); invalid values raise the classes' own errors."""
    det_params, match_params = split_parameters(params, caller)
    return DericheMoravecDetector(**det_params), HopfieldMatcher(**match_params)


@keeps_interrupts
def match_stereo(left, right, *, mask_left=None, mask_right=None, fundamental_matrix=None,
                 rectified: bool | None = None, record_energy: bool = False,
                 detector: DericheMoravecDetector | None = None,
                 matcher: HopfieldMatcher | None = None, threads: int | None = None,
                 **params) -> StereoMatchResult:
    """Detect Moravec points on a stereo pair and match them with the Hopfield network.

    Parameters
    ----------
    left, right : (H, W) or (H, W, 3|4) ndarray
        The pair (grey, BGR or BGRA; 8-bit, 16-bit or float): rectified, of the same height,
        unless ``fundamental_matrix`` is given.
    mask_left, mask_right : (H, W) uint8 or bool ndarray, optional
        Where keypoints may be detected.
    fundamental_matrix : (3, 3) array-like, optional
        The known geometry of an unrectified pair (``x_r^T F x_l = 0``, as
        ``cv2.findFundamentalMat`` returns it). With no disparity range, the pair is matched
        as with ``rectified=False`` but along this F (its rows lined up by it, not by one
        estimated; ``result.geometry.source == "given"``), unless too few SIFT
        correspondences agree with it for that; then, and with a range,
        ``preset="paper"`` or ``rectified=True``, the network searches the epipolar band
        of F (its matches only: no guided pass or refinement).
    rectified : bool or None
        None (default): the pair's rows are searched, as for True, unless the rectification
        check (docs/robustness.md) finds the pair far from rectified, or the images differ
        in height; it is then matched as with False, and an
        :class:`~hopmatch.errors.UnrectifiedPairWarning` says so. A
        pair that keeps few matches on its rows without such a sign (too far off for the
        check to see, or of unlike exposure) is matched as with False too, and that match
        kept when it finds a geometry of two views side by side and more matches
        (:func:`~.second_try.fallback_kept`; the same warning). Only
        without ``fundamental_matrix``, a disparity range (``min_disparity`` or
        ``max_disparity``) and ``preset="paper"``: with any of them None is True.
        True: always the rows (the images must be rectified; a far-off pair gets the
        warning and few matches).
        False for a pair whose geometry is unknown (two photos): the epipolar geometry and
        the disparity range are estimated from the pair itself, the right image is
        aligned with the left one and the network searches the epipolar band
        (``hopmatch.matching.unrectified``; docs/pipelines.md); matches where the
        estimate is extrapolated are dropped (``hopmatch.matching.epipolar_support``).
        The result carries ``fundamental_matrix`` and ``geometry``; when the pair
        supports no geometry (no texture, unrelated images) it is empty and a
        :class:`~hopmatch.errors.GeometryWarning` says why. Cannot be combined with
        ``fundamental_matrix`` or a disparity range (it finds its own). Unless given (as
        a keyword), ``vertical_threshold`` is then
        :data:`~hopmatch.matching.unrectified.UNRECTIFIED_VERTICAL`.
    record_energy : bool
        Keep the network energy after every iteration (``result.network.energy_trace``).
    detector, matcher : DericheMoravecDetector, HopfieldMatcher, optional
        Ready instances to use (their parameters; the matcher's pair information is left
        untouched). Parameters of a part given as an instance cannot also be passed as
        keywords.
    threads : int, optional
        Threads to use: the left and right detection run concurrently, and the
        search of the candidate pairs along rows (the band search), their similarity, the
        guided pass and the refinement split their points between threads (rectified
        pairs; with ``rectified=False`` only the similarity does). None (default):
        :func:`hopmatch.getNumThreads` (every core unless :func:`hopmatch.setNumThreads`
        said otherwise, as OpenCV does). Results are bit-identical for any count; peak
        memory of the detection is that of both images at once with 2 or more.
    **params
        Any :class:`DericheMoravecDetector` or :class:`HopfieldMatcher` parameter;
        ``preset`` applies to both.

    Returns
    -------
    StereoMatchResult
        ``result.network.config`` holds the matcher parameters used (``max_disparity``
        resolved). On a rectified pair (no ``fundamental_matrix``; rows of one height), and
        with ``rectified=False`` when the network searched the rows of the aligned images
        (``result.geometry.search == "aligned"``), two steps beyond the paper follow the
        network, each with its parameter
        (docs/method.md): ``guided`` appends matches for left points the network left
        unmatched (``result.passes == 1``, right points appended to ``points_right``),
        and ``refine`` moves every match's right point to its sub-pixel position on the
        row the vertical model gives (``result.refinement``), then drops the matches whose
        grey window straddles a depth edge (:mod:`hopmatch.matching.halves`).
        Two more look at both images (docs/method.md 4.6-4.7): before detection the
        sharper view is blurred towards the other (``sharpness_ratio``;
        ``result.sharpness``), and after a first match whose grey levels differ by a curve
        or a varying gain (``tone_tolerance``, ``gain_field_tolerance``) the right view is
        mapped through them and the pair matched again (``result.tone_map``; a first
        match too poor to read the map off has it read off the two views' histograms).
        ``preset="paper"`` turns all four off, and ``both_features`` (method.md 4.11).

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(1)
    >>> left = (rng.random((120, 160)) * 255).astype(np.uint8)
    >>> right = np.roll(left, -6, axis=1)               # disparity 6 everywhere
    >>> res = match_stereo(left, right, max_disparity=12)
    >>> bool(abs(np.median(res.disparities) - 6.0) < 0.01), len(res.matches) > 20
    (True, True)
    >>> set(res.passes.tolist()) <= {0, 1, 2, 3}  # network, guided; the same of the 2nd run
    True
    """
    call = dict(mask_left=mask_left, mask_right=mask_right, rectified=rectified,
                fundamental_matrix=fundamental_matrix, record_energy=record_energy,
                detector=detector, matcher=matcher, threads=threads, **params)
    det_params, match_params = split_parameters(params)
    for name, given, keywords in (("detector", detector, det_params),
                                  ("matcher", matcher, match_params)):
        if given is not None and keywords:
            raise InvalidArgumentError(
                f"match_stereo got a `{name}` instance and its parameters {sorted(keywords)} "
                f"as keywords: set them on the instance instead"
            )
    if detector is not None and not isinstance(detector, DericheMoravecDetector):
        raise InvalidTypeError(
            f"`detector` must be a DericheMoravecDetector, got {type(detector).__name__}")
    if matcher is not None and not isinstance(matcher, HopfieldMatcher):
        raise InvalidTypeError(
            f"`matcher` must be a HopfieldMatcher, got {type(matcher).__name__}")
    threads = resolve_threads(threads)
    detector = detector if detector is not None else DericheMoravecDetector(**det_params)
    config = matcher.config() if matcher is not None else matcher_config(match_params,
                                                                          "match_stereo")
    fundamental = as_fundamental_matrix(fundamental_matrix, "fundamental_matrix",
                                        optional=True)
    if rectified is not None and not isinstance(rectified, (bool, np.bool_)):
        raise InvalidTypeError(f"`rectified` must be None, True or False, got {rectified!r}")
    if config.both_features:  # twice, on each feature image (method.md 4.11)
        return both_features.match_both_features(
            lambda **kw: match_stereo(left, right, **kw), call, detector, matcher, threads)
    channels = channels_kept(left, right, config.channel_clip_share, detector.getMaxPixels())
    if channels is not None:  # a view that clips channels the other does not (method.md 4.9)
        return match_both_greys(lambda gl, gr: match_stereo(gl, gr, **call),
                                (detector.gray_image(left, "left"),
                                 detector.gray_image(right, "right")), left, right, channels)
    unrectified_config = config
    if matcher is None and "vertical_threshold" not in match_params:
        unrectified_config = dataclasses.replace(config,
                                                 vertical_threshold=UNRECTIFIED_VERTICAL)
    if rectified is not None and not rectified:
        with using_threads(threads):
            return _match_unrectified(left, right, detector, unrectified_config, fundamental,
                                      mask_left, mask_right, record_energy)
    auto = (rectified is None and config.max_disparity is None
            and "min_disparity" not in match_params and config.preset != "paper"
            and (matcher is None or config.min_disparity in (None, 0.0))
            and warpable(np.shape(left), np.shape(right)))  # else rows (or F's band) only
    may_switch = auto and fundamental is None
    if auto and fundamental is not None:
        # the rows lined up by the given F, as rectified=False does with its own; when too
        # few correspondences agree with F for that, its epipolar band below
        later = []
        with using_threads(threads):
            aligned = _match_unrectified(left, right, detector, unrectified_config, None,
                                         mask_left, mask_right, record_energy,
                                         warnings_later=later, given=fundamental)
        if aligned.fundamental_matrix is not None:
            for give in later:
                give()
            return aligned

    given = left, right  # an unrectified pair is equalised after its warp (method.md 4.6)
    left, right = detector.gray_image(left, "left"), detector.gray_image(right, "right")
    if may_switch and left.shape[0] != right.shape[0]:  # rows of two heights: no rows to search
        warn(f"`left` has {left.shape[0]} rows and `right` {right.shape[0]}, so they are not "
             "a rectified pair: matched as an unrectified pair, its epipolar geometry "
             "estimated from the images (rectified=False; result.fundamental_matrix, "
             "result.geometry)", UnrectifiedPairWarning)
        with using_threads(threads):
            return _match_unrectified(*given, detector, unrectified_config, None,
                                      mask_left, mask_right, record_energy)
    left, right, sharpness = equalise_sharpness(left, right, config.sharpness_ratio)

    def detect(image, mask, side):
        t0 = time.perf_counter()
        out = detector.detect_and_describe(image, mask, name=side, mask_name=f"mask_{side}",
                                           keep_gray=True)
        return out, time.perf_counter() - t0

    with using_threads(threads):
        (found_l, t_l), (found_r, t_r) = run_both(lambda: detect(left, mask_left, "left"),
                                                  lambda: detect(right, mask_right, "right"),
                                                  threads)
        keypoint_size = float(detector.getWindowSize())

        def rematch(gray_right):  # the right view mapped through the pair's tone map
            found, t = detect(gray_right, mask_right, "right")
            later = []
            again = match_detected(found_l, found, config, keypoint_size=keypoint_size,
                                   fundamental=fundamental, record_energy=record_energy,
                                   timings={"detect_left": t_l, "detect_right": t_r + t},
                                   threads=threads, raise_unrectified=may_switch,
                                   warnings_later=later)
            return again.matched_left, again.matched_right, (again, found, later)

        try:
            first_warnings = []
            result = match_detected(found_l, found_r, config, keypoint_size=keypoint_size,
                                    fundamental=fundamental, record_energy=record_energy,
                                    timings={"detect_left": t_l, "detect_right": t_r},
                                    threads=threads, raise_unrectified=may_switch,
                                    warnings_later=first_warnings)
            # a second match through the tone map may find the pair off its rows where
            # the first, on views of unlike grey levels, could not tell
            tone, second = rematch_through_map(found_l[4], found_r[4], result.matched_left,
                                               result.matched_right, config.tone_tolerance,
                                               config.gain_field_tolerance, rematch)
        except LooksUnrectifiedError as found:
            warn(f"the pair does not look rectified: {found.evidence}, so it was matched as "
                 "an unrectified pair, its epipolar geometry estimated from the images "
                 "(rectified=False; result.fundamental_matrix, result.geometry); pass "
                 "rectified=True to search its rows anyway", UnrectifiedPairWarning)
            return _match_unrectified(*given, detector, unrectified_config, None,
                                      mask_left, mask_right, record_energy)
        exposure = exposure_note(found_l[4], found_r[4])  # the views as given
        if second is not None:
            result, found_r, first_warnings = second
        if may_switch and still_few(len(result.query_idx), found_l[0], found_r[0]):
            # too few matches on its rows, and no clear sign of a pair off them: the unrectified
            # path, kept when it finds a geometry and more (robustness.md, "Rectification check")
            later = []
            kept = fallback_if_kept(len(result.query_idx), lambda: _match_unrectified(
                *given, detector, unrectified_config, None, mask_left, mask_right,
                record_energy, warnings_later=later))
            if kept is not None:
                other, pending = kept
                warn(f"the pair kept {len(result.query_idx)} matches along its rows and "
                     f"{len(other.query_idx)} as an unrectified pair, its epipolar geometry "
                     "estimated from the images (rectified=False; result.fundamental_matrix, "
                     "result.geometry), so it was matched as one; pass rectified=True to "
                     "search its rows anyway", UnrectifiedPairWarning)
                for give in pending + later:
                    give()
                return other
        for give in first_warnings:  # those of the match kept
            give(exposure=exposure)
        result.tone_map = tone
    # after match_detected, whose checks of the pair (two heights...) come first
    (pts_l, *_, gray_l), (pts_r, *_, gray_r) = found_l, found_r
    window = detector.getDescriptorSize()
    warn_if_no_keypoints([("left", pts_l, gray_l, mask_left, window),
                          ("right", pts_r, gray_r, mask_right, window)])
    result.sharpness = sharpness
    return result


def match_detected(left, right, config: MatcherConfig, *, keypoint_size: float,
                   fundamental=None, record_energy: bool = False,
                   timings: dict | None = None, threads: int | None = None,
                   raise_unrectified: bool = False,
                   warnings_later: list | None = None) -> StereoMatchResult:
    """The matching half of :func:`match_stereo`, on what detection gave for each image.

    ``left`` and ``right`` are ``(points, responses, descriptors, gradient, grey)`` as
    :meth:`DericheMoravecDetector.detect_and_describe` returns them with ``keep_gray=True``
    (points may come from elsewhere, described on that detector's gradient); ``config``
    the matcher's parameters; ``fundamental`` None or a checked 3 x 3 matrix. Runs the
    network, then (rectified pairs) the guided pass and the refinement, these
    two in up to ``threads`` threads (None: :func:`hopmatch._threads.current_threads`).
    ``raise_unrectified``: raise :class:`~.diagnostics.LooksUnrectifiedError` where the
    rectification check would warn (:func:`match_pair`). ``warnings_later``: a list, for
    a caller that may keep another match instead (:func:`match_stereo`'s second match
    through a tone map): the warnings of the match (few matches, not rectified, the range)
    are appended to it as callables instead of being given (each called with no argument,
    or with ``exposure=`` :func:`~.diagnostics.exposure_note`'s words)."""
    pts_l, resp_l, desc_l, g_l, gray_l = left
    pts_r, resp_r, desc_r, g_r, gray_r = right
    timings = dict(timings or {})
    t2 = time.perf_counter()
    shape_l, shape_r = g_l.shape, g_r.shape
    if fundamental is None and shape_l[0] != shape_r[0]:
        raise InvalidArgumentError(
            f"`left` and `right` must have the same height (a rectified pair), got "
            f"{shape_l[0]} and {shape_r[0]}; for an unrectified pair pass rectified=False "
            "(its geometry estimated) or fundamental_matrix"
        )
    size_l, size_r = shape_l[::-1], shape_r[::-1]
    if fundamental is None and shape_l[1] != shape_r[1]:
        warn(f"`left` is {shape_l[1]} px wide and `right` {shape_r[1]} px: the images of a "
             "rectified pair have one size; matching goes on (disparities are measured from "
             "the left edge of both), but check that the pair is the one you meant",
             ImageSizeWarning)
        size_r = size_l  # warned once here; the matcher need not repeat it
    check_coordinate_range(pts_l, "left")
    check_coordinate_range(pts_r, "right")
    pair = PairInfo(pts_l, pts_r, size_l, size_r)
    few_matches_check = []  # the few-matches check, made on the final matches below
    with deferring(warnings_later):  # the range's and the geometry's warnings too
        net = match_pair(pair, desc_l, desc_r, config, fundamental=fundamental,
                         record_energy=record_energy, descriptors_checked=True,
                         raise_unrectified=raise_unrectified, few_matches_later=few_matches_check)
    t3 = time.perf_counter()
    timings["match"] = t3 - t2
    result = StereoMatchResult(
        points_left=pts_l, points_right=pts_r, responses_left=resp_l, responses_right=resp_r,
        query_idx=net.query_idx, train_idx=net.train_idx, distances=net.distances,
        network=net, keypoint_size=keypoint_size, timings=timings,
        match_timings={"network": t3 - t2, "guided": 0.0, "refine": 0.0},
    )
    if fundamental is None and len(net.query_idx):  # rows of one height (checked above)
        result = beyond_network(result, (desc_l, desc_r), (g_l, g_r), (gray_l, gray_r),
                                net.config, threads=threads)
    give_or_defer([functools.partial(check, kept=len(result.query_idx))
                   for check in few_matches_check], warnings_later)
    return result


def beyond_network(result: StereoMatchResult, descriptors, gradients, grays,
                   config: MatcherConfig, *, threads: int | None = None,
                   image_shape=None) -> StereoMatchResult:
    """``result`` (the network's matches on a rectified pair) with the guided pass's
    matches appended (``config.guided``) and every match refined (``config.refine``), less
    the matches whose refined windows straddle a depth edge (with ``config.refine``, unless
    ``hopmatch.matching.halves.HALF_CHECK`` is False;
    :func:`~hopmatch.matching.halves.straddling`).

    ``descriptors``, ``gradients`` and ``grays`` are the (left, right) windows, feature
    images and grey images of the detection (the grey images are what the refinement
    measures, and what the guided pass falls back on: :func:`grey_fallback`);
    ``image_shape`` the (H, W) of the images the pair was given as, which sets the
    refinement window (:func:`refine_radius`; default: the grey images' own). The
    vertical offset both steps search along is the robust plane
    (``config.vertical_model="plane"``) or the median of ``yl - yr`` over the network's
    matches. Returns ``result`` itself when neither step is on, and
    with only ``row_offset`` set when that offset varies too fast for a rectified pair
    (:meth:`~hopmatch.matching.vertical.RowOffset.is_residual`: the steps search along
    rows; rectify the pair or pass a fundamental matrix).
    """
    if not (config.guided or config.refine):
        return result
    t0 = time.perf_counter()
    net = result.network
    pts_l, pts_r = result.points_left, result.points_right
    ml = pts_l[net.query_idx]
    dy = ml[:, 1].astype(np.float64) - pts_r[net.train_idx, 1]
    offset = fit_row_offset(ml, dy) if config.vertical_model == "plane" else median_offset(dy)
    if not offset.is_residual():
        return dataclasses.replace(result, row_offset=offset)
    grays = (measurable_gray(np.asarray(grays[0])), measurable_gray(np.asarray(grays[1])))
    n_right = len(pts_r)
    gm = None
    if config.guided:
        gm = guided_rounds(pts_l, pts_r, descriptors[0], descriptors[1], gradients[0],
                           gradients[1], net.query_idx, net.train_idx, offset.at(pts_l),
                           config, margin=config.guided_margin,
                           fallback=grey_fallback(grays, gradients,
                                                  descriptors[0].shape[1]),
                           threads=threads)
    t1 = time.perf_counter()
    k = 0 if gm is None else len(gm.query_idx)
    query_idx = (net.query_idx if k == 0 else
                 np.concatenate((net.query_idx, gm.query_idx)).astype(np.int32, copy=False))
    train_idx = (net.train_idx if k == 0 else np.concatenate(
        (net.train_idx, np.arange(n_right, n_right + k, dtype=np.int32)))
                 .astype(np.int32, copy=False))
    points_right = (pts_r if k == 0 else np.concatenate((pts_r, gm.right_points))
                    .astype(np.float32, copy=False))
    responses_right = (result.responses_right if k == 0 else
                       np.concatenate((result.responses_right, np.zeros(k, np.float32))))
    refinement = None
    passes = np.full(len(net.query_idx) + k, PASS_NETWORK, np.uint8)
    passes[len(net.query_idx):] = PASS_GUIDED
    distances = net.distances if k == 0 else np.concatenate((net.distances, gm.distances))
    if config.refine:
        left = pts_l[query_idx]
        yr = left[:, 1].astype(np.float64) - offset.at(left)
        radius = refine_radius(np.shape(grays[0])[:2] if image_shape is None
                               else image_shape)
        refinement = refine_disparities(grays[0], grays[1], left,
                                        points_right[train_idx, 0], yr, radius=radius,
                                        threads=threads)
        moved = train_idx[refinement.ok]
        points_right = points_right.copy() if points_right is pts_r else points_right
        points_right[moved, 0] = refinement.x[refinement.ok]
        points_right[moved, 1] = yr[refinement.ok]
        # one scale for both passes: field and peak curvature
        u = fields_of_distances(net.distances)
        u = u if k == 0 else np.concatenate((u, gm.fields))
        distances = confidence_distances(u, refinement.curvature)
        if halves.HALF_CHECK:  # windows that straddle a depth edge (matching.halves)
            drop = halves.straddling(grays[0], grays[1], left, points_right[train_idx],
                                     radius=half_window_radius(radius), threads=threads)
            if drop.any():
                (query_idx, train_idx, points_right, passes, distances, gm,
                 refinement) = _without(drop, query_idx, train_idx, points_right, pts_r,
                                        n_right, passes, distances, gm, refinement)
                k = 0 if gm is None else len(gm.query_idx)
                responses_right = responses_right[:n_right + k]
    t2 = time.perf_counter()
    timings = dict(result.timings, match=result.timings["match"] + (t2 - t0))
    match_timings = dict(result.match_timings, guided=t1 - t0, refine=t2 - t1)
    return dataclasses.replace(
        result, points_right=points_right, responses_right=responses_right,
        query_idx=query_idx, train_idx=train_idx, distances=distances.astype(np.float32),
        timings=timings, match_timings=match_timings, passes=passes,
        n_detected_right=n_right, guided=gm, refinement=refinement, row_offset=offset)


def grey_fallback(grays, gradients, window_values: int) -> GreyFallback | None:
    """The guided rounds' :class:`~.guided_results.GreyFallback` of a pair whose (left, right)
    grey images are ``grays`` and feature images ``gradients``, its points described by
    windows of ``window_values`` values (a square side's square); None
    without :data:`~.guided.GUIDED_FALLBACK`, or when the feature images are the
    normalised grey levels themselves (``on="intensity"``: the same search again)."""
    if not guided.GUIDED_FALLBACK:
        return None
    left = normalised_intensity(np.asarray(grays[0]))
    if left.shape == np.shape(gradients[0]) and np.array_equal(left, gradients[0]):
        return None
    return GreyFallback(left, normalised_intensity(np.asarray(grays[1])),
                        int(round(np.sqrt(window_values))))


def _without(drop, query_idx, train_idx, points_right, pts_r, n_right, passes, distances,
             gm, refinement):
    """The matches of :func:`beyond_network` but those where ``drop``: the network's
    detected right points they moved back where they were detected, the guided ones
    removed from ``points_right`` and ``gm`` (the rest renumbered, in order)."""
    keep = ~drop
    points_right = points_right.copy()
    gone = train_idx[drop & (train_idx < n_right)]
    points_right[gone] = pts_r[gone]
    if gm is not None and len(gm.query_idx):
        keep_g = keep[len(query_idx) - len(gm.query_idx):]
        gm = GuidedMatches(*(getattr(gm, f.name)[keep_g]
                             for f in dataclasses.fields(GuidedMatches)))
        points_right = np.r_[points_right[:n_right],
                             points_right[n_right:][keep_g]].astype(np.float32)
        n_net = len(query_idx) - len(keep_g)
        train_idx = np.r_[train_idx[:n_net][keep[:n_net]],
                          n_right + np.arange(len(gm.query_idx))].astype(np.int32)
    else:
        train_idx = train_idx[keep]
    return (query_idx[keep], train_idx, points_right, passes[keep], distances[keep], gm,
            None if refinement is None else Refinement(*(a[keep] for a in refinement)))


def refine_radius(shape) -> int:
    """Half-side of the refinement windows for images of ``shape`` (H, W):
    ``REFINE_RADIUS`` (7 x 7 windows) up to about 0.74 Mpixel (``REFINE_REFERENCE_PIXELS``
    times 1.85; every shared scene but aloe), then ``round(REFINE_RADIUS * (H W /
    REFINE_REFERENCE_PIXELS) ** 0.25)``: 4 on aloe (1282 x 1110), 6 at 2964 x 2000.

    A fixed 7 x 7 window covers 16 times less of the scene at four times the resolution;
    on motorcycle upsampled to 2964 x 2000 its ZNCC peak is too flat to fix the disparity
    to 1 px (precision at 1 px 0.894 with 3, 0.929 with 6, 0.932 with 8), while on
    motorcycle itself 4 already loses (docs/parameters.md, "Refinement window and image
    size")."""
    pixels = float(shape[0]) * float(shape[1])
    return max(REFINE_RADIUS,
               int(np.floor(REFINE_RADIUS * (pixels / REFINE_REFERENCE_PIXELS) ** 0.25 + 0.5)))


def half_window_radius(refine_half_side: int) -> int:
    """Half-side of the half-window test's windows (:mod:`hopmatch.matching.halves`) beside
    a refinement of half-side ``refine_half_side`` (:func:`refine_radius`):
    ``HALF_RADIUS`` (9 x 9) beside the 7 x 7 windows, grown in proportion beyond them."""
    return max(halves.HALF_RADIUS,
               int(np.floor(halves.HALF_RADIUS * refine_half_side / REFINE_RADIUS + 0.5)))


def warm_up_beyond_network() -> None:
    """Compile (or load from the cache) the kernels of the guided pass, the refinement and
    the half-window test on tiny inputs of the dtypes :func:`match_stereo` gives them
    (``hopmatch.warmup``)."""
    rng = np.random.default_rng(0)
    g = np.ascontiguousarray(rng.random((40, 64)) * 100, dtype=np.float32)
    xs, ys = np.meshgrid(np.arange(20.0, 44.0, 4.0), np.arange(15.0, 26.0, 5.0))
    pts = np.c_[xs.ravel(), ys.ravel()].astype(np.float32)
    desc = DericheMoravecDetector().describe_points(g, pts)[1]
    matched = np.arange(1, len(pts), dtype=np.int32)  # all but the first: it has neighbours
    guided_pass(pts, pts, desc, desc, g, g, matched, matched, np.zeros(len(pts)),
                matcher_config({}))
    refine_disparities(g, g, pts, pts[:, 0], pts[:, 1])
    halves.straddling(g, g, pts, pts)


def _match_unrectified(left, right, detector, config, fundamental, mask_left, mask_right,
                       record_energy, warnings_later: list | None = None,
                       given=None) -> StereoMatchResult:
    """``match_stereo(..., rectified=False)``: :func:`match_unrectified` as a result.
    ``warnings_later``: a list, for a caller that may keep another match instead; the
    warnings about the result (no geometry, few matches) are appended to it as callables of
    no argument instead of being given. ``given``: a checked F to line the rows up with
    (``match_stereo(..., fundamental_matrix=F)``), not estimated; ``fundamental`` is the
    caller's argument with ``rectified=False``, refused."""
    if fundamental is not None:
        raise InvalidArgumentError(
            "match_stereo got rectified=False and a fundamental_matrix: rectified=False "
            "estimates F from the pair; to match along a known F pass only "
            "fundamental_matrix")
    if config.max_disparity is not None:
        raise InvalidArgumentError(
            f"match_stereo got rectified=False and max_disparity={config.max_disparity:g}: "
            "the disparity range of an unrectified pair is found with its geometry (in the "
            "frame the right image is aligned to); leave max_disparity=None")
    few_matches_check = []  # the few-matches check, made on the final matches below
    pts_l, resp_l, pts_r, resp_r, net, geometry, timings, frame = match_unrectified(
        left, right, detector, config, mask_left=mask_left, mask_right=mask_right,
        record_energy=record_energy, few_matches_later=few_matches_check, fundamental=given)
    pending = []
    if net is None:
        pending.append(functools.partial(
            warn, f"match_stereo(rectified=False) found no epipolar geometry, so no matches: "
            f"{geometry.reason}", GeometryWarning))
        net = empty_network_result(config)
    result = StereoMatchResult(
        points_left=pts_l, points_right=pts_r, responses_left=resp_l, responses_right=resp_r,
        query_idx=net.query_idx, train_idx=net.train_idx, distances=net.distances,
        network=net, keypoint_size=float(detector.getWindowSize()), timings=timings,
        match_timings={"network": timings.get("match", 0.0), "guided": 0.0, "refine": 0.0},
        fundamental_matrix=geometry.fundamental, geometry=geometry,
        sharpness=None if frame is None else frame.sharpness,
        tone_map=None if frame is None else frame.tone_map)
    if frame is not None and frame.mode != "epipolar" and len(net.query_idx):
        result = unrectified_beyond_network(result, frame)
    if frame is not None and given is None:  # matches where F is extrapolated
        m_l, m_r = result.matched_left, result.matched_right
        drop = unsupported(frame.bootstrap, np.shape(left), m_l, m_r)
        result = _dropping(result, drop, pts_r) if drop.any() else result
        pending += [functools.partial(warn, m, GeometryWarning) for m in support_notes(drop)]
    give_or_defer(pending + [functools.partial(check, kept=len(result.query_idx))
                             for check in few_matches_check], warnings_later)
    return result


def unrectified_beyond_network(result: StereoMatchResult, frame) -> StereoMatchResult:
    """:func:`beyond_network` (the guided pass and the refinement) on an unrectified pair
    searched along the rows of its aligned images (``frame.mode`` ``'aligned'``) or of its
    rectification (``'rectified'``): run in the canvas of
    :func:`~hopmatch.matching.unrectified.shared_frame` or
    :func:`~hopmatch.matching.unrectified.rectified_canvas`, where the pair is a rectified
    one of one size (its refinement window that of the left image's size, not the
    canvas's), and every new or moved right point mapped back into the right image; a
    match whose right point lands outside it is dropped (``_without``)."""
    pts_l, pts_r = result.points_left, result.points_right
    if frame.mode == "aligned":
        fl, fr, grays, grads, (_, b) = shared_frame(frame, pts_l, frame.right_points)
        descriptors, to_right = frame.descriptors, np.linalg.inv(frame.to_aligned)
    else:
        fl, fr, grays, grads, descriptors, to_right = rectified_canvas(
            frame, pts_l, frame.right_points)
        b = 0
    out = beyond_network(dataclasses.replace(result, points_left=fl, points_right=fr),
                         descriptors, grads, grays, result.network.config,
                         image_shape=np.shape(frame.grays[0])[:2])
    if out.points_right is fr:
        return dataclasses.replace(out, points_left=pts_l, points_right=pts_r)
    n = len(fr)
    back = np.asarray(out.points_right, np.float64) - [b, 0.0]
    mapped = transform_points(back, to_right).astype(np.float32)
    same = np.all(out.points_right[:n] == fr, axis=1)
    mapped[:n][same] = pts_r[same]
    # the canvas holds more than the right image: a window there may peak just beyond it
    h, w = frame.right_shape
    outside = ~((mapped[:, 0] >= 0) & (mapped[:, 0] <= w - 1) & (mapped[:, 1] >= 0)
                & (mapped[:, 1] <= h - 1))
    out = dataclasses.replace(out, points_left=pts_l, points_right=mapped)
    drop = outside[out.train_idx]
    return _dropping(out, drop, pts_r) if drop.any() else out


def _dropping(result: StereoMatchResult, drop, detected) -> StereoMatchResult:
    """``result`` less the matches where ``drop`` (:func:`_without`, of ``detected``)."""
    n = len(detected)
    query_idx, train_idx, points_right, passes, distances, gm, refinement = _without(
        drop, result.query_idx, result.train_idx, result.points_right, detected, n,
        result.passes, result.distances, result.guided, result.refinement)
    return dataclasses.replace(  # the detected right points and the guided ones kept
        result, query_idx=query_idx, train_idx=train_idx, points_right=points_right,
        passes=passes, distances=distances, guided=gm, refinement=refinement,
        responses_right=result.responses_right[:len(points_right)])
