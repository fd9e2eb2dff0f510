"""The neighbour-grid kernels (``hopmatch._kernels.neighbours``, SPEC section 4's neighbour
window) against the brute-force lists of ``tests/naive.py``."""

from __future__ import annotations

import naive
import numpy as np
import pytest
from network_problems import make_problem

from hopmatch._kernels import neighbours as _k


class TestNeighbours:
    @pytest.mark.parametrize("seed", range(4))
    def test_transposed_lists_equal_brute_force(self, seed):
        """Any relation (not only a symmetric one), with unused room after the lists."""
        rng = np.random.default_rng(seed)
        n, n_out = int(rng.integers(1, 40)), int(rng.integers(1, 30))
        lists = [sorted(rng.choice(n_out, int(rng.integers(0, n_out + 1)), replace=False))
                 for _ in range(n)]
        offsets = np.r_[0, np.cumsum([len(x) for x in lists])].astype(np.int64)
        indices = np.r_[np.concatenate([np.asarray(x, np.int64) for x in lists] + [[]]),
                        rng.integers(0, n_out, 5)].astype(np.int32)  # room left after them
        off_t, out = _k.transposed_lists(offsets, indices, n_out)
        got = [out[off_t[i]:off_t[i + 1]].tolist() for i in range(n_out)]
        assert got == [[j for j in range(n) if i in lists[j]] for i in range(n_out)]

    @pytest.mark.parametrize("seed", [0, 3])
    @pytest.mark.parametrize("width,height", [(40.0, 20.0), (10.0, 4.0), (0.0, 0.0), (7.0, 3.0),
                                              (1000.0, 2.0), (3.0, 900.0)])
    @pytest.mark.parametrize("n", [1, 60, 600])
    def test_neighbour_lists_equal_brute_force(self, seed, width, height, n):
        pts, _, _, _ = make_problem(seed, max(n, 7), integer=True)
        pts = pts[:n] if n > 1 else pts[:1]
        if n == 1:
            off, idx = _k.neighbour_lists(pts, np.float32(width / 2), np.float32(height / 2))
            assert off.tolist() == [0, 0] and len(idx) == 0
            return
        pts[5] = pts[6]                        # a duplicate point: neighbour at distance 0
        off, idx = _k.neighbour_lists(pts, np.float32(width / 2), np.float32(height / 2))
        want = naive.neighbours(pts, width, height)
        got = [idx[off[i]:off[i + 1]].tolist() for i in range(len(pts))]
        assert got == want
        assert 6 in got[5] and 5 in got[6]
        if width == 40.0:
            assert sum(map(len, want)) > 60
        # among the points with neurons only: the others have, and are in, no list
        rng = np.random.default_rng(seed)
        start = np.r_[0, np.cumsum(rng.integers(0, 3, len(pts)) * (rng.random(len(pts)) < 0.6))]
        has = np.flatnonzero(np.diff(start) > 0)
        off, idx = _k.neighbour_lists_among(pts, start, np.float32(width / 2),
                                            np.float32(height / 2))
        got = [idx[off[i]:off[i + 1]].tolist() for i in range(len(pts))]
        assert got == [[j for j in want[i] if j in has] if i in has else []
                       for i in range(len(pts))]

    @pytest.mark.parametrize("seed", [0, 3])
    @pytest.mark.parametrize("width,height", [(40.0, 20.0), (10.0, 4.0), (0.0, 0.0),
                                              (1000.0, 2.0)])
    @pytest.mark.parametrize("cap", [1, 5, 10**9])
    def test_neighbour_counts_equal_brute_force_up_to_the_cap(self, seed, width, height, cap):
        pts, _, _, _ = make_problem(seed, 300, integer=True)
        pts[5] = pts[6]                        # a duplicate point: neighbour at distance 0
        queries = np.r_[np.arange(0, 300, 7), 5, 6].astype(np.int64)
        got = _k.neighbour_counts(pts, queries, np.float32(width / 2), np.float32(height / 2),
                                  cap)
        want = [min(len(naive.neighbours(pts, width, height)[i]), cap) for i in queries]
        assert got.tolist() == want
        assert got[-1] >= 1 and got[-2] >= 1  # the duplicates count each other
        if width == 40.0 and cap > 100:
            assert max(want) > 5

    def test_neighbour_counts_stop_at_the_cap_on_crowded_points(self):
        """100 000 coincident points: each query counts to the cap and stops."""
        pts = np.zeros((100_000, 2), dtype=np.float32)
        got = _k.neighbour_counts(pts, np.arange(0, 100_000, 1000, dtype=np.int64),
                                  np.float32(20.0), np.float32(10.0), 9)
        assert got.tolist() == [9] * 100
        empty = _k.neighbour_counts(pts[:1], np.zeros(1, dtype=np.int64), np.float32(20.0),
                                    np.float32(10.0), 9)
        assert empty.tolist() == [0]

    @pytest.mark.parametrize("seed", range(6))
    def test_neighbour_pairs_bound_dense_equals_sparse(self, seed):
        """The dense-grid count of the neighbour bound equals the sorted-key count, and
        bounds the brute-force number of ordered neighbour pairs (crowded and spread-out
        points, coincident points included)."""
        from hopmatch.matching.matcher import (
            neighbour_pairs_bound,
            sparse_neighbour_pairs_bound,
        )

        rng = np.random.default_rng(seed)
        n = int(rng.integers(2, 300))
        spread = [5.0, 100.0, 1000.0][seed % 3]
        pts = (rng.random((n, 2)) * spread).astype(np.float32)
        if seed % 2:
            pts[: n // 3] = pts[0]  # coincident points
        half_w, half_h = float(rng.uniform(1, 30)), float(rng.uniform(1, 15))
        dense = neighbour_pairs_bound(pts, half_w, half_h)
        assert dense == sparse_neighbour_pairs_bound(pts, half_w, half_h)
        dx = np.abs(pts[:, None, 0] - pts[None, :, 0]) <= np.float32(half_w)
        dy = np.abs(pts[:, None, 1] - pts[None, :, 1]) <= np.float32(half_h)
        assert (dx & dy).sum() - n <= dense
        assert _k.grid_neighbour_bound(pts, half_w, half_h, 0) == -1  # grid refused


class TestCellSize:
    """``cell_size``: the one rule for the grid of the neighbour lists and of the neighbour
    bound."""

    @pytest.mark.parametrize("half", [0.0, 1e-9, 5e-4, 1e-3, 0.05, 3.3, 10.0, 20.0, 1e6])
    def test_is_the_half_window_a_hair_larger_and_at_least_1e_3(self, half):
        cw, ch = _k.cell_size(half, 2.0 * half)
        assert (cw, ch) == (max(half * (1.0 + 1e-6), 1e-3), max(2.0 * half * (1.0 + 1e-6), 1e-3))
        assert cw >= half and cw >= 1e-3 and isinstance(cw, float)
        # the float32 half-window the kernels receive: the same rule on its float64 value
        h32 = np.float32(half)
        assert _k.cell_size(h32, h32) == _k.cell_size(float(h32), float(h32))
        assert _k.cell_size(h32, h32)[0] >= float(h32)

    @pytest.mark.parametrize("seed", range(4))
    def test_grid_bound_on_those_cells_bounds_the_neighbour_lists(self, seed):
        """On cells of ``cell_size`` of the float32 half-window, the dense-grid bound is at
        least the number of entries ``neighbour_lists`` stores (points on cell edges and
        coincident points included)."""
        rng = np.random.default_rng(seed)
        n = 200
        half_w, half_h = np.float32(rng.choice([0.5, 2.0, 7.5])), np.float32(rng.choice([1, 4]))
        pts = np.round(rng.random((n, 2)) * [40, 30] / half_w) * half_w  # on the cell grid
        pts = pts.astype(np.float32)
        pts[: n // 5] = pts[0]
        off, _ = _k.neighbour_lists(pts, half_w, half_h)
        bound = _k.grid_neighbour_bound(pts, *_k.cell_size(half_w, half_h), 10**7)
        assert 0 < off[-1] <= bound
