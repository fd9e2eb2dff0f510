"""The interaction kernels (``hopmatch._kernels.interactions``, eqs. 5, 6 and 10) against the
dense network of ``tests/naive.py``: the stored pairs, their weights, their count."""

from __future__ import annotations

import os

import naive
import numpy as np
import pytest
from network_problems import (
    CONFIGS,
    PROBLEMS,
    brute_force_interactions,
    kernel_network,
    make_problem,
    params,
    sparse_t,
    stored_weights,
)

from hopmatch._kernels import interactions as _k


@pytest.fixture(scope="module", params=sorted(CONFIGS))
def config(request):
    """Each parameter set of ``CONFIGS`` in turn."""
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
        lower = sum(np.maximum(cnt[net["nb_idx"][net["nb_off"][i]:net["nb_off"][i + 1]]] - 1,
                               0).sum() for i in net["ni"])
        exact = _k.count_interactions(net["ni"], net["nk"], net["start"], net["nb_off"],
                                      net["nb_idx"])
        assert lower <= exact <= bound and net["n_inter"] <= bound
        assert _k.interaction_bounds(net["start"], net["nb_off"], net["nb_idx"]) == (lower,
                                                                                     bound)
        if p["similarity_gate"] is None and not p["max_candidates"]:
            assert (net["n_inter"], bound) == brute_force_interactions(problem[0], problem[1], p)


def test_compatibility_equals_reference():
    """Eq. 5 against ``naive.compatibility``, through the edge ``theta`` and far past it
    (where the kernel returns the limit -1)."""
    for theta, slope in ((10.0, 0.5), (34.0, 2.0), (0.5, 4.0)):
        for x in np.r_[np.linspace(0.0, 3.0 * theta, 61), 1e3, 1e6]:
            got = _k.compatibility(x, theta, slope)
            assert -1.0 <= got <= 1.0  # rounds to the limits far from theta
            assert got == pytest.approx(naive.compatibility(x, theta, slope), rel=0, abs=1e-15)
        assert _k.compatibility(theta, theta, slope) == 0.0


class TestCountStopsAtTheLimit:
    """Issue 20: the exact count behind the max_interactions refusal went on to the end
    (1,500 identical points: hours); with a limit it stops as soon as it passes it."""

    @pytest.mark.parametrize("seed,n", PROBLEMS)
    def test_limit(self, seed, n):
        p = params(**CONFIGS["default"])
        net = kernel_network(*make_problem(seed, n), p)
        args = (net["ni"], net["nk"], net["start"], net["nb_off"], net["nb_idx"])
        exact = _k.count_interactions(*args)
        assert _k.count_interactions(*args, -1) == exact
        for limit in (exact, exact + 1, 10**18):
            assert _k.count_interactions(*args, limit) == exact  # within it: exact
        for limit in (0, exact // 2, exact - 1):
            if limit < exact:
                got = _k.count_interactions(*args, limit)
                assert limit < got <= exact  # past it: stopped, above the limit

    @pytest.mark.skipif(os.environ.get("NUMBA_DISABLE_JIT", "0") not in ("", "0"),
                        reason="a time limit for the compiled kernels")
    def test_crowded_points_are_refused_within_a_second(self):
        import time

        import hopmatch
        from hopmatch.errors import BudgetExceededError

        pts = np.full((1500, 2), 100.0, np.float32)
        desc = np.tile(np.random.default_rng(0).normal(size=(1, 25)), (1500, 1)).astype(
            np.float32)
        hopmatch.hopfield_match(pts[:50], pts[:50] - [10, 0], desc[:50], desc[:50],
                                max_disparity=20)  # compiled and cached before timing
        t0 = time.process_time()  # CPU seconds, every thread: steady under load
        with pytest.raises(BudgetExceededError, match="max_interactions=100000000") as exc:
            hopmatch.hopfield_match(pts, pts - [10, 0], desc, desc, max_disparity=20)
        assert time.process_time() - t0 < 1.0 and exc.value.argument == "max_interactions"
