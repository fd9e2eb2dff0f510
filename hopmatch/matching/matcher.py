"""The cv2 DescriptorMatcher-like HopfieldMatcher."""

from __future__ import annotations

import copy
import warnings

import cv2
import numpy as np

from .._params import Configurable, _state_params
from .._validate import (
    as_descriptors,
    as_image_size,
    as_mask,
    as_points,
    check_coordinate_range,
)
from ..errors import (
    BudgetExceededError,
    DisparityRangeWarning,
    ImageSizeWarning,
    InvalidArgumentError,
    InvalidTypeError,
    PairInfoError,
    UnrectifiedPairWarning,
)
from .._kernels import neighbours as _kn
from .network import (
    NetworkResult,
    candidate_pairs,
    run_hopfield_network,
    similarity_distance,
)
from .params import MATCHER_PARAMS, PRESETS

#: ``record_energy`` keeps one float64 per allowed iteration: refuse more than this many
#: (1 GiB) rather than let the allocation fail.
MAX_ENERGY_TRACE = 2**27

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


def rectification_evidence(q_pts, t_pts, qd, td, min_disparity, max_disparity, max_vertical):
    """Median ``|y_left - y_right|`` of unambiguous best look-alikes in a generous band.

    Up to :data:`RECTIFICATION_SAMPLE` left points (evenly spaced in the keypoint order) are
    compared by the network's similarity distance with every right point within the
    disparity range and ``band = max(16, 4 * max_vertical)`` rows. A point counts when its
    best candidate is clearly better than its second (distance ratio below
    :data:`RECTIFICATION_RATIO`). Returns ``(median |dy|, number of points counted,
    fraction of them with |dy| <= max(1, max_vertical))``, or None when there is too little
    to judge (fewer than 2 x RECTIFICATION_MIN_EVIDENCE points
    on a side, or more than RECTIFICATION_MAX_PAIRS pairs to compare).
    """
    if min(len(q_pts), len(t_pts)) < 2 * RECTIFICATION_MIN_EVIDENCE:
        return None
    n = min(len(q_pts), RECTIFICATION_SAMPLE)
    sample = np.unique(np.linspace(0, len(q_pts) - 1, n).astype(np.int64))
    left = np.ascontiguousarray(q_pts[sample])
    band = max(16.0, 4.0 * max_vertical)
    try:
        ni, nk = candidate_pairs(left, t_pts, min_disparity, max_disparity, band,
                                 RECTIFICATION_MAX_PAIRS)
    except BudgetExceededError:
        return None
    if len(ni) == 0:
        return None
    sim = similarity_distance(np.ascontiguousarray(qd[sample]), td, ni, nk)
    order = np.lexsort((sim, ni))
    ni_o, nk_o, sim_o = ni[order], nk[order], sim[order]
    first = np.flatnonzero(np.r_[True, ni_o[1:] != ni_o[:-1]])
    counts = np.diff(np.r_[first, len(ni_o)])
    has_two = counts >= 2
    best, second = first[has_two], first[has_two] + 1
    clear = sim_o[best] < RECTIFICATION_RATIO * sim_o[second]
    best = best[clear]
    if len(best) < RECTIFICATION_MIN_EVIDENCE:
        return None
    dy = np.abs(left[ni_o[best], 1].astype(np.float64) - t_pts[nk_o[best], 1])
    return (float(np.median(dy)), int(len(best)),
            float(np.mean(dy <= max(1.0, max_vertical))))


def resolve_max_disparity(max_disparity, query_size, query_pts, train_pts) -> float:
    """``max_disparity``, or when it is None a quarter of the query image's width (or of the
    keypoints' horizontal extent when the image size is unknown)."""
    if max_disparity is not None:
        return float(max_disparity)
    if query_size is not None:
        return 0.25 * query_size[0]
    xs = [pts[:, 0].max() for pts in (query_pts, train_pts) if len(pts)]
    return 0.25 * (float(max(xs)) + 1.0) if xs else 0.0


