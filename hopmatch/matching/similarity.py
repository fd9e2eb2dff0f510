"""SPEC section 3, eqs. 7-9: the similarity of two windows, and the one-pixel shift check."""

from __future__ import annotations

import numpy as np

from .._kernels import similarity as _ks
from .._threads import current_threads, map_chunks, map_ranges, run_both

#: Regulariser of eq. 7's normalisation (added to the windows' mean contrast).
EPS = 1e-6


def window_contrasts(desc_l: np.ndarray, desc_r: np.ndarray):
    """``(s_l, s_r)``: each float descriptor row's ``mean |row|``, the contrast that
    normalises eq. 7 (:func:`similarity_distance`); None for binary (uint8) descriptors."""
    if desc_l.dtype == np.uint8:
        return None
    # the two images' rows on two threads when there are (each row on its own: the same)
    return run_both(lambda: _ks.row_mean_abs(desc_l), lambda: _ks.row_mean_abs(desc_r),
                    current_threads())


def similarity_distance(desc_l: np.ndarray, desc_r: np.ndarray, ni: np.ndarray,
                        nk: np.ndarray, gate: float | None = None,
                        contrasts=None, gain_tolerance: float = 1.0) -> np.ndarray:
    """Normalised similarity distance of each candidate pair (eqs. 7-9).

    Float descriptors: ``M_ik`` of eq. 7 (mean absolute difference of the mean-subtracted
    windows) divided by the mean of the two windows' mean absolute values, so that it does
    not depend on contrast: 0 for identical windows, about 1 for unrelated ones, at most 2.
    This also serves any float descriptor (SIFT...). Binary (uint8) descriptors: the
    fraction of differing bits, in [0, 1].

    With a ``gate``, float pairs whose distance certainly exceeds it (their contrasts
    differ too much) are given ``inf`` without computing it; the others are exact.
    ``contrasts``: :func:`window_contrasts` of the descriptors, if already computed.

    ``gain_tolerance`` (>= 1; the matcher's ``gain_tolerance``): before the difference, the
    right window is scaled by the ratio of the two contrasts, clipped to
    ``[1 / gain_tolerance, gain_tolerance]``, so that two views of one surface whose gain
    differs by less than that compare as equal; a larger contrast difference still counts.
    1 is eq. 7 as written.

    Float pairs are computed in :func:`hopmatch._threads.current_threads` threads (each
    pair on its own: bit-identical for any count).
    """
    if desc_l.dtype == np.uint8:
        return _ks.hamming_fraction(desc_l, desc_r, ni, nk)
    scale_l, scale_r = contrasts if contrasts is not None else window_contrasts(desc_l, desc_r)
    gate = np.inf if gate is None else float(gate)
    tol = float(gain_tolerance)
    return map_chunks(lambda i, k: (_ks.normalised_difference(desc_l, desc_r, i, k, scale_l,
                                                              scale_r, EPS, gate, tol),),
                      (ni, nk))[0]


#: The zero-mean test of window rows: ``|mean| <= WINDOW_MEAN_TOL[0] * mean |x| + [1]``.
WINDOW_MEAN_TOL = (1e-3, 1e-9)


def _window_shaped(desc: np.ndarray) -> bool:
    """Whether rows can be the windows of eqs. 8-9: float, square length (s >= 3)."""
    if desc.dtype == np.uint8 or desc.ndim != 2 or len(desc) == 0:
        return False
    s = int(round(np.sqrt(desc.shape[1])))
    return s >= 3 and s * s == desc.shape[1]


def shift_minimal(desc_l: np.ndarray, desc_r: np.ndarray, qi: np.ndarray,
                  ti: np.ndarray) -> np.ndarray:
    """Boolean (M,): the right window of each match fits the left one better at the matched
    position than shifted by one pixel along the row (either way).

    Compares the overlapping columns of the square (s x s) descriptor windows at column
    shifts -1, 0, +1 with the mean absolute difference. A match whose cost is lower at a
    one-pixel shift is a localisation near-miss (the right keypoint is off by >= 1 px) and
    is rejected. Descriptors that are not windows pass unchanged: windows (as
    ``gradient_windows`` makes them) are float rows of square length with zero mean, SIFT,
    KAZE... rows are not (``_ks.zero_mean`` on the matched rows, :data:`WINDOW_MEAN_TOL`).
    """
    qi = np.ascontiguousarray(qi, dtype=np.int64)
    ti = np.ascontiguousarray(ti, dtype=np.int64)
    keep = np.ones(len(qi), dtype=bool)
    if len(qi) == 0 or not (_window_shaped(desc_l) and _window_shaped(desc_r)):
        return keep
    s = int(round(np.sqrt(desc_l.shape[1])))
    # in contiguous ranges of the pairs on up to current_threads() threads: each pair's test
    # is its own, and the rows are windows when they are in every range
    parts = map_ranges(lambda lo, hi: _ks.shift_minimal_windows(
        desc_l, desc_r, qi[lo:hi], ti[lo:hi], s, *WINDOW_MEAN_TOL), len(qi))
    if not all(windows for _, windows in parts):
        return keep
    return parts[0][0] if len(parts) == 1 else np.concatenate([k for k, _ in parts])




def match_distance(fields: np.ndarray) -> np.ndarray:
    """``1 / (1 + exp(u))`` of each local field ``u`` (eq. 12's bracket): the
    ``DMatch.distance`` of a neuron, near 0 when strongly supported, 0.5 when undecided,
    near 1 when suppressed. float64; overflow of ``exp`` gives exactly 0 or 1."""
    with np.errstate(over="ignore"):
        return 1.0 / (1.0 + np.exp(fields))
