"""Random stereo problems and the sparse network built from them step by step, shared by the
kernel tests (tests/_kernels/) and the matching tests (tests/matching/)."""

from __future__ import annotations

import numpy as np

from hopmatch._kernels import interactions as _ki
from hopmatch._kernels import neighbours as _kn
from hopmatch.matching.network import _starts, candidate_pairs, similarity_distance
from hopmatch.matching.params import MATCHER_PARAMS, PRESETS


def python_version(kernel):
    """The plain-Python function of a kernel (``py_func``; the kernel itself when
    ``NUMBA_DISABLE_JIT=1`` left it uncompiled)."""
    return getattr(kernel, "py_func", kernel)


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
    """The defaults with ``overrides``, the range resolved as the network takes it (a given
    max_disparity with min_disparity None means 0, as ``match_pair`` resolves it)."""
    p = dict(DEFAULTS)
    p.update(overrides)
    if p["max_disparity"] is not None and p["min_disparity"] is None:
        p["min_disparity"] = 0.0
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
    sim = (similarity_distance(desc_l, desc_r, ni, nk, gain_tolerance=p["gain_tolerance"])
           if len(ni) else np.zeros(0))
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
    nb_off, nb_idx = _kn.neighbour_lists(left, np.float32(p["neighbour_width"] / 2),
                                         np.float32(p["neighbour_height"] / 2))
    n_inter = _ki.count_interactions(ni, nk, start, nb_off, nb_idx)
    off, idx, w = _ki.fill_interactions(left, right, ni, nk, start, nb_off, nb_idx,
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


PROBLEMS = [(0, 8), (1, 15), (2, 25), (3, 20)]


def brute_force_interactions(left, right, p):
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
