"""Kernels of SPEC eqs. 11-13: the energy, the local fields and the asynchronous dynamics of
the sparse Hopfield network.

Neurons exist only for candidate pairs (i, k) (:mod:`.candidates`); interactions only between
a neuron (i, k) and the neurons (j, l) of i's left neighbours j (:mod:`.interactions`).
Everything is stored as CSR arrays whose size is the number of candidates and interactions;
nothing is of size Nl x Nr x Nl x Nr.
"""

from __future__ import annotations

import numpy as np

from .._config import jit
from .neighbours import transposed_lists


@jit(inline=True)
def splitmix64(state):
    """One step of SplitMix64: returns (new state, random 64-bit value)."""
    state = state + np.uint64(0x9E3779B97F4A7C15)
    z = state
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return state, z ^ (z >> np.uint64(31))


@jit(inline=True)
def shuffle(perm, state):
    """Fisher-Yates shuffle of ``perm`` in place with SplitMix64; returns the new state."""
    for a in range(perm.shape[0] - 1, 0, -1):
        state, r = splitmix64(state)
        b = np.int64(r % np.uint64(a + 1))
        tmp = perm[a]
        perm[a] = perm[b]
        perm[b] = tmp
    return state


@jit(inline=True)
def local_field(coupling, v, row_count, col_count, unique_w, bias):
    """Eq. 12's bracket for one neuron (i, k) in state ``v``: ``u = sum_(j,l) T_ik,jl V_jl +
    I`` with ``T = C - w (delta_ij + delta_kl)`` and ``T_ik,ik = 0``, that is ``coupling -
    unique_w (row_count - v + col_count - v) + bias``.

    ``coupling`` is ``sum_(j,l) C_ik,jl V_jl`` over the neuron's stored interactions,
    ``row_count`` and ``col_count`` the active neurons of left point i and of right point k
    (its own state among them: ``- v`` leaves it out). The one expression of the field,
    for :func:`local_fields` and the dynamics of :func:`run_network` alike; inlined, so
    each rounds it as when it held its own copy.
    """
    return coupling - unique_w * (row_count - v + col_count - v) + bias


@jit
def local_fields(v, ni, nk, off, idx, w, row, col, unique_w, bias):
    """Eq. 12's bracket for every neuron (:func:`local_field`), the couplings summed in
    float64 over the CSR interactions ``(off, idx, w)``; ``row``/``col`` the active
    neurons of each left/right point in the state ``v``."""
    n = ni.shape[0]
    u = np.empty(n, dtype=np.float64)
    for p in range(n):
        s = 0.0
        for e in range(off[p], off[p + 1]):
            if v[idx[e]]:
                s += np.float64(w[e])
        u[p] = local_field(s, v[p], row[ni[p]], col[nk[p]], unique_w, bias)
    return u


@jit
def network_energy(v, ni, nk, off, idx, w, row, col, unique_w, bias):
    """Eq. 11: ``E = -1/2 sum T V V - sum I V`` (with the uniqueness weight ``unique_w``)."""
    pair = 0.0
    active = 0
    for p in range(ni.shape[0]):
        if v[p]:
            active += 1
            for e in range(off[p], off[p + 1]):
                if v[idx[e]]:
                    pair += np.float64(w[e])
    unique = 0.0
    for i in range(row.shape[0]):
        unique += row[i] * (row[i] - 1)
    for k in range(col.shape[0]):
        unique += col[k] * (col[k] - 1)
    return -0.5 * pair + 0.5 * unique_w * unique - bias * active


