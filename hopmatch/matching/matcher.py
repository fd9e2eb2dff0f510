"""The cv2 DescriptorMatcher-like HopfieldMatcher."""

from __future__ import annotations

import copy

import cv2
import numpy as np

from .._params import Configurable
from .._validate import as_descriptors, as_image_size, as_points
from ..errors import InvalidArgumentError, InvalidTypeError, PairInfoError
from .network import NetworkResult, run_hopfield_network
from .params import MATCHER_PARAMS, PRESETS


def resolve_max_disparity(max_disparity, query_size, query_pts, train_pts) -> float:
    """``max_disparity``, or when it is None a quarter of the query image's width (or of the
    keypoints' horizontal extent when the image size is unknown)."""
    if max_disparity is not None:
        return float(max_disparity)
    if query_size is not None:
        return 0.25 * query_size[0]
    xs = [pts[:, 0].max() for pts in (query_pts, train_pts) if len(pts)]
    return 0.25 * (float(max(xs)) + 1.0) if xs else 0.0


def _check_mask(mask, shape):
    if mask is None:
        return None
    if not isinstance(mask, np.ndarray):
        raise InvalidTypeError(f"`mask` must be a numpy array or None, got {type(mask).__name__}")
    if mask.dtype not in (np.uint8, np.bool_):
        raise InvalidTypeError(f"`mask` must have dtype uint8 or bool, got {mask.dtype}")
    if mask.shape != shape:
        raise InvalidArgumentError(
            f"`mask` must have shape (n_query, n_train) = {shape}, got {mask.shape}"
        )
    return np.ascontiguousarray(mask != 0)


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

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> left = rng.uniform(20, 180, (60, 2)).astype(np.float32)
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
        """Run the network and return everything it computed (:class:`NetworkResult`)."""
        if self._pair is None:
            raise PairInfoError(
                "no pair information: call setPairInfo(queryKpts, trainKpts, queryImageSize, "
                "trainImageSize) before matching"
            )
        q_pts, t_pts, q_size, _ = self._pair
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
        mask = _check_mask(mask, (len(q_pts), len(t_pts)))
        p = dict(self._params)
        p["max_disparity"] = resolve_max_disparity(p["max_disparity"], q_size, q_pts, t_pts)
        if p["max_disparity"] < p["min_disparity"]:
            raise InvalidArgumentError(
                f"`max_disparity` ({p['max_disparity']}) must not be below `min_disparity` "
                f"({p['min_disparity']})"
            )
        self._last = run_hopfield_network(q_pts, t_pts, qd, td, p, mask=mask,
                                          record_energy=record_energy,
                                          fundamental=self._fundamental)
        return self._last

    def match(self, queryDescriptors, trainDescriptors, mask=None):  # noqa: N803
        """The network's matches after disambiguation and the left-right check.

        Returns a tuple of ``cv2.DMatch`` (queryIdx = left point, trainIdx = right point),
        ordered by queryIdx.
        """
        res = self.run(queryDescriptors, trainDescriptors, mask)
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
        res = self.run(queryDescriptors, trainDescriptors, mask)
        n_train = len(self._pair[1])
        ranked = self._ranked_candidates(res)
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
        res = self.run(queryDescriptors, trainDescriptors, mask)
        out = []
        for qi, (cands, dists) in enumerate(self._ranked_candidates(res)):
            row = [cv2.DMatch(qi, t, d) for t, d in zip(cands, dists) if d <= maxDistance]
            if row or not compactResult:
                out.append(row)
        return out

    def _ranked_candidates(self, res: NetworkResult):
        n_query = len(self._pair[0])
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
        self._init_params(state["params"])
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