def neighbour_pairs_bound(points: np.ndarray, half_w: float, half_h: float) -> int:
    """An upper bound on the number of (ordered) neighbour pairs the network stores: points
    are bucketed in cells of ``half_w x half_h`` (as the kernel does), and every neighbour
    of a point lies in the 3 x 3 cells around it. Counted on a dense grid in O(N + cells)
    when it has at most ``8 N + 1024`` cells, else on the occupied cells in O(N log N)
    (:func:`sparse_neighbour_pairs_bound`); O(N) memory either way."""
    n = len(points)
    if n < 2:
        return 0
    cw, ch = _cell_size(half_w, half_h)
    dense = _kn.grid_neighbour_bound(np.ascontiguousarray(points, dtype=np.float32), cw, ch,
                                     8 * n + 1024)
    return int(dense) if dense >= 0 else sparse_neighbour_pairs_bound(points, half_w, half_h)


def _cell_size(half_w: float, half_h: float) -> tuple[float, float]:
    return max(float(half_w) * (1.0 + 1e-6), 1e-3), max(float(half_h) * (1.0 + 1e-6), 1e-3)


def sparse_neighbour_pairs_bound(points: np.ndarray, half_w: float, half_h: float) -> int:
    """:func:`neighbour_pairs_bound` counted on the occupied cells only (sorted cell keys),
    for points spread over far more cells than there are points."""
    n = len(points)
    if n < 2:
        return 0
    cw, ch = _cell_size(half_w, half_h)
    pts = points.astype(np.float64)
    cx = np.floor((pts[:, 0] - pts[:, 0].min()) / cw).astype(np.int64) + 1
    cy = np.floor((pts[:, 1] - pts[:, 1].min()) / ch).astype(np.int64) + 1
    stride = int(cy.max()) + 2  # coordinates within +-2**20 keep cx * stride in int64
    keys, counts = np.unique(cx * stride + cy, return_counts=True)
    around = np.zeros(len(keys), dtype=np.int64)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            other = keys + dx * stride + dy
            pos = np.minimum(np.searchsorted(keys, other), len(keys) - 1)
            around += np.where(keys[pos] == other, counts[pos], 0)
    return int((counts * around).sum()) - n


def _check_neighbour_budget(points: np.ndarray, p: dict) -> None:
    """Refuse point sets whose neighbour lists alone would exceed ``max_interactions``
    entries (many coincident or crowded points), before the kernel allocates them."""
    if len(points) * (len(points) - 1) <= p["max_interactions"]:
        return
    bound = neighbour_pairs_bound(points, p["neighbour_width"] / 2, p["neighbour_height"] / 2)
    if bound > p["max_interactions"]:
        raise BudgetExceededError(
            f"the left points are so crowded that their neighbour lists could hold {bound} "
            f"pairs (an upper bound), more than max_interactions={p['max_interactions']}; "
            "remove duplicate keypoints, shrink neighbour_width/neighbour_height, use fewer "
            "keypoints, or raise max_interactions"
        )


