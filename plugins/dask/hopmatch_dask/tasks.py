"""What runs on the workers: read a pair, match it, return arrays or the result table.

Only these functions (and the arguments) travel to the workers, which need hopmatch and
this package installed, and must see the image paths (a shared file system).
"""

from __future__ import annotations

import multiprocessing
import os
import time
import traceback
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import hopmatch
from hopmatch.errors import HopmatchError, InvalidTypeError, collect_warnings
from hopmatch.imageio import DEFAULT_MAX_PIXELS, ImageReadError, read_image

from .results import matches_table, short_text

__all__ = ["ImageReadError", "PairResult", "batch_task", "give_warnings", "match_pair",
           "read_image", "warnings_text"]


@dataclass(eq=False)
class PairResult:
    """The matches of one pair (what :func:`hopmatch.match_stereo` found).

    Attributes
    ----------
    name : str
    matched_left, matched_right : (M, 2) float32 ndarray
        (x, y) of each match.
    disparities, distances : (M,) float32 ndarray
    seconds : float
        Time spent reading and matching on the worker.
    worker : str
        Host and process id of the worker that matched it.
    warnings : tuple of (category, message)
        The warnings :func:`hopmatch.match_stereo` gave for the pair (a
        :class:`~hopmatch.errors.FewMatchesWarning` says why a pair has no or few
        matches). On a worker they are kept, not shown; when the result is received in
        another process (``future.result()``, ``client.gather``, a bag computed on a
        cluster), they are given there with ``warnings.warn`` (same category and
        message). Matched in the caller's own process, they were given at once.
        :func:`give_warnings` gives them on demand.
    """

    name: str
    matched_left: np.ndarray
    matched_right: np.ndarray
    disparities: np.ndarray
    distances: np.ndarray
    seconds: float = 0.0
    worker: str = field(default="")
    warnings: tuple = ()

    def __setstate__(self, state) -> None:
        """Unpickled in another process than the worker's (the client, after
        ``future.result()`` or ``client.gather``): give the worker's warnings again."""
        self.__dict__.update(state)
        if self.warnings and self.worker != _worker_id():
            give_warnings(self.warnings, stacklevel=3)

    def to_csv(self) -> str:
        """The table ``hopmatch match`` writes to matches.csv."""
        return matches_table(self.matched_left, self.matched_right, self.disparities,
                             self.distances)


def _image(value, side: str, max_pixels: int | None = DEFAULT_MAX_PIXELS) -> np.ndarray:
    if isinstance(value, np.ndarray):
        return value
    if isinstance(value, (str, os.PathLike)):
        return read_image(value, max_pixels=max_pixels)  # refused from the header if larger
    raise InvalidTypeError(f"`{side}` must be an image path or a numpy array, got "
                           f"{type(value).__name__}", argument=side)


def _worker_id() -> str:
    import socket

    return f"{socket.gethostname()}:{os.getpid()}"


# -- warnings carried back to the client --------------------------------------------------
#
# In a worker process (a distributed worker, or a process of a multiprocessing pool), the
# warnings hopmatch gives while matching a pair are collected
# (:func:`hopmatch.errors.collect_warnings`: not shown there, whatever the worker's filters)
# and travel with the result: the client gives them. In the client's own process (a bag
# computed by the synchronous scheduler) they are given at once, as usual, and kept in the
# result as well.


def _in_worker_process() -> bool:
    if multiprocessing.parent_process() is not None:
        return True
    try:
        from distributed import get_worker

        get_worker()
    except (ImportError, ValueError):
        return False
    return True


def give_warnings(caught, stacklevel: int = 2) -> None:
    """Give again, with ``warnings.warn``, the ``(category, message)`` pairs of ``caught``
    (:attr:`PairResult.warnings`, or a batch task's)."""
    for category, message in caught:
        warnings.warn(message, category, stacklevel=stacklevel)


def warnings_text(caught) -> str:
    """``caught`` as one line for summary.csv: ``"Category: message"`` joined by ``" | "``,
    cut to :data:`~hopmatch_dask.results.MAX_MESSAGE_CHARS` characters.

    Examples
    --------
    >>> from hopmatch.errors import FewMatchesWarning
    >>> warnings_text([(FewMatchesWarning, "no matches:  flat")])
    'FewMatchesWarning: no matches: flat'
    """
    return short_text(" | ".join(f"{getattr(c, '__name__', 'Warning')}: {m}"
                                 for c, m in caught))


def match_pair(pair, params: dict) -> PairResult:
    """Match one :class:`~hopmatch_dask.Pair` (on a worker); errors propagate, warnings are
    given and kept in :attr:`PairResult.warnings`."""
    t0 = time.perf_counter()
    max_pixels = params.get("max_pixels", DEFAULT_MAX_PIXELS)
    with collect_warnings() as caught:
        left = _image(pair.left, "left", max_pixels)
        right = _image(pair.right, "right", max_pixels)
        res = hopmatch.match_stereo(left, right, **params)
    if not _in_worker_process():  # the caller's own process: given here, as usual
        for give in caught:
            give()
    return PairResult(pair.name, res.matched_left, res.matched_right, res.disparities,
                      res.distances, time.perf_counter() - t0, _worker_id(),
                      tuple((category, message) for category, message in caught))


def batch_task(pair, params: dict) -> dict:
    """Match one pair of a batch; never raises for a bad pair.

    Returns ``{"status": "ok", "csv": <table>, "matches": M, "seconds": s, "warnings":
    [(category, message), ...]}`` or
    ``{"status": "failed", "error": <one line>, "seconds": s}``: a corrupt or missing image
    is a result of the batch, not a reason to retry or to stop it.
    """
    t0 = time.perf_counter()
    try:
        res = match_pair(pair, params)
    except HopmatchError as exc:
        return {"status": "failed", "error": " ".join(str(exc).split()),
                "seconds": time.perf_counter() - t0, "worker": _worker_id()}
    except Exception as exc:  # a bug: report it with the frame it came from, go on
        where = traceback.extract_tb(exc.__traceback__)[-1]
        return {"status": "failed",
                "error": f"internal error: {type(exc).__name__}: {' '.join(str(exc).split())} "
                         f"({Path(where.filename).name}:{where.lineno})",
                "seconds": time.perf_counter() - t0, "worker": _worker_id()}
    return {"status": "ok", "csv": res.to_csv(), "matches": int(len(res.disparities)),
            "seconds": res.seconds, "worker": res.worker,
            "warnings": [(c, short_text(m)) for c, m in res.warnings]}
