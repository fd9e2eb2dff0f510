"""The cv2 DescriptorMatcher-like HopfieldMatcher: parameters and pair information around
:func:`~hopmatch.matching.network.match_pair`."""

from __future__ import annotations

import copy
import threading

import cv2
import numpy as np

from .._interrupts import keeps_interrupts
from .._params import Configurable, state_params

# The imports marked "noqa: F401" re-export names that lived in this module before the
# matching layer was split, so they stay importable from here.
from .._validate import (
    as_descriptors,
    as_flag,
    as_fundamental_matrix,  # noqa: E402, F401
    as_int,
)
from .._warnings import warn
from ..errors import (
    ConcurrentPairInfoError,
    InvalidArgumentError,
    InvalidTypeError,
    PairInfoError,
)
from .budget import (  # noqa: E402, F401
    MAX_ENERGY_TRACE,
    neighbour_pairs_bound,
    sparse_neighbour_pairs_bound,
)
from .candidates import resolve_max_disparity  # noqa: E402, F401
from .diagnostics import (  # noqa: E402, F401
    RECTIFICATION_MAX_IN_BAND,
    RECTIFICATION_MAX_PAIRS,
    RECTIFICATION_MIN_EVIDENCE,
    RECTIFICATION_RATIO,
    RECTIFICATION_SAMPLE,
    RECTIFICATION_SUSPICIOUS,
    rectification_evidence,
)
from .geometry import EpipolarGeometry, GeometryWarning, estimate_geometry_of_points
from .network import NetworkResult, PairInfo, hopfield_match, match_pair
from .params import MATCHER_PARAMS, PRESETS, MatcherConfig, check_disparity_order
from .similarity import match_distance

__all__ = ["HopfieldMatcher", "dmatch_rows", "dmatches", "hopfield_match", "knn_rows",
           "radius_rows", "ranked_neurons"]


def _is_number(value) -> bool:
    """A real number (not a bool, not an array): cv2's ``knnMatch(query, k)`` and
    ``radiusMatch(query, maxDistance)`` forms give one where the train descriptors go."""
    return isinstance(value, (int, float, np.integer, np.floating)) \
        and not isinstance(value, (bool, np.bool_))


def dmatches(query_idx, train_idx, distances) -> tuple:
    """A tuple of ``cv2.DMatch(query_idx[m], train_idx[m], distances[m])`` with imgIdx 0,
    the one train image, as ``cv2.BFMatcher`` gives it (set after construction: the
    four-argument constructor costs five times the three-argument one, its overload
    tried second).

    Built in bulk: ``cv2.DMatch`` called from C (``map``) on flat lists, about half the
    time of a generator that calls it per match.
    """
    matches = tuple(map(cv2.DMatch, np.asarray(query_idx).tolist(),
                        np.asarray(train_idx).tolist(), np.asarray(distances).tolist()))
    for m in matches:
        m.imgIdx = 0
    return matches


def ranked_neurons(res: NetworkResult):
    """``(left, right, distance)`` of every neuron, int64, int64 and float64, ordered by
    left point, then by increasing distance
    (:func:`~hopmatch.matching.similarity.match_distance`), ties by train index."""
    dist = match_distance(res.fields)
    order = np.lexsort((res.neuron_right, dist, res.neuron_left))
    return (res.neuron_left[order].astype(np.int64), res.neuron_right[order].astype(np.int64),
            np.asarray(dist, dtype=np.float64)[order])


def dmatch_rows(query, train, dist, n_query: int, keep_empty: bool) -> list:
    """One list of ``cv2.DMatch`` (imgIdx 0) per query ``0..n_query - 1`` from the entries
    ``(query, train, dist)`` sorted by query (each row in the entries' order); the queries
    without an entry give ``[]``, or no row unless ``keep_empty``. The DMatch objects are
    made in one bulk call (:func:`dmatches`)."""
    flat = dmatches(query, train, dist)
    bounds = np.searchsorted(np.asarray(query), np.arange(n_query + 1))
    return [list(flat[a:b]) for a, b in zip(bounds[:-1].tolist(), bounds[1:].tolist())
            if keep_empty or b > a]


