"""The sparse Hopfield network kernels (SPEC sections 2-4) against the dense reference of
``tests/naive.py``: candidates, neighbourhoods, weights, energy, dynamics, disambiguation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import naive
from hopmatch._kernels import network as _k
from hopmatch.errors import BudgetExceededError
from hopmatch.matching.disambiguate import (
    disambiguate,
    singular_choice,
    vertically_consistent,
)
from hopmatch.matching.network import (
    _starts,
    candidate_pairs,
    run_hopfield_network,
    shift_minimal,
    similarity_distance,
    vertical_offsets,
)
from hopmatch.matching.params import MATCHER_PARAMS, PRESETS

DEFAULTS = {param.name: param.default for param in MATCHER_PARAMS}

#: Parameter sets the dense comparison runs: the defaults (two-phase annealing), the
#: paper's section 4, a gated/limited network with the stable-iterations rule, and a
#: network cut short by max_iterations.
CONFIGS = {
    "default": dict(max_disparity=15.0, max_vertical=2.0, similarity_gate=None),
    "paper": dict(PRESETS["paper"]),
    "gated": dict(max_disparity=15.0, max_vertical=3.0, similarity_gate=1.2, max_candidates=3,
                  stable_iterations=5, initial_bias=0.5, input_bias=-0.7, theta=8.0,
                  slope=0.7, uniqueness_weight=0.6, similarity_weight=2.0),
    "short": dict(max_disparity=15.0, max_vertical=3.0, similarity_gate=None,
                  initial_bias=None, input_bias=1.3, max_iterations=7),
}


def params(**overrides):
    p = dict(DEFAULTS)
    p.update(overrides)
    return p


def make_problem(seed, n_left, n_right=None, width=80.0, height=40.0, dim=9,
                 integer=False):
    """A random stereo problem: most right points are left points shifted by a disparity of
    about 6 px (with noise), the rest are outliers; descriptors of true pairs are close."""
    rng = np.random.default_rng(seed)
    n_right = n_left if n_right is None else n_right
    left = np.column_stack([rng.uniform(0, width, n_left), rng.uniform(0, height, n_left)])
    n_true = min(n_left, n_right) * 3 // 4
    right = np.column_stack([rng.uniform(0, width, n_right), rng.uniform(0, height, n_right)])
    right[:n_true] = left[:n_true] - [6.0, 0.0] + rng.normal(0, [1.5, 0.7], (n_true, 2))
    desc_l = rng.normal(size=(n_left, dim))
    desc_r = rng.normal(size=(n_right, dim))
    desc_r[:n_true] = desc_l[:n_true] + rng.normal(0, 0.4, (n_true, dim))
    perm = rng.permutation(n_right)
    right, desc_r = right[perm], desc_r[perm]
    if integer:
        left, right = np.round(left), np.round(right)
    return (np.ascontiguousarray(left, np.float32), np.ascontiguousarray(right, np.float32),
            desc_l.astype(np.float32), desc_r.astype(np.float32))


def kernel_network(left, right, desc_l, desc_r, p):
    """The sparse network exactly as ``run_hopfield_network`` builds it, step by step."""
    ni, nk = candidate_pairs(left, right, p["min_disparity"], p["max_disparity"],
                             p["max_vertical"], p["max_neurons"])
    sim = similarity_distance(desc_l, desc_r, ni, nk) if len(ni) else np.zeros(0)
    keep = np.ones(len(ni), dtype=bool)
    if p["similarity_gate"] is not None:
        keep &= sim <= p["similarity_gate"]
    if p["max_candidates"] and len(ni):
        order = np.lexsort((sim, ni))
        rank = np.empty(len(ni), dtype=np.int64)
        rank[order] = np.arange(len(ni)) - np.searchsorted(ni[order], ni[order])
        keep &= rank < p["max_candidates"]
    ni, nk, sim = ni[keep], nk[keep], sim[keep]
    start = _starts(ni, len(left))
    nb_off, nb_idx = _k.neighbour_lists(left, np.float32(p["neighbour_width"] / 2),
                                        np.float32(p["neighbour_height"] / 2))
    n_inter = _k.count_interactions(ni, nk, start, nb_off, nb_idx)
    off, idx, w = _k.fill_interactions(left, right, ni, nk, start, nb_off, nb_idx,
                                       p["similarity_weight"] * sim, p["theta"], p["slope"],
                                       n_inter)
    assert off[-1] == n_inter
    return dict(ni=ni, nk=nk, sim=sim, start=start, nb_off=nb_off, nb_idx=nb_idx,
                n_inter=n_inter, off=off, idx=idx, w=w)


def sparse_t(net, uniqueness_weight):
    """T of eq. 11 assembled from the kernel's CSR weights and the uniqueness terms."""
    ni, nk = net["ni"], net["nk"]
    n = len(ni)
    t = np.zeros((n, n))
    for p in range(n):
        for e in range(net["off"][p], net["off"][p + 1]):
            t[p, net["idx"][e]] += net["w"][e]
    t -= uniqueness_weight * ((ni[:, None] == ni[None, :]).astype(float)
                              + (nk[:, None] == nk[None, :]))
    np.fill_diagonal(t, 0.0)
    return t


