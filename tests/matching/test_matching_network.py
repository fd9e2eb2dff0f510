"""``hopmatch.matching.network.run_hopfield_network`` at a size the dense reference cannot
have: the interactions it stores and the ``max_interactions`` budget."""

from __future__ import annotations

import pytest
from network_problems import brute_force_interactions, make_problem, params

from hopmatch.errors import BudgetExceededError
from hopmatch.matching.network import run_hopfield_network


class TestSparsity:
    def test_2000_points(self):
        """2000 points a side: a dense T would have (Nl Nr)^2 = 1.6e13 entries; the sparse
        network stores exactly the brute-force count of interactions."""
        n = 2000
        left, right, dl, dr = make_problem(11, n, width=400.0, height=400.0, integer=True)
        p = params(max_disparity=20.0, max_vertical=2.0, similarity_gate=None,
                   max_iterations=20000)
        count, bound = brute_force_interactions(left, right, p)
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