def knn_rows(res: NetworkResult, n_query: int, n_train: int, k: int, mask=None,
             compact: bool = False) -> list:
    """``knnMatch``'s rows: each query's first ``k`` candidates by increasing distance
    (:func:`ranked_neurons`), then, unless ``compact``, as many of the lowest train indices
    not among them (allowed by ``mask``, an ``(n_query, n_train)`` array, when given) at
    distance 1.0 as make ``k`` (fewer when the train set runs out); with ``compact`` the
    queries without a candidate give no row.

    Built with array operations: the candidates' ranks within their query, and for the
    queries short of ``k``, their first ``k`` allowed train indices (at most ``k - 1`` of
    which are candidates), of which the ones not taken are the padding."""
    left, right, dist = ranked_neurons(res)
    start = np.searchsorted(left, np.arange(n_query + 1))
    rank = np.arange(len(left), dtype=np.int64) - start[left]
    top = rank < k
    left, right, dist, rank = left[top], right[top], dist[top], rank[top]
    count = np.minimum(np.diff(start), k)
    short = np.flatnonzero(count < k) if not compact else np.zeros(0, np.int64)
    width = int(min(k, n_train))
    if len(short) == 0 or width == 0:
        return dmatch_rows(left, right, dist, n_query, keep_empty=not compact)
    # the first `width` allowed train indices of each short row (n_train where fewer)
    if mask is None:
        pool = np.broadcast_to(np.arange(width, dtype=np.int64), (len(short), width)).copy()
    else:
        allowed = np.asarray(mask)[short] != 0
        pool = np.full((len(short), width), n_train, dtype=np.int64)
        for r, row in enumerate(allowed):
            first = np.flatnonzero(row)[:width]
            pool[r, :len(first)] = first
    # their candidates (fewer than k each) are taken: marked n_train, sorted to the end
    row_of = np.full(n_query, -1, dtype=np.int64)
    row_of[short] = np.arange(len(short))
    mine = row_of[left] >= 0
    # each row's pool is increasing: find a candidate in it by one search over all rows,
    # keyed row * (n_train + 1) + index (the fill value n_train stays within its row)
    keys = (np.arange(len(short), dtype=np.int64)[:, None] * (n_train + 1) + pool).ravel()
    wanted = row_of[left[mine]] * (n_train + 1) + right[mine]
    at = np.minimum(np.searchsorted(keys, wanted), len(keys) - 1)
    pool.ravel()[at[keys[at] == wanted]] = n_train
    pool.sort(axis=1)
    need = k - count[short]
    pick = (np.arange(width)[None, :] < need[:, None]) & (pool < n_train)
    rows, cols = np.nonzero(pick)
    query = np.concatenate((left, short[rows]))
    order = np.lexsort((np.concatenate((rank, count[short][rows] + cols)), query))
    return dmatch_rows(query[order], np.concatenate((right, pool[rows, cols]))[order],
                       np.concatenate((dist, np.ones(len(rows))))[order], n_query,
                       keep_empty=True)