def counts(net, v, n_left, n_right):
    row = np.bincount(net["ni"][v == 1], minlength=n_left).astype(np.int64)
    col = np.bincount(net["nk"][v == 1], minlength=n_right).astype(np.int64)
    return row, col


# ======================================================================================
# candidates and neighbourhoods
# ======================================================================================


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
        from hopmatch.matching.network import left_visit_order as _left_visit_order, right_band_index as _right_band_index

        left, right, _, _ = make_problem(3, 50, 60)
        if spread:
            left[::7, 1] += 1e6
            right[::7, 1] += 1e6
        visit = _left_visit_order(left)
        assert np.array_equal(visit, np.argsort(np.floor(left[:, 1]), kind="stable"))
        for limit in (0, 10**7):  # forced sort, forced count
            assert np.array_equal(_k.row_order(left, limit)[0], visit)
        rows, row_start, r_order, rx, ry = _right_band_index(right)
        want = sorted(range(len(right)), key=lambda k: (np.floor(right[k, 1]), right[k, 0], k))
        assert r_order.tolist() == want
        assert rows.tolist() == sorted(set(np.floor(right[:, 1]).astype(np.int64).tolist()))
        ni, nk = candidate_pairs(left, right, 0.0, 20.0, 2.0, 10**6)
        assert list(zip(ni.tolist(), nk.tolist())) == naive.candidate_pairs(
            left, right, 0.0, 20.0, 2.0)

    def test_right_points_ordered_by_row_then_x_then_index(self):
        from hopmatch.matching.network import right_band_index as _right_band_index
        rng = np.random.default_rng(11)
        pts = np.column_stack([rng.choice([-3.5, -0.0, 0.0, 1e-30, 2.25, -1e6, 7.0], 400),
                               rng.choice([-2.5, -0.5, 0.0, 0.75, 3.0], 400)])
        pts = np.concatenate([pts, rng.uniform(-50, 50, (300, 2))]).astype(np.float32)
        rows, row_start, order, rx, ry = _right_band_index(pts)
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

    @pytest.mark.parametrize("max_entries", [1, 40, 10**4])
    def test_row_buckets_bracket_every_x_range(self, max_entries):
        """Every point of a row within [x_lo, x_hi] lies between the table entries of the
        two end buckets, for any budget of entries (one bucket per row at the least) and
        for queries far outside the points."""
        from hopmatch.matching.network import right_band_index as _right_band_index
        rng = np.random.default_rng(4)
        pts = np.column_stack([np.round(rng.uniform(-40, 60, 300), 1),
                               rng.integers(0, 12, 300)]).astype(np.float32)
        rows, row_start, order, rx, ry = _right_band_index(pts)
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
        from hopmatch.matching.network import right_band_index as _right_band_index
        _, row_start, _, rx, _ = _right_band_index(right)
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


# ======================================================================================
# similarity
# ======================================================================================


