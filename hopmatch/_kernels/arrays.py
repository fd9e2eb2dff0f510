"""Array helpers the kernels share: binary searches in a sorted range, and a grown copy of
an output buffer (the kernels' outputs grow by doubling)."""

from __future__ import annotations

import numpy as np

from .._config import jit


@jit(inline=True)
def lower_bound(a, lo, hi, value):
    """First index t in [lo, hi) with ``a[t] >= value`` (``hi`` if none); ``a`` sorted."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


@jit(inline=True)
def upper_bound(a, lo, hi, value):
    """First index t in [lo, hi) with ``a[t] > value`` (``hi`` if none); ``a`` sorted."""
    while lo < hi:
        mid = (lo + hi) >> 1
        if a[mid] <= value:
            lo = mid + 1
        else:
            hi = mid
    return lo


@jit
def grown(a, n, cap):
    """A copy of ``a[:n]`` with room for ``cap`` entries."""
    out = np.empty(cap, dtype=a.dtype)
    for t in range(n):  # an element loop: a slice assignment compiles a shape check
        out[t] = a[t]
    return out