def radius_rows(res: NetworkResult, n_query: int, max_distance: float,
                compact: bool = False) -> list:
    """``radiusMatch``'s rows: each query's candidates with distance at most
    ``max_distance``, by increasing distance (:func:`ranked_neurons`); with ``compact`` the
    queries without one give no row."""
    left, right, dist = ranked_neurons(res)
    near = dist <= max_distance
    return dmatch_rows(left[near], right[near], dist[near], n_query, keep_empty=not compact)


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

    The steps after the network that need the images, the guided second pass
    (``guided``) and the sub-pixel refinement (``refine``), do not run in :meth:`match`,
    which sees descriptors only. To get them with this matcher's parameters, pass it to
    :func:`~hopmatch.match_stereo` with the images: ``res = match_stereo(left, right,
    matcher=m)``; ``res.matches`` (cv2.DMatch), ``res.keypoints_left`` and
    ``res.keypoints_right`` (the detected right keypoints, then one per guided match at its
    sub-pixel position) then work with ``cv2.drawMatches`` and ``cv2.triangulatePoints``
    as the network's matches do, and ``res.passes`` says which pass found each match.

    Resource budgets: ``max_neurons`` (candidate pairs) and ``max_interactions`` (stored
    interactions, and the neighbour lists they are built from) are checked before the
    network is allocated, raising :class:`~hopmatch.errors.BudgetExceededError`.

    Threads: ``match``/``knnMatch``/``radiusMatch``/``run`` read the pair information
    once and keep everything else local, so threads may share one matcher as long as none
    of them calls ``setPairInfo``, ``setFundamentalMatrix`` or a parameter setter
    meanwhile; ``getLastResult()`` is then the result of whichever call finished last.
    Give each thread its own matcher (``clone()``) to match different pairs concurrently.
    Misuse is detected rather than answered with another pair's matches: every change of
    the pair information counts a generation, and a match raises
    :class:`~hopmatch.errors.ConcurrentPairInfoError` when the pair it would use was set
    by another thread after this thread's own ``setPairInfo``, or when the generation
    changed while it ran.

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
        check_disparity_order(self._params["min_disparity"], self._params["max_disparity"])

    def __init__(self, **params):
        self._init_params(params)
        self._init_pair_state()
        self._last: NetworkResult | None = None

    def _init_pair_state(self) -> None:
        """No pair information; generation 0 (see :meth:`_set_pair_state`)."""
        self._pair = None
        self._fundamental = None
        self._train = None  # the descriptors add() gave: one train image's, or None
        self._pair_lock = threading.Lock()
        self._generation = 0
        self._set_here = threading.local()  # .generation: what this thread's last set made

    def _set_pair_state(self, **fields) -> None:
        """Change the pair information (``_pair``, ``_fundamental``) as one step: a new
        generation, remembered as this thread's own."""
        with self._pair_lock:
            for key, value in fields.items():
                setattr(self, key, value)
            self._generation += 1
            self._set_here.generation = self._generation

    def _pair_state(self):
        """``(pair, fundamental, generation)`` read together; raises
        :class:`ConcurrentPairInfoError` when this thread set the pair information and
        another thread has replaced it since."""
        with self._pair_lock:
            pair, fundamental, generation = self._pair, self._fundamental, self._generation
        mine = getattr(self._set_here, "generation", None)
        if mine is not None and mine != generation:
            raise ConcurrentPairInfoError(
                "another thread replaced the pair information this thread gave with "
                "setPairInfo/setFundamentalMatrix, so these descriptors would be matched "
                "against its keypoints; HopfieldMatcher is not safe for concurrent "
                "setPairInfo: give each thread its own matcher "
                "(matcher.clone(emptyTrainData=True))")
        return pair, fundamental, generation

    # -- pair information (as LightGlueMatcher) ----------------------------------------
    @keeps_interrupts
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
        self._set_pair_state(_pair=PairInfo.of(queryKpts, trainKpts, queryImageSize,
                                               trainImageSize))

    def clearPairInfo(self) -> None:  # noqa: N802
        """Forget the pair information (keypoints, image sizes and fundamental matrix)."""
        self._set_pair_state(_pair=None, _fundamental=None)

    def setFundamentalMatrix(self, F) -> None:  # noqa: N802, N803
        """Match an unrectified pair: candidates lie within ``max_vertical`` pixels of the
        left point's epipolar line ``F (x, y, 1)`` instead of a horizontal band, and the
        disambiguation measures offsets from that line. ``F`` is 3 x 3 as returned by
        ``cv2.findFundamentalMat`` (``x_r^T F x_l = 0``); None returns to rectified mode."""
        self._set_pair_state(_fundamental=as_fundamental_matrix(F, optional=True))

    @keeps_interrupts
    def estimateFundamentalMatrix(self, queryDescriptors,  # noqa: N802, N803
                                  trainDescriptors) -> EpipolarGeometry:  # noqa: N803
        """Estimate the epipolar geometry of the pair from the pair information and these
        descriptors, and match along it from now on (:meth:`setFundamentalMatrix`).

        For an unrectified pair whose F nobody gave (two photos): a thinned set of the
        query points is compared, by the network's similarity (eqs. 7-9) and a ratio test,
        with the train points of a two-dimensional window (a quarter of the width either
        way, 12 % of the height up and down); ``cv2.findFundamentalMat`` with
        ``cv2.USAC_MAGSAC`` fits F to those correspondences
        (``hopmatch.matching.geometry``). ``match_stereo(left, right, rectified=False)``,
        which sees the images, does more (SIFT correspondences, the right image aligned
        with the left one; docs/pipelines.md).

        Returns
        -------
        EpipolarGeometry
            ``fundamental`` (also set on the matcher), the correspondences and their
            ``inliers``. When the correspondences support no F (too few, or too few
            agreeing, or no more than agree by chance: images without texture, or of
            different scenes), ``fundamental`` is None, ``reason`` says why, a
            :class:`~hopmatch.errors.GeometryWarning` is issued and the matcher's
            fundamental matrix is left as it was.

        Examples
        --------
        >>> import cv2
        >>> matcher = HopfieldMatcher.create()
        >>> matcher.setPairInfo(kp_left, kp_right, size_left, size_right)  # doctest: +SKIP
        >>> geometry = matcher.estimateFundamentalMatrix(des_left, des_right)  # doctest: +SKIP
        >>> matches = matcher.knnMatch(des_left, des_right, k=2)  # doctest: +SKIP
        """
        pair = self._pair
        if pair is None:
            raise PairInfoError(
                "no pair information: call setPairInfo(queryKpts, trainKpts, queryImageSize, "
                "trainImageSize) before estimateFundamentalMatrix"
            )
        qd = as_descriptors(queryDescriptors, "queryDescriptors")
        td = as_descriptors(trainDescriptors, "trainDescriptors")
        if len(qd) != len(pair.query_points) or len(td) != len(pair.train_points):
            raise PairInfoError(
                f"descriptor counts ({len(qd)} query, {len(td)} train) disagree with the "
                f"keypoints given to setPairInfo ({len(pair.query_points)} query, "
                f"{len(pair.train_points)} train)"
            )
        geometry = estimate_geometry_of_points(pair.query_points, pair.train_points, qd, td,
                                               pair.query_size)
        if geometry.fundamental is None:
            warn(f"estimateFundamentalMatrix found no epipolar geometry: {geometry.reason}; "
                 "the matcher's fundamental matrix is unchanged", GeometryWarning)
        else:
            self.setFundamentalMatrix(geometry.fundamental)
        return geometry

    def getFundamentalMatrix(self):  # noqa: N802
        """The fundamental matrix set by :meth:`setFundamentalMatrix`, or None."""
        return None if self._fundamental is None else self._fundamental.copy()

    # -- matching ------------------------------------------------------------------------
    # -- the train collection (as cv2.DescriptorMatcher's) -------------------------------
    def add(self, descriptors) -> None:
        """Add the train (right) image's descriptors, as ``cv2.DescriptorMatcher.add``:
        a list holding one descriptor array (or the array itself). ``match(des1)``,
        ``knnMatch(des1, k)`` and ``radiusMatch(des1, maxDistance)`` then match against
        them (the keypoints still come from :meth:`setPairInfo`).

        The network matches one stereo pair, so the collection holds one train image:
        adding a second raises :class:`~hopmatch.errors.InvalidArgumentError` (call
        :meth:`clear` first). The array is copied."""
        if isinstance(descriptors, (list, tuple)):
            if len(descriptors) != 1:
                raise InvalidArgumentError(
                    f"`descriptors`: HopfieldMatcher matches one stereo pair, so add() takes "
                    f"the descriptors of one train image (a list of one array), got a list of "
                    f"{len(descriptors)}", argument="descriptors")
            descriptors = descriptors[0]
        desc = np.array(as_descriptors(descriptors, "descriptors"))  # a copy
        if self._train is not None:
            raise InvalidArgumentError(
                "`descriptors`: the train collection already holds one image's descriptors "
                f"({len(self._train)} rows); HopfieldMatcher matches one stereo pair: call "
                "clear() before adding another", argument="descriptors")
        self._train = desc

    def getTrainDescriptors(self) -> list:  # noqa: N802
        """The train collection, as ``cv2.DescriptorMatcher.getTrainDescriptors``: a list
        of zero or one descriptor arrays (:meth:`add`)."""
        return [] if self._train is None else [self._train]

    def train(self) -> None:
        """``cv2.DescriptorMatcher.train``: nothing to train (the network is built per
        match)."""

    def _train_descriptors(self, trainDescriptors):  # noqa: N803
        """``trainDescriptors``, or the collection's when None (:meth:`add`)."""
        if trainDescriptors is not None:
            return trainDescriptors
        if self._train is None:
            raise PairInfoError(
                "no train descriptors: pass them (match(queryDescriptors, trainDescriptors)) "
                "or add them first (matcher.add([trainDescriptors]))")
        return self._train

    def config(self) -> MatcherConfig:
        """The parameters as a frozen :data:`~hopmatch.matching.params.MatcherConfig`."""
        return MatcherConfig(**self._params)

    @keeps_interrupts
    def run(self, queryDescriptors, trainDescriptors=None, mask=None,  # noqa: N803
            record_energy: bool = False) -> NetworkResult:
        """Run the network and return everything it computed (:class:`NetworkResult`).
        ``trainDescriptors`` None: those of the train collection (:meth:`add`).

        Warns (:class:`~hopmatch.errors.HopmatchWarning` subclasses) when the images differ
        in size, when the disparity range is wider than the left image, or when the pair
        does not look rectified; see ``docs/robustness.md``.
        """
        return self._run(queryDescriptors, trainDescriptors, mask, record_energy)[0]

    def _run(self, queryDescriptors, trainDescriptors, mask=None,  # noqa: N803
             record_energy: bool = False):
        """:meth:`run`, also returning the pair information it used (read once, so that a
        concurrent ``setPairInfo`` cannot mix two pairs in one call, and checked again at
        the end: :class:`ConcurrentPairInfoError` if it changed meanwhile)."""
        trainDescriptors = self._train_descriptors(trainDescriptors)  # noqa: N806
        pair, fundamental, generation = self._pair_state()
        if pair is None:
            raise PairInfoError(
                "no pair information: call setPairInfo(queryKpts, trainKpts, queryImageSize, "
                "trainImageSize) before matching"
            )
        result = match_pair(pair, queryDescriptors, trainDescriptors, self.config(),
                            mask=mask, fundamental=fundamental, record_energy=record_energy)
        if self._generation != generation:
            raise ConcurrentPairInfoError(
                "the pair information changed while this match ran (setPairInfo, "
                "setFundamentalMatrix or clearPairInfo from another thread); its matches "
                "may not be of the keypoints the caller meant, so none are returned: give "
                "each thread its own matcher (matcher.clone(emptyTrainData=True))")
        self._last = result
        return result, pair

    @keeps_interrupts
    def match(self, queryDescriptors, trainDescriptors=None, mask=None):  # noqa: N803
        """The network's matches after disambiguation and the left-right check.

        Returns a tuple of ``cv2.DMatch`` (queryIdx = left point, trainIdx = right point),
        ordered by queryIdx. ``trainDescriptors`` None: those of the train collection
        (:meth:`add`), as cv2's ``match(queryDescriptors)``. ``imgIdx`` is 0 (the one
        train image), as ``cv2.BFMatcher`` gives it in both forms.
        """
        res = self._run(queryDescriptors, trainDescriptors, mask)[0]
        return dmatches(res.query_idx, res.train_idx, res.distances)

    @keeps_interrupts
    def knnMatch(self, queryDescriptors, trainDescriptors=None, k=None,  # noqa: N802, N803
                 mask=None, compactResult=False):  # noqa: N803
        """Up to ``k`` matches per query, ranked by the network's evidence.

        As in cv2, ``knnMatch(queryDescriptors, k)`` (a number second) matches against
        the train collection (:meth:`add`).

        Each query's candidates (neurons) come first, by increasing
        ``distance = 1 / (1 + exp(u))``; when it has fewer than ``k``, the list is padded
        with other train points at distance 1.0 (no evidence), as BFMatcher returns ``k``
        matches whenever the train set has them, so the ratio test of OpenCV's tutorial
        works unchanged. With ``compactResult=True`` queries without candidates are left
        out.
        """
        if k is None and _is_number(trainDescriptors):  # cv2's knnMatch(query, k)
            trainDescriptors, k = None, trainDescriptors  # noqa: N806
        if k is None:
            raise InvalidTypeError("knnMatch() needs `k`, the number of matches per query")
        k = as_int(k, "k", lo=1)
        compact = as_flag(compactResult, "compactResult")
        res, pair = self._run(queryDescriptors, trainDescriptors, mask)
        return knn_rows(res, len(pair.query_points), len(pair.train_points), k, mask,
                        compact)

    @keeps_interrupts
    def radiusMatch(self, queryDescriptors, trainDescriptors=None,  # noqa: N802, N803
                    maxDistance=None, mask=None, compactResult=False):  # noqa: N803
        """Every candidate with ``distance <= maxDistance``, per query, best first.
        As in cv2, ``radiusMatch(queryDescriptors, maxDistance)`` (a number second)
        matches against the train collection (:meth:`add`)."""
        if maxDistance is None and _is_number(trainDescriptors):  # cv2's 2-argument form
            trainDescriptors, maxDistance = None, trainDescriptors  # noqa: N806
        if maxDistance is None:
            raise InvalidTypeError("radiusMatch() needs `maxDistance`, a number in [0, 1]")
        if isinstance(maxDistance, bool) or not isinstance(maxDistance, (int, float, np.number)):
            raise InvalidTypeError(f"`maxDistance` must be a number, got {maxDistance!r}")
        if maxDistance != maxDistance:
            raise InvalidArgumentError(
                "`maxDistance` must be a number (distances lie in [0, 1]), got NaN"
            )
        compact = as_flag(compactResult, "compactResult")
        res, pair = self._run(queryDescriptors, trainDescriptors, mask)
        return radius_rows(res, len(pair.query_points), float(maxDistance), compact)

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
        """True while neither pair information nor train descriptors (:meth:`add`) are
        set."""
        return self._pair is None and self._train is None

    def clear(self) -> None:
        """Forget the pair information, the train collection and the last result."""
        self.clearPairInfo()
        self._train = None
        self._last = None

    def clone(self, emptyTrainData=False):  # noqa: N803
        """A copy with the same parameters (and pair information and train collection
        unless ``emptyTrainData``)."""
        other = type(self)(**self._params)
        if not emptyTrainData:
            if self._pair is not None:
                other._pair = copy.deepcopy(self._pair)
                other._fundamental = self.getFundamentalMatrix()
                other._generation = 1
            if self._train is not None:
                other._train = self._train.copy()
        return other

    def __getstate__(self):
        return {"params": dict(self._params)}

    def __setstate__(self, state):
        self._init_params(state_params(self, state))
        self._init_pair_state()
        self._last = None
