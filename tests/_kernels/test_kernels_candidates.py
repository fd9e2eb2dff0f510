"""The candidate-pair kernels (``hopmatch._kernels.candidates``, SPEC section 4's search
window) against the brute-force pairs of ``tests/naive.py``."""

from __future__ import annotations

import os
import warnings

import naive
import numpy as np
import pytest
from network_problems import make_problem

from hopmatch._kernels import candidates as _k
from hopmatch.errors import BudgetExceededError
from hopmatch.matching.candidates import best_two_look_alikes
from hopmatch.matching.network import candidate_pairs


class TestCandidates:
    @pytest.mark.parametrize("seed", [0, 1, 2])
    @pytest.mark.parametrize("dmin,dmax,vmax", [(0.0, 15.0, 2.0), (-10.0, 30.0, 15.0),
                                                (3.0, 7.0, 0.0), (5.0, 5.0, 1.0)])
    def test_equal_brute_force(self, seed, dmin, dmax, vmax):
        # integer coordinates: the limits are hit exactly, so inclusiveness is tested
        left, right, _, _ = make_problem(seed, 40, 35, integer=True)
        ni, nk = candidate_pairs(left, right, dmin, dmax, vmax, 10**6)
        want = naive.candidate_pairs(left, right, dmin, dmax, vmax)
        assert list(zip(ni.tolist(), nk.tolist())) == want
        assert ni.dtype == np.int32 and nk.dtype == np.int32
        d = left[ni, 0] - right[nk, 0]
        assert ((d >= dmin) & (d <= dmax)).all()
        assert (np.abs(left[ni, 1] - right[nk, 1]) <= vmax).all()

    @pytest.mark.parametrize("vmax", [0.0, 1.0, 2.5])
    def test_unsorted_output_is_the_same_pairs_grouped_by_left_point(self, vmax):
        left, right, _, _ = make_problem(5, 60, 70, integer=vmax == 0.0)
        ni, nk = candidate_pairs(left, right, 0.0, 20.0, vmax, 10**6)
        ui, uk = candidate_pairs(left, right, 0.0, 20.0, vmax, 10**6, sort=False)
        assert len(ni) > 20
        assert sorted(zip(ui.tolist(), uk.tolist())) == list(zip(ni.tolist(), nk.tolist()))
        groups = [g for g, first in zip(ui.tolist(), np.r_[True, ui[1:] != ui[:-1]]) if first]
        assert len(groups) == len(set(groups))  # each left point's pairs are contiguous
        rows = np.floor(left[groups, 1])
        assert (np.diff(rows) >= 0).all()  # visited row by row
        values = uk.astype(np.float64) * 10
        gi, gk, gv = _k.group_by_left(ui, uk, values, len(left), False, 0.0)
        assert np.array_equal(gi, ni)
        _k.sort_groups(gi, gk, gv)
        assert np.array_equal(gk, nk) and np.array_equal(gv, nk * 10.0)
        # gated: the same as dropping the pairs above the limit (and NaN) first
        values[::3] = np.nan
        limit = float(np.nanmedian(values))
        gi, gk, gv = _k.group_by_left(ui, uk, values, len(left), True, limit)
        _k.sort_groups(gi, gk, gv)
        keep = values <= limit
        wi, wk, wv = _k.group_by_left(ui[keep], uk[keep], values[keep], len(left), False, 0.0)
        _k.sort_groups(wi, wk, wv)
        assert 0 < len(gi) < len(ui)
        assert np.array_equal(gi, wi) and np.array_equal(gk, wk) and np.array_equal(gv, wv)

    @pytest.mark.parametrize("spread", [False, True])
    def test_row_order_and_band_index_sort_when_rows_spread(self, spread):
        """Rows spread over far more values than there are points are sorted instead of
        counted: the orders, and the pairs, are the same either way."""
        from hopmatch.matching.candidates import left_visit_order, right_band_index

        left, right, _, _ = make_problem(3, 50, 60)
        if spread:
            left[::7, 1] += 1e6
            right[::7, 1] += 1e6
        visit = left_visit_order(left)
        assert np.array_equal(visit, np.argsort(np.floor(left[:, 1]), kind="stable"))
        for limit in (0, 10**7):  # forced sort, forced count
            assert np.array_equal(_k.row_order(left, limit)[0], visit)
        rows, row_start, r_order, rx, ry = right_band_index(right)
        want = sorted(range(len(right)), key=lambda k: (np.floor(right[k, 1]), right[k, 0], k))
        assert r_order.tolist() == want
        assert rows.tolist() == sorted(set(np.floor(right[:, 1]).astype(np.int64).tolist()))
        ni, nk = candidate_pairs(left, right, 0.0, 20.0, 2.0, 10**6)
        assert list(zip(ni.tolist(), nk.tolist())) == naive.candidate_pairs(
            left, right, 0.0, 20.0, 2.0)

    def test_right_points_ordered_by_row_then_x_then_index(self):
        from hopmatch.matching.candidates import right_band_index
        rng = np.random.default_rng(11)
        pts = np.column_stack([rng.choice([-3.5, -0.0, 0.0, 1e-30, 2.25, -1e6, 7.0], 400),
                               rng.choice([-2.5, -0.5, 0.0, 0.75, 3.0], 400)])
        pts = np.concatenate([pts, rng.uniform(-50, 50, (300, 2))]).astype(np.float32)
        rows, row_start, order, rx, ry = right_band_index(pts)
        floor_y = np.floor(pts[:, 1]).astype(np.int64)
        want = sorted(range(len(pts)), key=lambda k: (floor_y[k], float(pts[k, 0]), k))
        # -0.0 and 0.0 are equal as numbers; only the index decides between them
        assert [(floor_y[k], float(pts[k, 0])) for k in order] == \
            [(floor_y[k], float(pts[k, 0])) for k in want]
        assert rows.tolist() == sorted(set(floor_y.tolist()))
        assert all((floor_y[order[row_start[r]:row_start[r + 1]]] == rows[r]).all()
                   for r in range(len(rows)))
        assert np.array_equal(rx, pts[order, 0]) and np.array_equal(ry, pts[order, 1])

    def test_subpixel_rows_at_the_band_edges(self):
        # right points in the rows just outside/inside floor(yl +- vmax)
        left = np.array([[30.0, 10.5]], np.float32)
        right = np.array([[25, 9.49], [25, 9.5], [25, 11.5], [25, 11.51], [25, 10.0],
                          [30.0, 10.5], [9.0, 10.5], [10.0, 10.5]], np.float32)
        ni, nk = candidate_pairs(left, right, 0.0, 20.0, 1.0, 100)
        assert nk.tolist() == [1, 2, 4, 5, 7]
        assert list(zip(ni.tolist(), nk.tolist())) == naive.candidate_pairs(
            left, right, 0.0, 20.0, 1.0)

    @pytest.mark.parametrize("slack", [-1, 0, 1, 5000])
    def test_output_grows_up_to_the_budget_and_no_further(self, slack):
        # many more pairs than the kernel's first allocation (8 per left point + 1024)
        rng = np.random.default_rng(7)
        left = np.column_stack([rng.uniform(400, 500, 20), rng.uniform(0, 3, 20)])
        right = np.column_stack([rng.uniform(0, 500, 3000), rng.uniform(0, 3, 3000)])
        left, right = left.astype(np.float32), right.astype(np.float32)
        want = naive.candidate_pairs(left, right, 0.0, 300.0, 1.0)
        assert len(want) > 8 * 20 + 1024
        budget = len(want) + slack
        if slack < 0:
            with pytest.raises(BudgetExceededError, match=f"would have {len(want)} neurons"):
                candidate_pairs(left, right, 0.0, 300.0, 1.0, budget)
            return
        ni, nk = candidate_pairs(left, right, 0.0, 300.0, 1.0, budget)
        assert list(zip(ni.tolist(), nk.tolist())) == want

    @pytest.mark.parametrize("seed", [0, 1])
    def test_epipolar_band_equals_brute_force_and_keeps_the_budget(self, seed):
        left, right, _, _ = make_problem(seed, 60, 70)
        rng = np.random.default_rng(seed)
        f = np.array([[0, 0, 0.001], [0, 0, -1], [0, 1, 0]]) + rng.normal(0, 1e-3, (3, 3))
        want = naive.epipolar_candidate_pairs(left, right, 0.0, 20.0, 2.0, f)
        assert len(want) > 20
        ni, nk = candidate_pairs(left, right, 0.0, 20.0, 2.0, len(want), f)
        assert list(zip(ni.tolist(), nk.tolist())) == want
        with pytest.raises(BudgetExceededError, match=f"would have {len(want)} neurons"):
            candidate_pairs(left, right, 0.0, 20.0, 2.0, len(want) - 1, f)

    @pytest.mark.parametrize("seed, vmax", [(0, 1.5), (1, 4.0), (2, 40.0), (3, 1e4)])
    def test_epipolar_strips_keep_every_pair_of_slanted_and_steep_lines(self, seed, vmax):
        """The strips of epipolar_candidates on a verged pair (lines slanted by up to about
        a third, and steep or vertical ones for some left points): the same pairs as the
        brute force, and each group in x order (ties by index) before any sort."""
        rng = np.random.default_rng(seed)
        left = np.column_stack([rng.uniform(0, 400, 300), rng.uniform(0, 300, 300)])
        right = np.column_stack([rng.uniform(-20, 420, 500), rng.uniform(-10, 310, 500)])
        right[:40, 0] = np.round(right[:40, 0])  # ties in x
        right[40:60, 0] = right[:20, 0]
        left, right = left.astype(np.float32), right.astype(np.float32)
        # lines through the epipole (e, 150): slanted for x far from e, steep near it
        e = rng.uniform(100, 300)
        f = np.array([[0.0, -1.0, 150.0], [1.0, 0.0, -e], [-150.0, e, 0.0]])
        f = f + rng.normal(0, 1e-4, (3, 3))
        want = naive.epipolar_candidate_pairs(left, right, -30.0, 120.0, vmax, f)
        assert len(want) > 100
        order = np.argsort(right[:, 0], kind="stable")
        ni, nk, n = _k.epipolar_candidates(left, right, order, f,
                                           np.float32(-30.0), np.float32(120.0),
                                           np.float32(vmax), 10**7)
        assert n == len(want) == len(ni)
        assert sorted(zip(ni.tolist(), nk.tolist())) == want
        assert (np.diff(ni) >= 0).all()
        rank = np.empty(len(right), np.int64)
        rank[order] = np.arange(len(right))
        same = np.diff(ni) == 0
        assert (np.diff(rank[nk])[same] > 0).all()
        if len(want) > 10:  # past the budget: the count stops at the first pair beyond it
            budget = len(want) // 2
            ci, ck, cn = _k.epipolar_candidates(left, right, order, f,
                                                np.float32(-30.0), np.float32(120.0),
                                                np.float32(vmax), budget)
            assert cn == budget + 1 and len(ci) == len(ck) == 0

    @pytest.mark.parametrize("max_entries", [1, 40, 10**4])
    def test_row_buckets_bracket_every_x_range(self, max_entries):
        """Every point of a row within [x_lo, x_hi] lies between the table entries of the
        two end buckets, for any budget of entries (one bucket per row at the least) and
        for queries far outside the points."""
        from hopmatch.matching.candidates import right_band_index
        rng = np.random.default_rng(4)
        pts = np.column_stack([np.round(rng.uniform(-40, 60, 300), 1),
                               rng.integers(0, 12, 300)]).astype(np.float32)
        rows, row_start, order, rx, ry = right_band_index(pts)
        table, x0, inv, nb = _k.row_buckets(row_start, rx, max_entries)
        assert nb >= 1 and len(table) == len(rows) * (nb + 1)
        table = table.reshape(len(rows), nb + 1)
        assert (np.diff(table, axis=1) >= 0).all()
        assert (table[:, 0] == row_start[:-1]).all() and (table[:, -1] == row_start[1:]).all()
        queries = [-1e300, -41.0, -40.0, -3.3, 0.0, 12.25, 59.9, 60.0, 75.0, 1e300]
        for x_lo in queries:
            for x_hi in queries:
                if x_hi < x_lo:
                    continue
                b_lo = _k._bucket(x_lo, x0, inv, nb)
                b_hi = _k._bucket(x_hi, x0, inv, nb) + 1
                for r in range(len(rows)):
                    inside = [t for t in range(row_start[r], row_start[r + 1])
                              if x_lo <= float(rx[t]) <= x_hi]
                    assert all(table[r, b_lo] <= t < table[r, b_hi] for t in inside)

    @pytest.mark.parametrize("dmin,dmax", [(0.0, 1e30), (-1e30, 1e30), (-5.0, 2.0)])
    def test_extreme_ranges_and_spans_equal_brute_force(self, dmin, dmax):
        """Disparity limits far beyond the points, a few points far from the others (a wide
        x span, so wide buckets) and many rows give the brute-force pairs."""
        left, right, _, _ = make_problem(2, 70, 80, width=60.0, height=2.0)
        right[:, 1] = np.arange(len(right), dtype=np.float32) * 0.25  # 80 points, 40 rows
        left[:, 1] = np.float32(8.0)
        right[::20, 0] = np.float32([-1e5, 1e5, -3e4, 7e4])
        left[::30, 0] = np.float32([1e5, -1e5, 5e4])
        for l_, r_ in ((left, right), (right, left)):
            ni, nk = candidate_pairs(l_, r_, dmin, dmax, 2.0, 10**6)
            want = naive.candidate_pairs(l_, r_, dmin, dmax, 2.0)
            assert len(want) > 0
            assert list(zip(ni.tolist(), nk.tolist())) == want

    def test_crowded_buckets_equal_brute_force(self):
        """One far-out right point makes the buckets ~1e4 px wide, so all the others crowd
        into one bucket per row, far more than BUCKET_SCAN_MAX: the search narrows them and
        still gives every pair of a narrow band."""
        rng = np.random.default_rng(12)
        right = np.column_stack([rng.uniform(0, 200, 600), rng.integers(0, 3, 600)])
        right[0] = (1e6, 1.0)
        left = np.column_stack([rng.uniform(0, 200, 80), rng.integers(0, 3, 80) + 0.5])
        left, right = left.astype(np.float32), right.astype(np.float32)
        from hopmatch.matching.candidates import right_band_index
        _, row_start, _, rx, _ = right_band_index(right)
        table, _, _, nb = _k.row_buckets(
            row_start, rx, _k.BUCKETS_PER_POINT * len(right) + _k.BUCKET_SLACK)
        assert np.diff(table.reshape(-1, nb + 1), axis=1).max() > _k.BUCKET_SCAN_MAX
        for dmin, dmax in ((0.0, 3.0), (-2.0, 0.5), (0.0, 150.0)):
            ni, nk = candidate_pairs(left, right, dmin, dmax, 1.0, 10**6)
            want = naive.candidate_pairs(left, right, dmin, dmax, 1.0)
            assert len(want) > 0
            assert list(zip(ni.tolist(), nk.tolist())) == want

    def test_limits_are_inclusive(self):
        left = np.array([[20, 10]], np.float32)
        right = np.array([[20, 10], [5, 10], [4, 10], [10, 8], [10, 7.5], [21, 10]], np.float32)
        ni, nk = candidate_pairs(left, right, 0.0, 15.0, 2.0, 100)
        assert nk.tolist() == [0, 1, 3]
        assert naive.candidate_pairs(left, right, 0.0, 15.0, 2.0) == [(0, 0), (0, 1), (0, 3)]

    def test_budget(self):
        left, right, _, _ = make_problem(0, 30)
        n = len(naive.candidate_pairs(left, right, 0.0, 15.0, 3.0))
        assert n > 10
        assert len(candidate_pairs(left, right, 0.0, 15.0, 3.0, n)[0]) == n
        with pytest.raises(BudgetExceededError):
            candidate_pairs(left, right, 0.0, 15.0, 3.0, n - 1)