class TestSimilarity:
    def test_normalised_difference(self):
        rng = np.random.default_rng(0)
        a = rng.normal(size=(20, 25)).astype(np.float32)
        b = rng.normal(size=(30, 25)).astype(np.float32)
        ni = rng.integers(0, 20, 200).astype(np.int32)
        nk = rng.integers(0, 30, 200).astype(np.int32)
        sa, sb = _k.row_mean_abs(a), _k.row_mean_abs(b)
        assert np.allclose(sa, np.abs(a.astype(np.float64)).mean(axis=1), rtol=1e-12)
        got = _k.normalised_difference(a, b, ni, nk, sa, sb, 1e-6, np.inf)
        m = np.abs(a[ni].astype(np.float64) - b[nk]).mean(axis=1)
        want = m / (0.5 * (sa[ni] + sb[nk]) + 1e-6)
        assert got.dtype == np.float64
        assert np.allclose(got, want, rtol=1e-12, atol=0)

    @pytest.mark.parametrize("gate", [0.0, 0.3, 0.9, 1.1])
    def test_gate_keeps_exactly_the_pairs_within_it(self, gate):
        rng = np.random.default_rng(4)
        a = rng.normal(size=(30, 81)).astype(np.float32)
        b = np.concatenate([a + rng.normal(scale=s, size=a.shape).astype(np.float32)
                            for s in (0.0, 0.2, 0.5, 2.0)])
        b[::7] *= 3.0                                   # contrast changes: the lower bound
        ni = np.repeat(np.arange(30, dtype=np.int32), 40)
        nk = rng.integers(0, len(b), len(ni)).astype(np.int32)
        full = similarity_distance(a, b, ni, nk)
        gated = similarity_distance(a, b, ni, nk, gate)
        within = full <= gate
        assert 0 < within.sum() < len(ni) or gate == 0.0
        assert np.array_equal(gated[within], full[within])   # exact, not approximate
        assert (gated[~within] > gate).all()
        assert np.isinf(gated[~within]).any()                    # some skipped by the bound

    @pytest.mark.parametrize("gate", [0.0, 0.3, 0.9, np.inf])
    def test_band_leaves_out_exactly_the_pairs_the_contrast_bound_rejects(self, gate):
        """``contrast_gate`` drops, before they are written, the band pairs whose contrasts
        alone put them past the gate: what is left is every pair whose similarity can be
        within the gate, and the budget still counts the whole band."""
        from hopmatch.matching.network import window_contrasts

        left, right, dl, dr = make_problem(6, 80, 90)
        dr[::5] *= 3.0  # contrast changes
        contrasts = window_contrasts(dl, dr)
        ni, nk = candidate_pairs(left, right, 0.0, 20.0, 2.0, 10**6)
        gi, gk = candidate_pairs(left, right, 0.0, 20.0, 2.0, 10**6,
                                 contrast_gate=(contrasts, gate))
        sim = similarity_distance(dl, dr, ni, nk, gate)
        plain = set(zip(ni.tolist(), nk.tolist()))
        kept = set(zip(gi.tolist(), gk.tolist()))
        assert kept <= plain and len(gi) == len(kept)
        assert {pair for pair, v in zip(zip(ni.tolist(), nk.tolist()), sim) if v <= gate} \
            <= kept
        assert kept == {pair for pair, v in zip(zip(ni.tolist(), nk.tolist()), sim)
                        if np.isfinite(v) or gate == np.inf}
        if 0.0 < gate < np.inf:
            assert 0 < len(kept) < len(plain)
        with pytest.raises(BudgetExceededError, match=f"would have {len(ni)} neurons"):
            candidate_pairs(left, right, 0.0, 20.0, 2.0, len(ni) - 1,
                            contrast_gate=(contrasts, gate))

    @pytest.mark.parametrize("size", [3, 5, 9])
    def test_shift_minimal_equals_reference(self, size):
        rng = np.random.default_rng(size)
        g = rng.uniform(0, 50, (40, 60)).astype(np.float32)
        ys, xs = rng.integers(size, 40 - size, 300), rng.integers(size + 1, 60 - size - 1, 300)
        shift = rng.integers(-1, 2, 300)                  # right windows 0 or 1 px off
        from hopmatch.feature import gradient_windows
        a = gradient_windows(g, np.column_stack([xs, ys]).astype(np.float32), size)
        b = gradient_windows(g, np.column_stack([xs + shift, ys]).astype(np.float32), size)
        qi = np.arange(300)
        got = shift_minimal(a, b, qi, qi)
        want = naive.shift_minimal(a, b, qi, qi)
        assert np.array_equal(got, want)
        assert got[shift == 0].all() and not got[shift != 0].all()

    def test_shift_minimal_passes_descriptors_that_are_not_windows(self):
        rng = np.random.default_rng(0)
        sift_like = rng.uniform(0, 1, (20, 128)).astype(np.float32)
        assert shift_minimal(sift_like, sift_like[::-1], np.arange(20), np.arange(20)).all()
        # square rows (9 x 9) that are not zero-mean: only the matched rows are tested, and
        # one that fails, even the last, lets every match pass
        rng = np.random.default_rng(1)
        windows = rng.normal(size=(30, 81)).astype(np.float32)
        windows -= windows.mean(axis=1, keepdims=True)
        shifted = np.roll(windows.reshape(30, 9, 9), 1, axis=2).reshape(30, 81)
        qi = np.arange(10)
        assert not shift_minimal(windows, shifted, qi, qi).all()  # windows: tested
        offset = windows.copy()
        offset[25] += 5.0                                         # a row with a mean
        assert np.array_equal(shift_minimal(offset, shifted, qi, qi),
                              shift_minimal(windows, shifted, qi, qi))  # row 25 unmatched
        last = np.r_[qi, 25]
        assert shift_minimal(offset, np.r_[shifted[:10], shifted[25:26]],
                             last, np.arange(11)).all()

    def test_hamming_fraction(self):
        rng = np.random.default_rng(1)
        a = rng.integers(0, 256, (20, 32)).astype(np.uint8)
        b = rng.integers(0, 256, (30, 32)).astype(np.uint8)
        b[3] = a[4]
        b[5] = ~a[6]
        ni = np.concatenate([[4, 6], rng.integers(0, 20, 200)]).astype(np.int32)
        nk = np.concatenate([[3, 5], rng.integers(0, 30, 200)]).astype(np.int32)
        got = _k.hamming_fraction(a, b, ni, nk)
        want = np.unpackbits(a[ni] ^ b[nk], axis=1).sum(axis=1) / 256.0
        assert np.array_equal(got, want)
        assert got[0] == 0.0 and got[1] == 1.0

    @pytest.mark.parametrize("dtype", [np.float32, np.uint8])
    def test_similarity_distance_equals_reference(self, dtype):
        rng = np.random.default_rng(2)
        if dtype == np.uint8:
            a = rng.integers(0, 256, (10, 16)).astype(np.uint8)
            b = rng.integers(0, 256, (12, 16)).astype(np.uint8)
        else:
            a = rng.normal(size=(10, 16)).astype(np.float32)
            b = rng.normal(size=(12, 16)).astype(np.float32)
        ni = rng.integers(0, 10, 50).astype(np.int32)
        nk = rng.integers(0, 12, 50).astype(np.int32)
        got = similarity_distance(a, b, ni, nk)
        want = [naive.similarity(a[i], b[k]) for i, k in zip(ni, nk)]
        assert np.allclose(got, want, rtol=1e-9)


