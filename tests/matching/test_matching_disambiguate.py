"""Section 4's disambiguation (``hopmatch.matching.disambiguate``) against the references of
``tests/naive.py``, and as ``run_hopfield_network`` applies it."""

from __future__ import annotations

import naive
import numpy as np
import pytest
from network_problems import CONFIGS, DEFAULTS, make_problem, params

from hopmatch.matching.disambiguate import (
    disambiguate,
    singular_choice,
    vertically_consistent,
)
from hopmatch.matching.network import run_hopfield_network, vertical_offsets
from hopmatch.matching.params import PRESETS


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