class TestCountStopsAtTheBudget:
    """Issue 20: past max_neurons the band was still counted to its end (300,000 points
    against 300,000: 9e10 pairs); the count now stops at the first row past the budget."""

    @pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0"),
                        reason="a time limit for the compiled kernels")
    def test_band_and_epipolar_refuse_within_a_second(self):
        import time

        grid = np.stack(np.meshgrid(np.arange(600), np.arange(500)), -1).reshape(-1, 2)
        left = grid.astype(np.float32)
        right = np.full_like(left, 300.0)
        f = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]], np.float64)
        for fundamental in (None, f):
            candidate_pairs(left[:10], right[:10], -1000, 1000, 1000, 10**6, fundamental)
            t0 = time.process_time()  # CPU seconds, every thread: steady under load
            with pytest.raises(BudgetExceededError, match="more than max_neurons=5000000"):
                candidate_pairs(left, right, -1000.0, 1000.0, 1000.0, 5_000_000, fundamental)
            assert time.process_time() - t0 < 1.0

    @pytest.mark.parametrize("budget", [10**7, 3000, 100])
    def test_count_only_counts_what_the_search_counts(self, budget):
        """``count_only`` (the recount behind a refusal's message) writes nothing and
        returns the ``n`` of the search that writes: every pair of the band within the
        budget, and past it the same lower bound (the count stops at the same segment)."""
        rng = np.random.default_rng(3)
        left = np.column_stack([rng.uniform(0, 400, 300), rng.uniform(0, 40, 300)])
        right = np.column_stack([rng.uniform(0, 400, 400), rng.uniform(0, 40, 400)])
        left, right = left.astype(np.float32), right.astype(np.float32)
        index = _k.band_index(right, 4 * len(right) + 1024)
        visit = _k.row_order(left, 4 * len(left) + 1024)[0]
        band = (np.float32(0.0), np.float32(150.0), np.float32(2.0))
        args = (left, visit, *index, *band, np.int64(budget), np.zeros(len(left)),
                np.zeros(len(right)), np.inf, 1e-6, 1.0)
        ni, nk, n = _k.band_candidates(*args)
        ci, ck, cn = _k.band_candidates(*args, True)
        assert cn == n and len(ci) == 0 and len(ck) == 0
        every = len(naive.candidate_pairs(left, right, 0.0, 150.0, 2.0))
        assert (n == every == len(ni)) if budget > every else (budget < n <= every)

    def test_huge_bounds_keep_every_pair(self):
        """max_vertical of 1e19 (beyond int64 once turned into rows) or 3.5e38 (inf in
        float32) gave no candidate; bounds past 2**22 are clamped: the same pairs as a
        band holding every point."""
        rng = np.random.default_rng(0)
        left = rng.uniform(0, 100, (30, 2)).astype(np.float32)
        right = rng.uniform(0, 100, (40, 2)).astype(np.float32)
        want = candidate_pairs(left, right, -200.0, 200.0, 200.0, 10**6)
        assert len(want[0]) == 30 * 40
        for vmax in (1e19, 3.5e38, 1e300):
            for lo, hi in ((-200.0, 200.0), (-1e300, 1e300)):
                got = candidate_pairs(left, right, lo, hi, vmax, 10**6)
                assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        # a range wholly beyond the clamp, either side: no pair, and no float32 overflow
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            for lo, hi in ((1e300, 1e300), (-1e300, -1e299)):
                assert len(candidate_pairs(left, right, lo, hi, 1e300, 10**6)[0]) == 0


