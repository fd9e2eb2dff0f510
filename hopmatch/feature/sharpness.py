"""Two views of unequal sharpness, made equal before detection (beyond the paper;
docs/method.md section 4.6).

Two cameras rarely focus alike, and a right image that was warped (rotated, rescaled,
rectified by interpolation) is smoother than the left one. The Moravec points of eqs. 1-2
and the windows of eqs. 7-9 then differ between the views of one surface: with the right
image of the shared scenes blurred by a Gaussian of sigma 1 px, a quarter fewer correct
matches are found. :func:`equalise_sharpness` measures both views (:func:`sharpness`)
and, where they differ by more than a ratio, blurs the sharper one until they differ by at
most a Gaussian of :data:`RESIDUAL_SIGMA` (:func:`equalising_sigma`), so that the pair is
matched as two nearly equally sharp images.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

#: Rows of the central band of an image that :func:`sharpness` and :func:`matching_sigma`
#: measure (all rows of a smaller image).
BAND_ROWS = 256
#: Every this-many-th row of that band is measured.
ROW_STEP = 4
#: Largest Gaussian sigma (px) :func:`matching_sigma` applies.
MAX_SIGMA = 4.0
#: Bisection steps of :func:`matching_sigma` (the sigma to ``MAX_SIGMA / 2**STEPS``).
STEPS = 9
#: Blur (px) left between the views: the sharper one is blurred by ``sqrt(sigma**2 -
#: RESIDUAL_SIGMA**2)`` (:func:`equalising_sigma`), sigma the Gaussian that makes the two
#: agree. A difference this small costs few matches, and blurring both views costs
#: precision, so it is left as it is (docs/parameters.md, "Two views of unequal
#: sharpness", measures 0, 0.5, 0.6 and 0.7).
RESIDUAL_SIGMA = 0.6
#: Grey levels beyond which :func:`sharpness` sums in float64: its float32 sums of a few
#: hundred thousand differences overflow from about 1e32.
FLOAT32_SUMS = 1e30


@dataclass(frozen=True)
class SharpnessMatch:
    """What :func:`equalise_sharpness` measured and did.

    Attributes
    ----------
    sharpness_left, sharpness_right : float
        :func:`sharpness` of each view as given (NaN for a flat one).
    sigma_left, sigma_right : float
        The Gaussian sigma (px) each view was blurred with before detection (0: not
        blurred; at most one of them is not 0).
    """

    sharpness_left: float
    sharpness_right: float
    sigma_left: float = 0.0
    sigma_right: float = 0.0


def central_rows(height: int) -> slice:
    """The central :data:`BAND_ROWS` rows of an image of ``height`` rows (all of them if
    fewer): the band :func:`equalise_sharpness` measures."""
    top = max((height - BAND_ROWS) // 2, 0)
    return slice(top, top + BAND_ROWS)


def sharpness(band: np.ndarray, valid: np.ndarray | None = None) -> float:
    """How sharp an image is: ``sum |I(x - 2) - 2 I(x) + I(x + 2)| / sum |I(x + 2) - I(x -
    2)|`` along every :data:`ROW_STEP`-th row of ``band`` (a float32 image), over the
    pixels whose five-pixel run is all ``valid`` (bool, ``band``'s shape; None: all).

    A ratio of a second difference to a first one: independent of gain and offset, larger
    for finer detail (a Gaussian blur of sigma 1 px lowers it by 34-48 % on the shared
    scenes' left views; noise raises it). Differences across 2 px rather than 1: on a
    smooth uint8 image the rounding of the grey levels dominates the 1-px second
    difference, and a view resampled by a warp then measures sharper than its original.
    NaN for an image without horizontal change (or narrower than 5 px).
    """
    rows = band[::ROW_STEP]
    if rows.size and float(np.max(np.abs(rows))) > FLOAT32_SUMS:  # sums overflow float32
        rows = rows.astype(np.float64)
    if rows.shape[1] < 5:
        return float("nan")
    second = np.abs(rows[:, :-4] - 2.0 * rows[:, 2:-2] + rows[:, 4:])
    first = np.abs(rows[:, 4:] - rows[:, :-4])
    if valid is not None:
        ok = valid[::ROW_STEP]
        ok = ok[:, :-4] & ok[:, 1:-3] & ok[:, 2:-2] & ok[:, 3:-1] & ok[:, 4:]
        second, first = second[ok], first[ok]
    total = float(first.sum())
    return float(second.sum()) / total if total > 0.0 else float("nan")


def blurred(image: np.ndarray, sigma: float) -> np.ndarray:
    """``image`` (float32) blurred by a Gaussian of ``sigma`` px (mirrored border, as
    ``cv2.GaussianBlur`` does by default); ``image`` itself for ``sigma <= 0``. Grey
    levels beyond :data:`FLOAT32_SUMS` are blurred in float64 (the float32 sums of the
    filter would overflow to infinity), and the result, a weighted mean of them, cast back."""
    if sigma <= 0.0:
        return image
    if image.size and float(np.max(np.abs(image))) > FLOAT32_SUMS:
        return cv2.GaussianBlur(image.astype(np.float64), (0, 0), sigma).astype(np.float32)
    return cv2.GaussianBlur(image, (0, 0), sigma)


def matching_sigma(band: np.ndarray, target: float,
                   valid: np.ndarray | None = None) -> float:
    """The Gaussian sigma (px, at most :data:`MAX_SIGMA`) that brings :func:`sharpness` of
    ``band`` (over ``valid``) down to ``target``, by bisection (sharpness falls as sigma
    grows); 0 when ``band`` is not sharper than ``target``."""
    if not sharpness(band, valid) > target:
        return 0.0
    lo, hi = 0.0, MAX_SIGMA
    if sharpness(blurred(band, hi), valid) > target:
        return hi
    for _ in range(STEPS):
        mid = 0.5 * (lo + hi)
        if sharpness(blurred(band, mid), valid) > target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def equalising_sigma(band: np.ndarray, target: float,
                     valid: np.ndarray | None = None) -> float:
    """The Gaussian sigma (px) :func:`equalise_sharpness` blurs ``band``'s image with to
    bring it within :data:`RESIDUAL_SIGMA` of an image of sharpness ``target``: ``sqrt(s**2
    - RESIDUAL_SIGMA**2)`` of :func:`matching_sigma`'s ``s`` (Gaussians compose by their
    variances), 0 when ``s <= RESIDUAL_SIGMA``."""
    sigma = matching_sigma(band, target, valid)
    return float(np.sqrt(max(sigma * sigma - RESIDUAL_SIGMA * RESIDUAL_SIGMA, 0.0)))


def equalise_sharpness(gray_left: np.ndarray, gray_right: np.ndarray, ratio: float | None,
                       valid: np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray, SharpnessMatch]:
    """``(left, right, record)``: the grey views as given, or, when one view's
    :func:`sharpness` exceeds the other's by more than the factor ``ratio``, that view
    blurred (float32) until the two differ by :data:`RESIDUAL_SIGMA` at most
    (:func:`equalising_sigma`); ``record`` says what was measured and done.

    Both are measured on their central rows (:func:`central_rows`), over ``valid`` (bool,
    the views' common shape; None: everywhere) when given: the right view warped into the
    left one's frame has pixels that show nothing. ``ratio`` None: never blur (the record
    still measures). A flat view (NaN sharpness) is never blurred, nor is the other view
    for it.
    """
    rows = central_rows(gray_left.shape[0])
    bands = (np.asarray(gray_left[rows], dtype=np.float32),
             np.asarray(gray_right[rows], dtype=np.float32))
    where = None if valid is None else valid[rows]
    measured = (sharpness(bands[0], where), sharpness(bands[1], where))
    views = [gray_left, gray_right]
    sigmas = [0.0, 0.0]
    if ratio is not None and np.isfinite(measured).all():
        for side, other in ((0, 1), (1, 0)):
            if measured[side] > ratio * measured[other]:
                sigmas[side] = equalising_sigma(bands[side], measured[other], where)
                if sigmas[side] > 0.0:
                    views[side] = blurred(np.asarray(views[side], dtype=np.float32),
                                          sigmas[side])
    return views[0], views[1], SharpnessMatch(*measured, *sigmas)