@jit
def run_network(v0, ni, nk, start, off, idx, w, n_left, n_right, unique_w, bias, seed,
                stable_iterations, max_iterations, record_energy):
    """Asynchronous binary dynamics (eq. 13) from the state ``v0`` (the paper: all zero).

    One *iteration* visits one left point i, drawn from a random permutation of the left
    points that have neurons (a new permutation each sweep, SplitMix64 seeded by ``seed``),
    and updates its neurons (i, k) in increasing k with eq. 13:
    ``V <- 1 if u > 0, V <- 0 if u < 0, unchanged if u = 0``. Local fields are kept up to
    date incrementally, so an update costs O(1) and a flip O(its interactions).

    Stops when a whole sweep changed nothing (a fixed point), when ``stable_iterations``
    consecutive iterations changed nothing (if > 0), or after ``max_iterations``.

    A visit reads only its neurons' fields, states and column counts and its row count; a
    left point whose last visit changed nothing and none of whose inputs changed since is
    *clean*, and its visit is counted without recomputing it (it would change nothing
    again). A flip marks dirty the left points of its interaction partners (their fields)
    and of the neurons in its column (their column count). States, iteration and sweep
    counts and the energy trace are those of visiting every point in full.

    Returns ``(v, iterations, sweeps, converged, energy_trace)``; ``energy_trace[t]`` is the
    energy after iteration t (index 0: the start), empty unless ``record_energy``.
    """
    n = ni.shape[0]
    v = v0.copy()
    field = np.zeros(n, dtype=np.float64)
    row = np.zeros(n_left, dtype=np.int64)
    col = np.zeros(n_right, dtype=np.int64)
    for p in range(n):
        if v[p]:
            row[ni[p]] += 1
            col[nk[p]] += 1
            for e in range(off[p], off[p + 1]):
                field[idx[e]] += w[e]
    col_start, col_left = transposed_lists(start, nk, n_right)  # the left points of each column
    clean = np.zeros(n_left, dtype=np.uint8)
    n_active_left = 0
    for i in range(n_left):
        if start[i + 1] > start[i]:
            n_active_left += 1
    perm = np.empty(n_active_left, dtype=np.int64)
    c = 0
    for i in range(n_left):
        if start[i + 1] > start[i]:
            perm[c] = i
            c += 1
    trace = np.empty(max_iterations + 1 if record_energy else 0, dtype=np.float64)
    energy = 0.0  # tracked only for the trace (the starting value costs a pass over the state)
    if record_energy:
        energy = network_energy(v, ni, nk, off, idx, w, row, col, unique_w, bias)
        trace[0] = energy
    state = np.uint64(seed)
    iterations = 0
    sweeps = 0
    unchanged_run = 0
    converged = False
    while iterations < max_iterations and n_active_left > 0:
        state = shuffle(perm, state)
        sweeps += 1
        sweep_changed = False
        for t in range(n_active_left):
            if iterations >= max_iterations:
                break
            i = perm[t]
            changed = False
            if not clean[i]:
                for p in range(start[i], start[i + 1]):
                    k = nk[p]
                    u = local_field(field[p], v[p], row[i], col[k], unique_w, bias)
                    new = v[p]
                    if u > 0.0:
                        new = 1
                    elif u < 0.0:
                        new = 0
                    if new != v[p]:
                        dv = 1.0 if new == 1 else -1.0
                        energy -= u * dv
                        v[p] = new
                        row[i] += 1 if new == 1 else -1
                        col[k] += 1 if new == 1 else -1
                        for e in range(off[p], off[p + 1]):
                            q = idx[e]
                            field[q] += dv * w[e]
                            clean[ni[q]] = 0
                        for m in range(col_start[k], col_start[k + 1]):
                            clean[col_left[m]] = 0
                        changed = True
                clean[i] = 0 if changed else 1
            iterations += 1
            if record_energy:
                trace[iterations] = energy
            if changed:
                sweep_changed = True
                unchanged_run = 0
            else:
                unchanged_run += 1
                if stable_iterations > 0 and unchanged_run >= stable_iterations:
                    converged = True
                    break
        if converged:
            break
        if not sweep_changed:
            converged = True
            break
    return v, iterations, sweeps, converged, trace[: iterations + 1 if record_energy else 0]