# ======================================================================================
# the network: weights, energy, dynamics
# ======================================================================================


PROBLEMS = [(0, 8), (1, 15), (2, 25), (3, 20)]


@pytest.fixture(scope="module", params=sorted(CONFIGS))
def config(request):
    return request.param


class TestDenseReference:
    @pytest.mark.parametrize("seed,n", PROBLEMS)
    def test_weights_equal_dense_t(self, config, seed, n):
        p = params(**CONFIGS[config])
        problem = make_problem(seed, n)
        net = kernel_network(*problem, p)
        dense = naive.dense_network(*problem, p)
        assert np.array_equal(net["ni"], dense["ni"]) and np.array_equal(net["nk"], dense["nk"])
        assert np.allclose(net["sim"], dense["sim"], rtol=1e-9)
        # the stored interactions are exactly the pairs that interact through C
        stored = np.zeros_like(dense["adj"])
        for q in range(len(net["ni"])):
            stored[q, net["idx"][net["off"][q]:net["off"][q + 1]]] = True
        assert np.array_equal(stored, dense["adj"])
        assert net["n_inter"] == dense["adj"].sum() == len(net["w"])
        # eq. 11: T = C - w (delta_ij + delta_kl), zero diagonal; symmetric
        t = sparse_t(net, p["uniqueness_weight"])
        assert np.allclose(t, dense["T"], rtol=0, atol=1e-7)   # float32 weights: ~1 ulp
        assert np.allclose(dense["T"], dense["T"].T, atol=0)
        assert not np.diag(dense["T"]).any()
        if n >= 15:
            c = dense["C"][dense["adj"]]
            assert len(c) > 0 and (np.abs(c) <= 1).all() and (c > 0).any()

    @pytest.mark.parametrize("seed,n", PROBLEMS)
    def test_energy_and_fields_of_any_state(self, config, seed, n):
        p = params(**CONFIGS[config])
        problem = make_problem(seed, n)
        net = kernel_network(*problem, p)
        dense = naive.dense_network(*problem, p)
        rng = np.random.default_rng(seed)
        uw = p["uniqueness_weight"]
        for _ in range(5):
            v = (rng.random(len(net["ni"])) < 0.4).astype(np.uint8)
            row, col = counts(net, v, n, n)
            args = (v, net["ni"], net["nk"], net["off"], net["idx"], net["w"], row, col, uw)
            for bias in (p["input_bias"], 2.0, -0.3):
                e = _k.network_energy(*args, bias)
                assert e == pytest.approx(naive.energy(dense["T"], bias, v), abs=1e-8)
                u = _k.local_fields(*args, bias)
                assert np.allclose(u, dense["T"] @ v + bias, rtol=0, atol=1e-9)

    @pytest.mark.parametrize("seed,n", PROBLEMS)
    @pytest.mark.parametrize("run_seed", [0, 7, 12345])
    def test_final_state_equals_dense(self, config, seed, n, run_seed):
        p = params(**CONFIGS[config], seed=run_seed)
        problem = make_problem(seed, n)
        res = run_hopfield_network(*problem, p, record_energy=True)
        dense, v, iterations, phases = naive.dense_match(*problem, p)
        assert np.array_equal(res.neuron_left, dense["ni"])
        assert np.array_equal(res.neuron_right, dense["nk"])
        assert np.array_equal(res.state, v.astype(bool))
        assert res.iterations == iterations
        # the recorded trace is the energy of the states the dense replay went through
        want = np.concatenate(phases)
        assert res.energy_trace.shape == want.shape
        assert np.allclose(res.energy_trace, want, rtol=0, atol=1e-8)
        for energies in phases:                       # eq. 13 never increases E (per phase)
            assert (np.diff(energies) <= 1e-9).all()
        assert res.energy == pytest.approx(naive.energy(dense["T"], p["input_bias"], v),
                                           abs=1e-8)
        assert np.allclose(res.fields, dense["T"] @ v + p["input_bias"], rtol=0, atol=1e-9)
        if config == "short":
            assert res.iterations <= 7
            assert res.converged or res.iterations == 7

    @pytest.mark.parametrize("seed,n", [(2, 25), (3, 20)])
    def test_python_versions_accumulate_in_float64(self, seed, n):
        """What the NUMBA_DISABLE_JIT=1 job runs (``py_func``) must agree with the dense
        reference as the compiled kernels do."""
        p = params(**CONFIGS["paper"])
        problem = make_problem(seed, n)
        net = kernel_network(*problem, p)
        t = naive.dense_network(*problem, p)["T"]
        v = (np.random.default_rng(0).random(len(net["ni"])) < 0.4).astype(np.uint8)
        row, col = counts(net, v, n, n)
        args = (v, net["ni"], net["nk"], net["off"], net["idx"], net["w"], row, col, 1.0, 2.0)
        assert _k.local_fields(*args) == pytest.approx(t @ v + 2.0, rel=0, abs=1e-9)
        assert _k.network_energy(*args) == pytest.approx(naive.energy(t, 2.0, v), abs=1e-8)
        assert _k.local_fields.py_func(*args) == pytest.approx(t @ v + 2.0, rel=0, abs=1e-9)
        assert _k.network_energy.py_func(*args) == pytest.approx(naive.energy(t, 2.0, v),
                                                                 abs=1e-8)

    def test_the_comparison_is_not_vacuous(self):
        """Across the problems above, the networks have neurons, turn some on and off, and
        some final states differ between seeds (so the visit order matters)."""
        p = params(**CONFIGS["paper"])
        problem = make_problem(2, 25)
        states, actives = set(), []
        for s in range(6):
            p["seed"] = s
            res = run_hopfield_network(*problem, p, record_energy=True)
            states.add((res.state.tobytes(), res.energy_trace.tobytes()))
            actives.append(res.state.sum())
        assert len(res.state) > 30 and min(actives) > 0
        assert len(states) > 1

    def test_visit_order_is_the_kernels(self):
        """naive.kernel_sweeps reproduces run_network's order: on a network without
        interactions where each left point has one neuron, each visit of the first sweep
        turns on the visited point's neuron, so after t iterations the active neurons are
        the first t points of the first sweep."""
        n = 12
        left = np.column_stack([np.arange(n) * 100.0, np.zeros(n)]).astype(np.float32)
        right = left - np.float32([5, 0])
        p = params(max_disparity=10.0, similarity_gate=None, initial_bias=None,
                   input_bias=0.5, neighbour_width=1.0, neighbour_height=1.0)
        net = kernel_network(left, right, np.ones((n, 4), np.float32),
                             np.ones((n, 4), np.float32), p)
        assert net["n_inter"] == 0
        for seed in (0, 1, 99):
            v, it, sweeps, converged, trace = _k.run_network(
                np.zeros(n, np.uint8), net["ni"], net["nk"], net["start"], net["off"],
                net["idx"], net["w"], n, n, 1.0, 0.5, np.uint64(seed), 0, 1000, True)
            first = next(naive.kernel_sweeps(net["start"], seed))
            # each visit adds 1 neuron, energy -0.5 each: the trace is a staircase
            assert np.allclose(trace[: n + 1], -0.5 * np.arange(n + 1))
            assert it == 2 * n and sweeps == 2 and converged and v.all()
            assert sorted(first.tolist()) == list(range(n))
            assert first.tolist() != list(range(n))
            assert np.array_equal(net["ni"], np.arange(n))
            for t in range(1, n + 1):
                v, it, *_ = _k.run_network(
                    np.zeros(n, np.uint8), net["ni"], net["nk"], net["start"], net["off"],
                    net["idx"], net["w"], n, n, 1.0, 0.5, np.uint64(seed), 0, t, False)
                assert it == t
                assert np.flatnonzero(v).tolist() == sorted(first[:t].tolist())
        a, b = (next(naive.kernel_sweeps(net["start"], s)) for s in (0, 1))
        assert not np.array_equal(a, b)

    def test_same_seed_same_result(self):
        problem = make_problem(3, 20)
        p = params(**CONFIGS["default"], seed=42)
        a = run_hopfield_network(*problem, p, record_energy=True)
        b = run_hopfield_network(*problem, p, record_energy=True)
        assert np.array_equal(a.state, b.state)
        assert np.array_equal(a.energy_trace, b.energy_trace)
        assert a.iterations == b.iterations and a.sweeps == b.sweeps
        assert np.array_equal(a.query_idx, b.query_idx)
        traces = set()
        for s in range(8):
            p["seed"] = s
            traces.add(run_hopfield_network(*problem, p, record_energy=True)
                       .energy_trace.tobytes())
        assert len(traces) > 1

    def test_annealing_phases(self):
        """With ``initial_bias`` the trace is two runs: each monotone, each ending at the
        energy of its state with its own bias."""
        p = params(**CONFIGS["default"])
        problem = make_problem(1, 25)
        net = kernel_network(*problem, p)
        args = (net["ni"], net["nk"], net["start"], net["off"], net["idx"], net["w"], 25, 25,
                p["uniqueness_weight"])
        v = np.zeros(len(net["ni"]), np.uint8)
        traces = []
        for phase, bias in enumerate((p["initial_bias"], p["input_bias"])):
            v, it, _, converged, trace = _k.run_network(
                v, *args, bias, np.uint64(p["seed"] + phase), 0, 10**6, True)
            assert converged and len(trace) == it + 1
            assert (np.diff(trace) <= 1e-12).all()
            row, col = counts(net, v, 25, 25)
            e = _k.network_energy(v, net["ni"], net["nk"], net["off"], net["idx"], net["w"],
                                  row, col, p["uniqueness_weight"], bias)
            assert trace[-1] == pytest.approx(e, abs=1e-9)
            traces.append(trace)
        assert traces[1][0] != traces[0][-1]            # the bias changed between phases
        res = run_hopfield_network(*problem, p, record_energy=True)
        assert np.array_equal(res.energy_trace, np.concatenate(traces))
        assert np.array_equal(res.state, v.astype(bool))


