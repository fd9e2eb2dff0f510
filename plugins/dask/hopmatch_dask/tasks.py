"""What runs on the workers: read a pair, match it, return arrays or the result table.

Only these functions (and the arguments) travel to the workers, which need hopmatch and
this package installed, and must see the image paths (a shared file system).
"""

from __future__ import annotations

import os
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

import hopmatch
from hopmatch.errors import HopmatchError, InvalidArgumentError
from hopmatch.imageio import DEFAULT_MAX_PIXELS, ImageReadError, read_image

from .results import matches_table

__all__ = ["ImageReadError", "PairResult", "batch_task", "match_pair", "read_image"]


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
    """

    name: str
    matched_left: np.ndarray
    matched_right: np.ndarray
    disparities: np.ndarray
    distances: np.ndarray
    seconds: float = 0.0
    worker: str = field(default="")

    def to_csv(self) -> str:
        """The table ``hopmatch match`` writes to matches.csv."""
        return matches_table(self.matched_left, self.matched_right, self.disparities,
                             self.distances)


def _image(value, side: str, max_pixels: int | None = DEFAULT_MAX_PIXELS) -> np.ndarray:
    if isinstance(value, np.ndarray):
        return value
    if isinstance(value, (str, os.PathLike)):
        return read_image(value, max_pixels=max_pixels)  # refused from the header if larger
    raise InvalidArgumentError(f"`{side}` must be an image path or a numpy array, got "
                               f"{type(value).__name__}")


def _worker_id() -> str:
    import socket

    return f"{socket.gethostname()}:{os.getpid()}"


def match_pair(pair, params: dict) -> PairResult:
    """Match one :class:`~hopmatch_dask.Pair` (on a worker); errors propagate."""
    t0 = time.perf_counter()
    max_pixels = params.get("max_pixels", DEFAULT_MAX_PIXELS)
    left = _image(pair.left, "left", max_pixels)
    right = _image(pair.right, "right", max_pixels)
    res = hopmatch.match_stereo(left, right, **params)
    return PairResult(pair.name, res.matched_left, res.matched_right, res.disparities,
                      res.distances, time.perf_counter() - t0, _worker_id())


def batch_task(pair, params: dict) -> dict:
    """Match one pair of a batch; never raises for a bad pair.

    Returns ``{"status": "ok", "csv": <table>, "matches": M, "seconds": s}`` or
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
            "seconds": res.seconds, "worker": res.worker}