class TestBestTwoPerGroup:
    """``best_two_per_group`` (one pass) against sorting the pairs (``naive``)."""

    @pytest.mark.parametrize("seed", [0, 1, 2, 3])
    def test_equals_sorting_with_ties_nan_and_lone_pairs(self, seed):
        rng = np.random.default_rng(seed)
        sizes = rng.integers(1, 9, 60)  # groups of one pair included
        groups = rng.permutation(200)[:len(sizes)]  # groups in any order, not contiguous ids
        ni = np.repeat(groups, sizes).astype(np.int32)
        nk = np.concatenate([rng.permutation(50)[:m] for m in sizes]).astype(np.int32)
        sim = rng.integers(0, 4, len(ni)).astype(np.float64) / 4  # many exact ties
        sim[rng.random(len(ni)) < 0.15] = np.nan
        want = naive.best_two_by_sorting(ni, nk, sim)
        left, best, second = _k.best_two_per_group(ni, nk, sim)
        assert left.tolist() == groups.tolist()  # one entry per group, in input order
        assert {i: (b, s) for i, b, s in zip(left.tolist(), best.tolist(),
                                              second.tolist())} == want
        assert (second[sizes == 1] == -1).all() and (second[sizes > 1] >= 0).all()
        wl, wb, ws = best_two_look_alikes(ni, nk, sim)
        assert wl.tolist() == sorted(groups.tolist())
        assert [(b, s) for b, s in zip(wb.tolist(), ws.tolist())] == [want[i] for i in
                                                                       wl.tolist()]

    def test_empty(self):
        left, best, second = _k.best_two_per_group(np.zeros(0, np.int32), np.zeros(0, np.int32),
                                                   np.zeros(0))
        assert len(left) == len(best) == len(second) == 0