class HopfieldMatcher(Configurable):
    """The 2D Hopfield-network matcher with the interface of ``cv2.DescriptorMatcher``.

    Geometry reaches it as it reaches OpenCV 5's ``LightGlueMatcher``: call
    :meth:`setPairInfo` with the keypoints of both images, then :meth:`match`,
    :meth:`knnMatch` or :meth:`radiusMatch` with their descriptors. Query = left image,
    train = right image; the pair is assumed rectified (``xr = xl - d``). Results are real
    ``cv2.DMatch`` objects with ``distance = 1 / (1 + exp(u))``, ``u`` the neuron's final
    local field (eq. 12's bracket): near 0 for a strongly supported match.

    Parameters are keyword arguments (see ``docs/parameters.md``), each with a
    ``getX``/``setX`` accessor; ``preset="paper"`` gives the paper's section 4 settings.

    Resource budgets: ``max_neurons`` (candidate pairs) and ``max_interactions`` (stored
    interactions, and the neighbour lists they are built from) are checked before the
    network is allocated, raising :class:`~hopmatch.errors.BudgetExceededError`.

    Threads: ``match``/``knnMatch``/``radiusMatch``/``run`` read the pair information
    once and keep everything else local, so threads may share one matcher as long as none
    of them calls ``setPairInfo``, ``setFundamentalMatrix`` or a parameter setter
    meanwhile; ``getLastResult()`` is then the result of whichever call finished last.
    Give each thread its own matcher (``clone()``) to match different pairs concurrently.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> left = rng.uniform(20, 80, (60, 2)).astype(np.float32)   # dense: each has neighbours
    >>> right = left - np.float32([8, 0])            # a fronto-parallel plane, d = 8
    >>> desc = rng.normal(size=(60, 49)).astype(np.float32)
    >>> m = HopfieldMatcher.create(max_disparity=16)
    >>> m.setPairInfo(left, right, (200, 200), (200, 200))
    >>> matches = m.match(desc, desc)
    >>> all(d.queryIdx == d.trainIdx for d in matches), len(matches) > 50
    (True, True)
    """

    DEFAULT_NAME = "hopmatch_HopfieldMatcher"
    PARAMS = MATCHER_PARAMS
    PRESETS = PRESETS

    def _check_consistency(self) -> None:
        p = self._params
        if p["max_disparity"] is not None and p["max_disparity"] < p["min_disparity"]:
            raise InvalidArgumentError(
                f"`max_disparity` ({p['max_disparity']}) must not be below `min_disparity` "
                f"({p['min_disparity']}); swap them or leave max_disparity=None (a quarter "
                "of the image width)"
            )

    def __init__(self, **params):
        self._init_params(params)
        self._pair = None
        self._fundamental = None
        self._last: NetworkResult | None = None

    # -- pair information (as LightGlueMatcher) ----------------------------------------
    def setPairInfo(self, queryKpts, trainKpts, queryImageSize=None,  # noqa: N802, N803
                    trainImageSize=None):  # noqa: N803
        """Give the keypoints of the left (query) and right (train) image.

        Parameters
        ----------
        queryKpts, trainKpts : sequence of cv2.KeyPoint or (N, 2) array
            (x, y) positions, in the order of the descriptor rows.
        queryImageSize, trainImageSize : (width, height), optional
            Image sizes, as cv2 gives them; used for the default disparity range.
        """
        q = as_points(queryKpts, "queryKpts")
        t = as_points(trainKpts, "trainKpts")
        check_coordinate_range(q, "queryKpts")
        check_coordinate_range(t, "trainKpts")
        self._pair = (q, t, as_image_size(queryImageSize, "queryImageSize"),
                      as_image_size(trainImageSize, "trainImageSize"))

    def clearPairInfo(self) -> None:  # noqa: N802
        """Forget the pair information (keypoints, image sizes and fundamental matrix)."""
        self._pair = None
        self._fundamental = None

    def setFundamentalMatrix(self, F) -> None:  # noqa: N802, N803
        """Match an unrectified pair: candidates lie within ``max_vertical`` pixels of the
        left point's epipolar line ``F (x, y, 1)`` instead of a horizontal band, and the
        disambiguation measures offsets from that line. ``F`` is 3 x 3 as returned by
        ``cv2.findFundamentalMat`` (``x_r^T F x_l = 0``); None returns to rectified mode."""
        self._fundamental = as_fundamental_matrix(F)

    def getFundamentalMatrix(self):  # noqa: N802
        """The fundamental matrix set by :meth:`setFundamentalMatrix`, or None."""
        return None if self._fundamental is None else self._fundamental.copy()

    # -- matching ------------------------------------------------------------------------
    def run(self, queryDescriptors, trainDescriptors, mask=None,  # noqa: N803
            record_energy: bool = False) -> NetworkResult:
        """Run the network and return everything it computed (:class:`NetworkResult`).

        Warns (:class:`~hopmatch.errors.HopmatchWarning` subclasses) when the images differ
        in size, when the disparity range is wider than the left image, or when the pair
        does not look rectified; see ``docs/robustness.md``.
        """
        return self._run(queryDescriptors, trainDescriptors, mask, record_energy)[0]

    def _run(self, queryDescriptors, trainDescriptors, mask=None,  # noqa: N803
             record_energy: bool = False, trusted: bool = False):
        """:meth:`run`, also returning the pair information it used (read once, so that a
        concurrent ``setPairInfo`` cannot mix two pairs in one call). ``trusted``: the
        descriptors are already float32 C-contiguous finite rows (``match_stereo`` made
        them), so they are not checked again."""
        pair, fundamental = self._pair, self._fundamental
        if pair is None:
            raise PairInfoError(
                "no pair information: call setPairInfo(queryKpts, trainKpts, queryImageSize, "
                "trainImageSize) before matching"
            )
        q_pts, t_pts, q_size, t_size = pair
        if trusted:
            qd, td = queryDescriptors, trainDescriptors
        else:
            qd = as_descriptors(queryDescriptors, "queryDescriptors")
            td = as_descriptors(trainDescriptors, "trainDescriptors")
        if len(qd) != len(q_pts) or len(td) != len(t_pts):
            raise PairInfoError(
                f"descriptor counts ({len(qd)} query, {len(td)} train) disagree with the "
                f"keypoints given to setPairInfo ({len(q_pts)} query, {len(t_pts)} train)"
            )
        if len(qd) and len(td) and (qd.dtype != td.dtype or qd.shape[1] != td.shape[1]):
            raise InvalidArgumentError(
                f"`queryDescriptors` ({qd.dtype}, {qd.shape[1]} columns) and "
                f"`trainDescriptors` ({td.dtype}, {td.shape[1]} columns) must have the same "
                "type and length"
            )
        mask = as_mask(mask, (len(q_pts), len(t_pts)), "mask", of="(n_query, n_train)")
        p = dict(self._params)
        p["max_disparity"] = resolve_max_disparity(p["max_disparity"], q_size, q_pts, t_pts)
        if p["max_disparity"] < p["min_disparity"]:
            raise InvalidArgumentError(
                f"`max_disparity` ({p['max_disparity']}) must not be below `min_disparity` "
                f"({p['min_disparity']})"
            )
        if record_energy and p["max_iterations"] + 1 > MAX_ENERGY_TRACE:
            raise BudgetExceededError(
                f"record_energy=True keeps one float64 per iteration, and max_iterations="
                f"{p['max_iterations']} would need {8 * (p['max_iterations'] + 1) / 2**30:.3g} "
                f"GiB; lower max_iterations to at most {MAX_ENERGY_TRACE - 1} or pass "
                "record_energy=False"
            )
        _check_neighbour_budget(q_pts, p)
        self._warn_geometry(pair, fundamental, qd, td, p)
        result = run_hopfield_network(q_pts, t_pts, qd, td, p, mask=mask,
                                      record_energy=record_energy, fundamental=fundamental)
        if len(result.query_idx) < RECTIFICATION_SUSPICIOUS * min(len(q_pts), len(t_pts)):
            self._warn_unrectified(pair, fundamental, qd, td, p)
        self._last = result
        return result, pair

    def _warn_geometry(self, pair, fundamental, qd, td, p) -> None:
        """The warnings of :meth:`run` (docs/robustness.md, "Warnings")."""
        q_pts, t_pts, q_size, t_size = pair
        if fundamental is None and q_size is not None and t_size is not None \
                and q_size != t_size:
            warnings.warn(
                f"the query image is {q_size[0]} x {q_size[1]} and the train image "
                f"{t_size[0]} x {t_size[1]} (width x height): a rectified pair has images of "
                "one size; rectify the pair first or call setFundamentalMatrix(F)",
                ImageSizeWarning, stacklevel=4)
        if q_size is not None and (p["max_disparity"] >= q_size[0]
                                   or -p["min_disparity"] >= q_size[0]):
            warnings.warn(
                f"the disparity range [{p['min_disparity']:g}, {p['max_disparity']:g}] does "
                f"not fit the left image's width ({q_size[0]} px): disparities beyond it can "
                "never occur and only add candidates; narrow the range (max_disparity)",
                DisparityRangeWarning, stacklevel=4)

    def _warn_unrectified(self, pair, fundamental, qd, td, p) -> None:
        """The unrectified-pair warning of :meth:`run`; it is only looked for when the
        network kept few matches (below :data:`RECTIFICATION_SUSPICIOUS` of the keypoints),
        so rectified pairs do not pay for it."""
        q_pts, t_pts = pair[0], pair[1]
        if fundamental is None and len(qd) and len(td):
            ev = rectification_evidence(q_pts, t_pts, qd, td, p["min_disparity"],
                                        p["max_disparity"], p["max_vertical"])
            if (ev is not None and ev[0] > max(2.0, 2.0 * p["max_vertical"])
                    and ev[2] < RECTIFICATION_MAX_IN_BAND):
                warnings.warn(
                    f"the pair does not look rectified: the clearest look-alikes of "
                    f"{ev[1]} sampled left points lie a median {ev[0]:.1f} px above or below "
                    f"them (max_vertical={p['max_vertical']:g}), so few true matches can be "
                    "found; rectify the pair (hopmatch.stereo.rectify) or call "
                    "setFundamentalMatrix(F)",
                    UnrectifiedPairWarning, stacklevel=4)

    def match(self, queryDescriptors, trainDescriptors, mask=None):  # noqa: N803
        """The network's matches after disambiguation and the left-right check.

        Returns a tuple of ``cv2.DMatch`` (queryIdx = left point, trainIdx = right point),
        ordered by queryIdx.
        """
        res = self._run(queryDescriptors, trainDescriptors, mask)[0]
        return tuple(
            cv2.DMatch(int(q), int(t), float(d))
            for q, t, d in zip(res.query_idx.tolist(), res.train_idx.tolist(),
                               res.distances.tolist())
        )

    def knnMatch(self, queryDescriptors, trainDescriptors, k, mask=None,  # noqa: N802, N803
                 compactResult=False):  # noqa: N803
        """Up to ``k`` matches per query, ranked by the network's evidence.

        Each query's candidates (neurons) come first, by increasing
        ``distance = 1 / (1 + exp(u))``; when it has fewer than ``k``, the list is padded
        with other train points at distance 1.0 (no evidence), as BFMatcher returns ``k``
        matches whenever the train set has them, so the ratio test of OpenCV's tutorial
        works unchanged. With ``compactResult=True`` queries without candidates are left
        out.
        """
        k = _positive_int(k, "k")
        res, pair = self._run(queryDescriptors, trainDescriptors, mask)
        n_train = len(pair[1])
        ranked = self._ranked_candidates(res, len(pair[0]))
        out = []
        for qi, (cands, dists) in enumerate(ranked):
            if compactResult and not cands:
                continue
            row = [cv2.DMatch(qi, t, d) for t, d in zip(cands[:k], dists[:k])]
            if len(row) < k and not compactResult:
                taken = set(cands[:k])
                allowed = (range(n_train) if mask is None
                           else np.flatnonzero(np.asarray(mask)[qi]).tolist())
                for t in allowed:
                    if len(row) >= k:
                        break
                    if t not in taken:
                        row.append(cv2.DMatch(qi, int(t), 1.0))
            out.append(row)
        return out

    def radiusMatch(self, queryDescriptors, trainDescriptors, maxDistance,  # noqa: N802, N803
                    mask=None, compactResult=False):  # noqa: N803
        """Every candidate with ``distance <= maxDistance``, per query, best first."""
        if isinstance(maxDistance, bool) or not isinstance(maxDistance, (int, float, np.number)):
            raise InvalidTypeError(f"`maxDistance` must be a number, got {maxDistance!r}")
        if maxDistance != maxDistance:
            raise InvalidArgumentError(
                "`maxDistance` must be a number (distances lie in [0, 1]), got NaN"
            )
        res, pair = self._run(queryDescriptors, trainDescriptors, mask)
        out = []
        for qi, (cands, dists) in enumerate(self._ranked_candidates(res, len(pair[0]))):
            row = [cv2.DMatch(qi, t, d) for t, d in zip(cands, dists) if d <= maxDistance]
            if row or not compactResult:
                out.append(row)
        return out

    @staticmethod
    def _ranked_candidates(res: NetworkResult, n_query: int):
        with np.errstate(over="ignore"):
            dist = 1.0 / (1.0 + np.exp(res.fields))
        order = np.lexsort((res.neuron_right, dist, res.neuron_left))
        left = res.neuron_left[order]
        bounds = np.searchsorted(left, np.arange(n_query + 1))
        right, dist = res.neuron_right[order].tolist(), dist[order].tolist()
        return [(right[a:b], dist[a:b]) for a, b in zip(bounds[:-1], bounds[1:])]

    # -- energy and last result --------------------------------------------------------
    def getLastResult(self) -> NetworkResult | None:  # noqa: N802
        """The :class:`NetworkResult` of the last match, or None."""
        return self._last

    def energy(self) -> float:
        """Energy (eq. 11) of the last converged state, with the final input bias."""
        if self._last is None:
            raise PairInfoError("energy() needs a network: call match() first")
        return self._last.energy

    # -- cv2.DescriptorMatcher housekeeping --------------------------------------------
    def isMaskSupported(self) -> bool:  # noqa: N802
        """True: ``mask[i, k] == 0`` forbids the neuron (i, k)."""
        return True

    def empty(self) -> bool:
        """True while no pair information is set."""
        return self._pair is None

    def clear(self) -> None:
        """Forget the pair information and the last result."""
        self.clearPairInfo()
        self._last = None

    def clone(self, emptyTrainData=False):  # noqa: N803
        """A copy with the same parameters (and pair information unless ``emptyTrainData``)."""
        other = type(self)(**self._params)
        if not emptyTrainData and self._pair is not None:
            other._pair = copy.deepcopy(self._pair)
            other._fundamental = self.getFundamentalMatrix()
        return other

    def __getstate__(self):
        return {"params": dict(self._params)}

    def __setstate__(self, state):
        self._init_params(_state_params(self, state))
        self._pair = None
        self._fundamental = None
        self._last = None