@settings(max_examples=40, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31), n=st.integers(2, 30),
       input_bias=st.floats(-2.0, 3.0), uniqueness=st.floats(0.0, 2.0),
       theta=st.floats(0.5, 20.0), slope=st.floats(0.1, 4.0), run_seed=st.integers(0, 2**40))
def test_energy_never_increases(seed, n, input_bias, uniqueness, theta, slope, run_seed):
    problem = make_problem(seed, n)
    p = params(max_disparity=15.0, max_vertical=4.0, similarity_gate=None, initial_bias=None,
               input_bias=input_bias, uniqueness_weight=uniqueness, theta=theta, slope=slope,
               seed=run_seed)
    res = run_hopfield_network(*problem, p, record_energy=True)
    trace = res.energy_trace
    assert len(trace) == res.iterations + 1 and trace[0] == 0.0
    assert (np.diff(trace) <= 1e-9).all()
    # the incremental energy is the true energy of the final state (eq. 11)
    assert trace[-1] == pytest.approx(res.energy, abs=1e-6)
    # a fixed point: no neuron would change (u > 0 for active, u < 0 ... or u = 0)
    if res.converged:
        u = res.fields
        assert not (res.state & (u < -1e-9)).any()
        assert not (~res.state & (u > 1e-9)).any()


