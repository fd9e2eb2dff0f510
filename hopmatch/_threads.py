"""hopmatch's thread setting, as OpenCV's: :func:`setNumThreads` / :func:`getNumThreads`.

hopmatch runs work on several threads where the parts are independent and the kernels
release the GIL (every kernel is ``nogil``): the left and right detection of
:func:`~hopmatch.match_stereo`, and the per-point kernels of its guided pass and refinement,
cut into contiguous chunks of points. Each point's result is computed by the same code in
the same order whatever the chunking, so results are bit-identical for any thread count.
Numba's own ``parallel=True`` is not used: it would compile every such kernel a second
time, for a threading layer, and cost seconds on the first run.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import threading
from concurrent.futures import ThreadPoolExecutor

from .errors import InvalidArgumentError, InvalidTypeError

__all__ = ["current_threads", "getNumThreads", "map_chunks", "map_ranges", "resolve_threads",
           "row_order", "run_both", "setNumThreads", "using_threads"]

#: Fewest points per chunk worth a thread (below, the hand-off costs more than it saves).
MIN_CHUNK = 256

_state = {"threads": None}  # None: all cores (os.sched_getaffinity or os.cpu_count)
#: The thread count of the call in progress (:func:`using_threads`); None: getNumThreads().
_current: contextvars.ContextVar = contextvars.ContextVar("hopmatch_threads", default=None)
_pool_lock = threading.Lock()
_pool: dict = {}


def _cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not Linux
        return max(1, os.cpu_count() or 1)


def setNumThreads(nthreads: int) -> None:  # noqa: N802
    """Set how many threads hopmatch uses, as ``cv2.setNumThreads`` does for OpenCV.

    ``nthreads > 0``: at most that many; ``0``: one (no threads, as OpenCV's 0 runs
    everything sequentially); negative: back to the default, every core this process may
    run on. Results do not depend on it (bit-identical for any count). It does not change
    OpenCV's own setting (``cv2.setNumThreads``), which its filters use inside one call.
    """
    if isinstance(nthreads, bool) or not isinstance(nthreads, int):
        raise InvalidTypeError(f"`nthreads` must be an int, got {nthreads!r}")
    _state["threads"] = None if nthreads < 0 else max(1, nthreads)


def getNumThreads() -> int:  # noqa: N802
    """How many threads hopmatch uses (:func:`setNumThreads`; default: every core)."""
    n = _state["threads"]
    return _cores() if n is None else n


def resolve_threads(threads, name: str = "threads") -> int:
    """``threads`` as a count >= 1: None gives :func:`getNumThreads`; errors name ``name``."""
    if threads is None:
        return getNumThreads()
    if isinstance(threads, bool) or not isinstance(threads, int):
        raise InvalidTypeError(f"`{name}` must be None or an int >= 1, got {threads!r}")
    if threads < 1:
        raise InvalidArgumentError(f"`{name}` must be None or an int >= 1, got {threads}")
    return threads


def current_threads() -> int:
    """The thread count of the call in progress: the ``threads`` of the enclosing
    :func:`using_threads` (``match_stereo(threads=...)``), else :func:`getNumThreads`."""
    n = _current.get()
    return getNumThreads() if n is None else n


@contextlib.contextmanager
def using_threads(threads: int):
    """Within the block (and this thread's context), :func:`current_threads` is ``threads``."""
    token = _current.set(threads)
    try:
        yield threads
    finally:
        _current.reset(token)


def _executor() -> ThreadPoolExecutor:
    """The process's pool of worker threads (made on first use; ``_cores()`` workers)."""
    with _pool_lock:
        pool = _pool.get(os.getpid())  # a forked child makes its own
        if pool is None:
            pool = _pool[os.getpid()] = ThreadPoolExecutor(
                max_workers=max(2, _cores()), thread_name_prefix="hopmatch")
        return pool


def run_both(first, second, threads: int):
    """``(first(), second())``, the two on two threads when ``threads >= 2``.

    ``first`` runs in the calling thread, ``second`` in a worker; when ``first`` raises,
    ``second`` is waited for and ``first``'s error is raised, so errors are those of the
    sequential order whatever the thread count.
    """
    if threads < 2:
        return first(), second()
    future = _executor().submit(contextvars.copy_context().run, second)
    try:
        a = first()
    except BaseException:
        future.cancel()
        if not future.cancelled():
            future.exception()  # wait: no work outlives the call
        raise
    return a, future.result()


def map_chunks(fn, split, threads: int | None = None, order=None):
    """``fn(*split)`` computed on contiguous chunks of the rows of ``split`` in up to
    ``threads`` threads (None: :func:`current_threads`), its outputs (a tuple of arrays)
    concatenated in row order.

    ``split`` are arrays with one row per item, sliced per chunk (slices of C-contiguous
    arrays along the first axis stay C-contiguous, so a kernel behind ``fn`` sees the types
    it was compiled for). ``fn`` must compute each row from that row's inputs alone: then
    the result is bit-identical to ``fn(*split)``. Chunks have at least :data:`MIN_CHUNK`
    rows.

    ``order``: a permutation of the rows (:func:`row_order`) in which ``fn`` sees them (the
    outputs are put back in the rows' own order): items whose windows lie on nearby image
    rows then follow one another, and a kernel that reads windows around each item finds
    them in the CPU's caches rather than in memory (a quarter to a third off the guided
    pass's row search on motorcycle). The result does not depend on it, since each row is
    computed on its own.
    """
    import numpy as np

    if order is not None:
        order = np.asarray(order, dtype=np.intp)
        outs = map_chunks(fn, [np.ascontiguousarray(a[order]) for a in split], threads)
        back = []
        for o in outs:
            b = np.empty_like(o)
            b[order] = o
            back.append(b)
        return tuple(back)
    n = len(split[0])
    chunks = min(current_threads() if threads is None else threads, n // MIN_CHUNK)
    if chunks < 2:
        return fn(*split)
    edges = [n * k // chunks for k in range(chunks + 1)]
    parts = [[a[lo:hi] for a in split] for lo, hi in zip(edges[:-1], edges[1:])]
    pool = _executor()
    futures = [pool.submit(fn, *p) for p in parts[1:]]
    try:
        first = fn(*parts[0])
    finally:
        rest = [f.result() for f in futures]
    outs = [first, *rest]
    return tuple(np.concatenate([o[k] for o in outs]) for k in range(len(first)))


def map_ranges(fn, n: int, threads: int | None = None) -> list:
    """``[fn(lo, hi) for (lo, hi) in ranges]``: ``fn`` called on contiguous ranges that
    cut ``0 .. n`` into up to ``threads`` parts (None: :func:`current_threads`) of at least
    :data:`MIN_CHUNK` items, in worker threads, the outputs in range order (one range,
    ``(0, n)``, in the calling thread when a split does not pay). For kernels whose inputs
    are not all cut alike (CSR offsets, one more row than items): the caller slices them
    in ``fn`` and joins the outputs."""
    chunks = min(current_threads() if threads is None else threads, n // MIN_CHUNK)
    if chunks < 2:
        return [fn(0, n)]
    edges = [n * k // chunks for k in range(chunks + 1)]
    pool = _executor()
    futures = [pool.submit(fn, lo, hi) for lo, hi in zip(edges[1:-1], edges[2:])]
    try:
        first = fn(edges[0], edges[1])
    finally:
        rest = [f.result() for f in futures]
    return [first, *rest]


def row_order(y):
    """The permutation that sorts items by their image row ``floor(y)`` (stable: items of
    one row keep their order; NaN last), for :func:`map_chunks`'s ``order``.

    Rows spanning fewer than 2**16 values (every image) are sorted as uint16 offsets from
    the first row, which NumPy's stable sort orders by radix sort: the same permutation
    (the same keys in the same order, ties kept), five times faster than sorting floats."""
    import numpy as np

    rows = np.floor(np.asarray(y, dtype=np.float64))
    if len(rows):
        lo, hi = rows.min(), rows.max()  # NaN when any is NaN
        if np.isfinite(lo) and np.isfinite(hi) and hi - lo < 2**16:
            return np.argsort((rows - lo).astype(np.uint16), kind="stable")
    return np.argsort(rows, kind="stable")