def as_fundamental_matrix(F):
    """Validate a fundamental matrix: None, or a finite 3 x 3 array (returned as float64)."""
    if F is None:
        return None
    if not isinstance(F, np.ndarray):
        raise InvalidTypeError(f"`F` must be a 3 x 3 numpy array or None, got {type(F).__name__}")
    if F.dtype == np.bool_ or not np.issubdtype(F.dtype, np.number):
        raise InvalidTypeError(f"`F` must hold numbers, got dtype {F.dtype}")
    if F.shape != (3, 3):
        raise InvalidArgumentError(
            f"`F` must have shape (3, 3), got {F.shape}; cv2.findFundamentalMat may return "
            "several stacked solutions (9 x 3) for FM_7POINT: pick one"
        )
    F = np.ascontiguousarray(F, dtype=np.float64)
    if not np.isfinite(F).all() or not F.any():
        raise InvalidArgumentError("`F` must be finite and not all zero")
    return F


def _positive_int(value, name):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise InvalidTypeError(f"`{name}` must be a positive integer, got {value!r}")
    if value < 1:
        raise InvalidArgumentError(f"`{name}` must be a positive integer, got {value}")
    return int(value)


def hopfield_match(left_pts, right_pts, left_desc, right_desc, *, image_size=None, mask=None,
                   fundamental_matrix=None, record_energy: bool = False,
                   **params) -> NetworkResult:
    """Match two keypoint sets with the Hopfield network (the function behind
    :class:`HopfieldMatcher`).

    Parameters
    ----------
    left_pts, right_pts : (N, 2) float32 ndarray or sequence of cv2.KeyPoint
        (x, y) positions of the left (query) and right (train) points.
    left_desc, right_desc : (N, D) float32 or uint8 ndarray
        Their descriptors, one row per point.
    image_size : (width, height), optional
        Left image size (for the default disparity range).
    mask : (Nl, Nr) uint8 or bool ndarray, optional
        Zero forbids a pair.
    fundamental_matrix : (3, 3) ndarray, optional
        For an unrectified pair (see :meth:`HopfieldMatcher.setFundamentalMatrix`).
    record_energy : bool
        Keep the energy after every iteration in ``energy_trace``.
    **params
        Any :class:`HopfieldMatcher` parameter.

    Returns
    -------
    NetworkResult
    """
    matcher = HopfieldMatcher(**params)
    matcher.setPairInfo(left_pts, right_pts, image_size, None)
    matcher.setFundamentalMatrix(fundamental_matrix)
    return matcher.run(left_desc, right_desc, mask, record_energy=record_energy)