# ======================================================================================
# sparsity: counts against brute force, at a size the dense matrix cannot have
# ======================================================================================


def _brute_force_interactions(left, right, p):
    """(count, bound): ordered pairs ((i, k), (j, l)), j a neighbour of i, l != k; and the
    same without the l != k restriction (sum over neurons of the neighbours' candidates)."""
    d = left[:, None, 0] - right[None, :, 0]
    dy = np.abs(left[:, None, 1] - right[None, :, 1])
    b = ((d >= np.float32(p["min_disparity"])) & (d <= np.float32(p["max_disparity"]))
         & (dy <= np.float32(p["max_vertical"]))).astype(np.float64)
    nb = ((np.abs(left[:, None, 0] - left[None, :, 0]) <= np.float32(p["neighbour_width"] / 2))
          & (np.abs(left[:, None, 1] - left[None, :, 1]) <= np.float32(p["neighbour_height"] / 2)))
    np.fill_diagonal(nb, False)
    nb = nb.astype(np.float64)
    cnt = b.sum(axis=1)
    bound = float(cnt @ (nb @ cnt))
    same_k = float((b * (nb @ b)).sum())
    return int(round(bound - same_k)), int(round(bound))


def stored_weights(off, idx, w, n):
    """The CSR weights as a dense (n, n) array, NaN where no interaction is stored."""
    dense = np.full((n, n), np.nan)
    for q in range(n):
        dense[q, idx[off[q]:off[q + 1]]] = w[off[q]:off[q + 1]]
    return dense


class TestMirroredWeights:
    """``fill_interactions`` computes each symmetric weight once and copies it to its mirror
    entry, and only when that entry is the mirror."""

    @pytest.mark.parametrize("seed", range(4))
    def test_symmetric_lists_give_exactly_symmetric_weights(self, config, seed):
        p = params(**CONFIGS[config])
        problem = make_problem(seed, 30)
        net = kernel_network(*problem, p)
        dense = naive.dense_network(*problem, p)
        w = stored_weights(net["off"], net["idx"], net["w"], len(net["ni"]))
        assert np.array_equal(w, w.T, equal_nan=True)
        assert np.allclose(np.nan_to_num(w), dense["C"], rtol=0, atol=1e-7)

    @pytest.mark.parametrize("seed", range(4))
    def test_one_sided_lists_give_each_pair_its_own_weight(self, seed):
        """Neighbour lists where j may list i but not the reverse: every stored weight is
        still eq. 5 of its own pair, whether a mirror entry exists or not."""
        p = params(**CONFIGS["default"])
        left, right, desc_l, desc_r = make_problem(seed, 30)
        net = kernel_network(left, right, desc_l, desc_r, p)
        dense = naive.dense_network(left, right, desc_l, desc_r, p)
        rng = np.random.default_rng(seed)
        keep = rng.random(len(net["nb_idx"])) < 0.6
        kept_before = np.r_[0, np.cumsum(keep)]
        nb_off = kept_before[net["nb_off"]]  # each list keeps its kept entries, in order
        nb_idx = net["nb_idx"][keep]
        ni, nk, start = net["ni"], net["nk"], net["start"]
        n_inter = _k.count_interactions(ni, nk, start, nb_off, nb_idx)
        off, idx, w = _k.fill_interactions(left, right, ni, nk, start, nb_off, nb_idx,
                                           p["similarity_weight"] * net["sim"], p["theta"],
                                           p["slope"], n_inter)
        assert off[-1] == n_inter > 0
        got = stored_weights(off, idx, w, len(ni))
        stored = ~np.isnan(got)
        assert (stored <= dense["adj"]).all() and stored.sum() < dense["adj"].sum()
        assert (stored & ~stored.T).any() and (stored & stored.T).any()  # both cases met
        assert np.allclose(got[stored], dense["C"][stored], rtol=0, atol=1e-7)


