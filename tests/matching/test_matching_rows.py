"""knnMatch's and radiusMatch's rows, built with array operations
(:func:`hopmatch.matching.matcher.knn_rows`, :func:`~hopmatch.matching.matcher.radius_rows`),
against a row-by-row reference: the loops the matcher ran before."""

from __future__ import annotations

from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from hopmatch.matching.matcher import knn_rows, radius_rows
from hopmatch.matching.similarity import match_distance


def _candidates(res, n_query):
    """Each query's (train indices, distances), by distance then train index."""
    dist = match_distance(res.fields)
    rows = [[] for _ in range(n_query)]
    for i, t, d in zip(res.neuron_left.tolist(), res.neuron_right.tolist(), dist.tolist()):
        rows[i].append((d, t))
    return [([t for _, t in sorted(r)], [d for d, _ in sorted(r)]) for r in rows]


def knn_reference(res, n_query, n_train, k, mask=None, compact=False):
    out = []
    for qi, (cands, dists) in enumerate(_candidates(res, n_query)):
        if compact and not cands:
            continue
        row = [(qi, t, d) for t, d in zip(cands[:k], dists[:k])]
        if len(row) < k and not compact:
            taken = set(cands[:k])
            allowed = range(n_train) if mask is None else np.flatnonzero(mask[qi]).tolist()
            for t in allowed:
                if len(row) >= k:
                    break
                if t not in taken:
                    row.append((qi, int(t), 1.0))
        out.append(row)
    return out


def radius_reference(res, n_query, max_distance, compact=False):
    out = []
    for qi, (cands, dists) in enumerate(_candidates(res, n_query)):
        row = [(qi, t, d) for t, d in zip(cands, dists) if d <= max_distance]
        if row or not compact:
            out.append(row)
    return out


def _keys(rows):
    for row in rows:
        assert all(isinstance(m, cv2.DMatch) and m.imgIdx == 0 for m in row)
    return [[(m.queryIdx, m.trainIdx, m.distance) for m in row] for row in rows]


def _expected(rows):  # DMatch stores float32 distances
    return [[(q, t, float(np.float32(d))) for q, t, d in row] for row in rows]


def _network(rng, n_query, n_train, n_neurons):
    """A random set of distinct neurons with tied fields (each left point's candidates are
    distinct train points, as the network's are)."""
    pairs = set()
    while len(pairs) < n_neurons:
        pairs.add((int(rng.integers(n_query)), int(rng.integers(n_train))))
    pairs = np.array(sorted(pairs), dtype=np.int32).reshape(-1, 2)
    perm = rng.permutation(len(pairs))
    return SimpleNamespace(neuron_left=pairs[perm, 0], neuron_right=pairs[perm, 1],
                           fields=rng.integers(-3, 4, len(pairs)).astype(np.float64))


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("k", [1, 2, 3, 7])
def test_knn_rows_are_the_reference(seed, k):
    rng = np.random.default_rng(seed)
    n_query, n_train = int(rng.integers(1, 30)), int(rng.integers(1, 12))
    res = _network(rng, n_query, n_train, int(rng.integers(0, n_query * n_train // 2 + 1)))
    mask = rng.random((n_query, n_train)) < 0.6
    for m in (None, mask, mask.astype(np.uint8)):
        for compact in (False, True):
            got = knn_rows(res, n_query, n_train, k, m, compact)
            assert _keys(got) == _expected(knn_reference(res, n_query, n_train, k, m, compact))


@pytest.mark.parametrize("seed", range(6))
def test_radius_rows_are_the_reference(seed):
    rng = np.random.default_rng(seed)
    n_query, n_train = int(rng.integers(1, 30)), int(rng.integers(1, 12))
    res = _network(rng, n_query, n_train, int(rng.integers(0, n_query * n_train // 2 + 1)))
    for max_distance in (-1.0, 0.05, 0.5, 0.9526, 2.0):
        for compact in (False, True):
            assert (_keys(radius_rows(res, n_query, max_distance, compact))
                    == _expected(radius_reference(res, n_query, max_distance, compact)))


def test_rows_without_neurons_or_train_points():
    none = SimpleNamespace(neuron_left=np.zeros(0, np.int32), neuron_right=np.zeros(0, np.int32),
                           fields=np.zeros(0))
    assert knn_rows(none, 3, 0, 2) == [[], [], []]
    assert knn_rows(none, 3, 0, 2, compact=True) == []
    assert _keys(knn_rows(none, 2, 3, 2)) == [[(0, 0, 1.0), (0, 1, 1.0)],
                                              [(1, 0, 1.0), (1, 1, 1.0)]]
    assert knn_rows(none, 0, 5, 2) == [] and radius_rows(none, 2, 1.0) == [[], []]
