"""Grey levels without the colour channels that one view clips (beyond the paper;
docs/method.md, section 4.9).

A view brighter than the other (a longer exposure, a gain) clips its channels at their top
level where the scene is bright, and a channel clips where the others do not: a warm
scene's red and green, over half of the view, while its blue keeps its texture. The grey
levels of ``cv2.COLOR_BGR2GRAY`` (0.299 R + 0.587 G + 0.114 B) keep, there, a tenth of the
texture the other view's grey levels have: the gradient, the Moravec points and the
windows no longer agree. Grey levels made of the channels that clip in neither view
(their ``COLOR_BGR2GRAY`` weights, scaled to sum to 1) are a linear function of the same
channels in the other view. They also lose the other channels' texture where nothing
clips, so :func:`match_stereo`
(``hopmatch.matching.stereo_match``) matches the pair both ways when a channel clips
apart (:func:`channels_kept`) and keeps the match with more pairs
(:func:`match_both_greys`).
"""

from __future__ import annotations

import cv2
import numpy as np

from .._warnings import deferred_warnings

#: ``cv2.COLOR_BGR2GRAY``'s weights of the B, G and R channels.
GREY_WEIGHTS = (0.114, 0.587, 0.299)


def _top_share(image: np.ndarray, channel: int, top: int) -> float:
    """The share of ``image``'s pixels whose ``channel`` is ``top`` (a histogram: no copy
    of the image)."""
    # (1, 1) from OpenCV 4, (1,) from OpenCV 5: summed, either is the count
    count = float(cv2.calcHist([image], [channel], None, [1], [top, top + 1]).sum())
    return count / (image.shape[0] * image.shape[1])


def channels_kept(left, right, share, max_pixels: int) -> tuple[int, ...] | None:
    """The colour channels (indices into B, G, R) that a second grey version of the pair is
    made of, or None when there is to be none.

    There is one when both views are BGR or BGRA arrays of one unsigned integer dtype
    (uint8 or uint16, whose top level is 255 or 65535), of at most ``max_pixels`` pixels
    each, and one or two of the channels are at their top level on at least ``share`` of
    one view's pixels more than of the other's: the others are kept. ``share`` None: never.
    Anything else (grey views, floats, bad input) gets None: the caller goes on as without
    this step, and its own checks refuse bad input.
    """
    if share is None:
        return None
    views = (left, right)
    if not all(isinstance(v, np.ndarray) and v.ndim == 3 and v.shape[2] in (3, 4)
               and v.shape[0] * v.shape[1] > 0 for v in views):
        return None
    if left.dtype != right.dtype or left.dtype.type not in (np.uint8, np.uint16):
        return None
    if any(v.shape[0] * v.shape[1] > max_pixels for v in views):
        return None  # the caller refuses them
    top = int(np.iinfo(left.dtype).max)
    views = [np.ascontiguousarray(v) for v in views]
    keep = tuple(c for c in range(3)
                 if abs(_top_share(views[0], c, top) - _top_share(views[1], c, top)) < share)
    return keep if 0 < len(keep) < 3 else None


def grey_of_channels(image: np.ndarray, channels: tuple[int, ...]) -> np.ndarray:
    """The grey levels of the BGR(A) ``image`` made of ``channels`` alone, with
    :data:`GREY_WEIGHTS` scaled to sum to 1 (``image``'s dtype, rounded as
    ``cv2.cvtColor`` rounds)."""
    weights = np.zeros((1, image.shape[2]), dtype=np.float64)
    for c in channels:
        weights[0, c] = GREY_WEIGHTS[c]
    weights /= weights.sum()
    grey = cv2.transform(np.ascontiguousarray(image), weights)
    return grey.reshape(image.shape[:2])


def match_both_greys(match, grey_pair, left, right, channels: tuple[int, ...]):
    """``match(grey_left, grey_right)`` on ``grey_pair`` (the views' usual grey levels)
    and on the grey levels of ``channels`` alone (:func:`grey_of_channels` of ``left``
    and ``right``): the result with more matches (the first on a tie), its
    ``grey_channels`` set to ``channels`` when it is the second; only its warnings are
    given."""
    with deferred_warnings() as usual_warnings:
        usual = match(*grey_pair)
    with deferred_warnings() as other_warnings:
        other = match(grey_of_channels(left, channels), grey_of_channels(right, channels))
    if len(other.query_idx) > len(usual.query_idx):
        other.grey_channels = tuple(channels)
        usual, usual_warnings = other, other_warnings
    for give in usual_warnings:
        give()
    return usual