class TestSparsity:
    @pytest.mark.parametrize("seed,n", PROBLEMS)
    def test_count_small(self, config, seed, n):
        p = params(**CONFIGS[config])
        problem = make_problem(seed, n)
        net = kernel_network(*problem, p)
        cnt = np.diff(net["start"])
        bound = sum(cnt[net["nb_idx"][net["nb_off"][i]:net["nb_off"][i + 1]]].sum()
                    for i in net["ni"])
        assert net["n_inter"] <= bound
        assert _k.interaction_bound(net["start"], net["nb_off"], net["nb_idx"]) == bound
        if p["similarity_gate"] is None and not p["max_candidates"]:
            assert (net["n_inter"], bound) == _brute_force_interactions(problem[0], problem[1], p)

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

    def test_2000_points(self):
        """2000 points a side: a dense T would have (Nl Nr)^2 = 1.6e13 entries; the sparse
        network stores exactly the brute-force count of interactions."""
        n = 2000
        left, right, dl, dr = make_problem(11, n, width=400.0, height=400.0, integer=True)
        p = params(max_disparity=20.0, max_vertical=2.0, similarity_gate=None,
                   max_iterations=20000)
        count, bound = _brute_force_interactions(left, right, p)
        assert 0 < count <= bound < 10**6
        res = run_hopfield_network(left, right, dl, dr, p)
        assert res.n_interactions == count
        assert len(res.neuron_left) < 10 * n
        assert res.n_interactions < 1e-6 * float(n * n) ** 2
        p["max_interactions"] = count
        run_hopfield_network(left, right, dl, dr, p)      # exactly at the budget: fine
        p["max_interactions"] = count - 1
        with pytest.raises(BudgetExceededError):
            run_hopfield_network(left, right, dl, dr, p)


# ======================================================================================
# disambiguation (section 4)
# ======================================================================================


