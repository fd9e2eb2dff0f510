"""The network kernels (``hopmatch._kernels.network``, eqs. 11-13) against the dense reference
of ``tests/naive.py``: energy, local fields, the dynamics and its visit order."""

from __future__ import annotations

import naive
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from network_problems import (
    CONFIGS,
    PROBLEMS,
    counts,
    kernel_network,
    make_problem,
    params,
    python_version,
)

from hopmatch._kernels import network as _k
from hopmatch.matching.network import run_hopfield_network

#: SplitMix64 (``splitmix64``) wraps its uint64 arithmetic by design; run as plain Python
#: (``NUMBA_DISABLE_JIT=1``), NumPy's scalars warn each time it does.
pytestmark = pytest.mark.filterwarnings("ignore:overflow encountered in scalar:RuntimeWarning")


@pytest.fixture(scope="module", params=sorted(CONFIGS))
def config(request):
    """Each parameter set of ``CONFIGS`` in turn."""
    return request.param


class TestDenseReference:
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
        """The kernels as plain Python (``py_func``, what the ``NUMBA_DISABLE_JIT=1`` step
        of ``.ci/run`` runs for all of tests/_kernels) agree with the dense reference as the
        compiled kernels do."""
        p = params(**CONFIGS["paper"])
        problem = make_problem(seed, n)
        net = kernel_network(*problem, p)
        t = naive.dense_network(*problem, p)["T"]
        v = (np.random.default_rng(0).random(len(net["ni"])) < 0.4).astype(np.uint8)
        row, col = counts(net, v, n, n)
        args = (v, net["ni"], net["nk"], net["off"], net["idx"], net["w"], row, col, 1.0, 2.0)
        assert _k.local_fields(*args) == pytest.approx(t @ v + 2.0, rel=0, abs=1e-9)
        assert _k.network_energy(*args) == pytest.approx(naive.energy(t, 2.0, v), abs=1e-8)
        assert python_version(_k.local_fields)(*args) == pytest.approx(t @ v + 2.0, rel=0,
                                                                       abs=1e-9)
        assert python_version(_k.network_energy)(*args) == pytest.approx(
            naive.energy(t, 2.0, v), abs=1e-8)

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


def test_local_field_is_the_field_of_local_fields_and_of_the_dynamics():
    """Eq. 12's one expression (``local_field``): ``local_fields`` gives it for every neuron
    from the summed couplings, and a network the dynamics left at a fixed point has no
    neuron whose field says otherwise."""
    p = params(**CONFIGS["paper"])
    problem = make_problem(2, 25)
    net = kernel_network(*problem, p)
    rng = np.random.default_rng(3)
    v = (rng.random(len(net["ni"])) < 0.4).astype(np.uint8)
    row, col = counts(net, v, 25, 25)
    u = _k.local_fields(v, net["ni"], net["nk"], net["off"], net["idx"], net["w"], row, col,
                        1.0, 2.0)
    for q in range(len(v)):
        coupling = 0.0
        for e in range(net["off"][q], net["off"][q + 1]):
            if v[net["idx"][e]]:
                coupling += np.float64(net["w"][e])
        want = coupling - 1.0 * (row[net["ni"][q]] - v[q] + col[net["nk"][q]] - v[q]) + 2.0
        assert _k.local_field(coupling, v[q], row[net["ni"][q]], col[net["nk"][q]], 1.0,
                              2.0) == want
        assert u[q] == pytest.approx(want, rel=0, abs=1e-12)
    v, _, _, converged, _ = _k.run_network(
        np.zeros(len(v), np.uint8), net["ni"], net["nk"], net["start"], net["off"],
        net["idx"], net["w"], 25, 25, 1.0, 2.0, np.uint64(0), 0, 10**6, False)
    assert converged and v.any()
    row, col = counts(net, v, 25, 25)
    u = _k.local_fields(v, net["ni"], net["nk"], net["off"], net["idx"], net["w"], row, col,
                        1.0, 2.0)
    assert not (v.astype(bool) & (u < 0)).any() and not (~v.astype(bool) & (u > 0)).any()