def _random_active(rng, integer_dy):
    a = int(rng.integers(0, 40))
    group = rng.integers(0, max(1, a // 2 + 1), a)
    if integer_dy:
        dy = rng.integers(-3, 4, a).astype(np.float64)
    else:
        dy = rng.normal(0, 1.5, a)
    score = rng.integers(0, 3, a).astype(np.float64)     # ties on purpose
    return group, dy, score


class TestDisambiguation:
    @pytest.mark.parametrize("integer_dy", [True, False])
    def test_singular_choice_equals_reference(self, integer_dy):
        rng = np.random.default_rng(int(integer_dy))
        n_multi_joined = 0
        for _ in range(300):
            group, dy, score = _random_active(rng, integer_dy)
            for threshold in (0.5, 1.0, 2.5):
                got = singular_choice(group, dy, score, threshold)
                want = naive.singular_choice(group, dy, score, threshold)
                assert np.array_equal(got, want)
                # at most one pair per group
                assert len(np.unique(group[got])) == got.sum()
                n_multi_joined += int(got.sum()) - int((np.bincount(group)[group] == 1).sum())
        assert n_multi_joined > 50

    def test_singular_choice_examples(self):
        keep = singular_choice(np.array([0, 1, 1]), np.array([0.0, 0.2, 3.0]), np.zeros(3), 1.0)
        assert keep.tolist() == [True, True, False]
        # a tie in |dy - Ybar| is broken by the higher score
        keep = singular_choice(np.array([0, 1, 1]), np.array([0.0, 0.5, -0.5]),
                               np.array([0.0, 1.0, 2.0]), 1.0)
        assert keep.tolist() == [True, False, True]
        assert naive.singular_choice(np.array([0, 1, 1]), np.array([0.0, 0.5, -0.5]),
                                     np.array([0.0, 1.0, 2.0]), 1.0).tolist() == keep.tolist()
        # Ybar is updated as groups join: group 2 joins only after group 1 moved Ybar
        group = np.array([0, 1, 1, 2, 2])
        dy = np.array([0.0, 0.9, 5.0, 1.4, 7.0])
        assert singular_choice(group, dy, np.zeros(5), 1.0).tolist() == [
            True, True, False, True, False]
        assert singular_choice(np.array([], int), np.zeros(0), np.zeros(0), 1.0).shape == (0,)

    def test_disambiguate_is_one_to_one(self):
        rng = np.random.default_rng(3)
        total = 0
        for _ in range(200):
            n = int(rng.integers(0, 60))
            ni = rng.integers(0, 15, n)
            nk = rng.integers(0, 15, n)
            active = rng.random(n) < 0.6
            dy = rng.integers(-2, 3, n).astype(np.float64)
            score = rng.normal(size=n)
            out = disambiguate(ni, nk, active, dy, score, 1.0)
            assert active[out].all()
            assert len(np.unique(ni[out])) == len(out) == len(np.unique(nk[out]))
            assert (np.diff(out) > 0).all()
            act = np.flatnonzero(active)
            both = (naive.singular_choice(ni[act], dy[act], score[act], 1.0)
                    & naive.singular_choice(nk[act], dy[act], score[act], 1.0))
            assert np.array_equal(out, act[both])
            total += len(out)
        assert total > 100

    @pytest.mark.parametrize("seed", [0, 1, 2])
    def test_network_matches_are_one_to_one(self, seed):
        res = run_hopfield_network(*make_problem(seed, 25),
                                   params(**CONFIGS["paper"], seed=seed))
        assert len(res.query_idx) > 0
        assert len(np.unique(res.query_idx)) == len(res.query_idx)
        assert len(np.unique(res.train_idx)) == len(res.train_idx)


class TestVerticalCheck:
    """``vertical_check="all"``: section 4's vertical test for every kept pair."""

    def test_equals_reference(self):
        rng = np.random.default_rng(5)
        rejected = 0
        for _ in range(300):
            n = int(rng.integers(0, 30))
            if rng.random() < 0.5:
                dy = rng.integers(-3, 4, n).astype(np.float64)   # ties on the median
            else:
                dy = rng.normal(0, 1.5, n)
            for threshold in (0.5, 1.0, 2.5):
                got = vertically_consistent(dy, threshold)
                want = naive.vertically_consistent(dy, threshold)
                assert np.array_equal(got, want)
                rejected += int((~got).sum())
        assert rejected > 100

    def test_examples(self):
        # the median (0.1), not the mean (0.66, pulled by the outlier), is the reference
        dy = np.array([0.1, -0.2, 0.0, 3.0, 0.4])
        assert vertically_consistent(dy, 1.0).tolist() == [True, True, True, False, True]
        assert naive.vertically_consistent(dy, 1.0).tolist() == [True, True, True, False, True]
        # strict, as section 4's test: exactly threshold away is out
        assert vertically_consistent(np.array([0.0, 0.0, 1.0]), 1.0).tolist() == [
            True, True, False]
        # a constant offset (a rectification error) is not removed
        assert vertically_consistent(np.full(4, 2.5), 1.0).all()
        assert vertically_consistent(np.array([0.0, np.inf, 0.1]), 1.0).tolist() == [
            True, False, True]
        assert vertically_consistent(np.zeros(0), 1.0).shape == (0,)

    def test_presets(self):
        assert DEFAULTS["vertical_check"] == "all"
        assert PRESETS["paper"]["vertical_check"] == "multiple"   # section 4 as written
        assert PRESETS["default"]["vertical_check"] == "all"

    @pytest.mark.parametrize("cross_check", [True, False])
    def test_network_applies_it_to_every_kept_pair(self, cross_check):
        """With a band wider than the threshold, ``"all"`` keeps exactly the pairs of
        ``"multiple"`` that lie strictly within ``vertical_threshold`` of their median
        vertical disparity; some pairs, singular ones among them, are removed."""
        removed = removed_singular = 0
        for seed in range(6):
            problem = make_problem(seed, 40)
            p = params(**{**CONFIGS["gated"], "max_vertical": 4.0}, cross_check=cross_check,
                       seed=seed)
            base = run_hopfield_network(*problem, {**p, "vertical_check": "multiple"})
            new = run_hopfield_network(*problem, {**p, "vertical_check": "all"})
            left, right = problem[0], problem[1]
            dy = vertical_offsets(left, right, base.query_idx, base.train_idx)
            assert len(dy) > 10
            keep = naive.vertically_consistent(dy, p["vertical_threshold"])
            assert np.array_equal(new.query_idx, base.query_idx[keep])
            assert np.array_equal(new.train_idx, base.train_idx[keep])
            new_dy = vertical_offsets(left, right, new.query_idx, new.train_idx)
            assert (np.abs(new_dy - np.median(dy)) < p["vertical_threshold"]).all()
            # the network itself is unchanged
            assert np.array_equal(new.state, base.state)
            removed += int((~keep).sum())
            # singular: the only active neuron of its left point
            n_active = np.bincount(base.neuron_left[base.state],
                                   minlength=len(left))[base.query_idx]
            removed_singular += int(((~keep) & (n_active == 1)).sum())
        assert removed > 0 and removed_singular > 0

    def test_the_paper_preset_keeps_off_row_singular_pairs(self):
        """Section 4 as written never tests a singular pair: with the paper's preset some
        kept pairs lie a threshold or more from the median vertical disparity."""
        far = 0
        for seed in range(4):
            left, right, dl, dr = make_problem(seed, 30)
            res = run_hopfield_network(left, right, dl, dr,
                                       params(**CONFIGS["paper"], seed=seed))
            dy = vertical_offsets(left, right, res.query_idx, res.train_idx)
            far += int((~vertically_consistent(dy, 1.0)).sum())
        assert far > 0
