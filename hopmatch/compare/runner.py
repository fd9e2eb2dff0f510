"""The runner: methods on scenes, scored against the ground truth, one row per pair.

:func:`compare` runs methods on scenes and scores them with
:func:`hopmatch.evaluate.score_matches` at :data:`THRESHOLDS` (vertical tolerance = the
threshold), on one OpenCV thread, after an untimed warm-up.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable

import cv2
import numpy as np

from .._threads import getNumThreads, setNumThreads
from ..datasets import StereoScene, load
from ..errors import InvalidArgumentError, InvalidTypeError
from ..evaluate import score_matches
from .methods import METHODS, MethodResult, disparity_range

__all__ = ["THRESHOLDS", "compare", "run_method"]

#: Disparity tolerances of the scores, in pixels (the vertical tolerance is the same).
THRESHOLDS = (0.5, 1.0, 2.0)


def _scene(item) -> StereoScene:
    if isinstance(item, StereoScene):
        return item
    if isinstance(item, str):
        return load(item)
    raise InvalidTypeError(
        f"`scenes` must hold scene names or StereoScene objects, got {type(item).__name__}"
    )


def _method(item) -> tuple[str, Callable]:
    if isinstance(item, str):
        if item not in METHODS:
            raise InvalidArgumentError(
                f"unknown method {item!r}; valid methods are {list(METHODS)}"
            )
        return item, METHODS[item]
    if callable(item):
        return getattr(item, "__name__", repr(item)), item
    raise InvalidTypeError(
        f"`methods` must hold method names or callables, got {type(item).__name__}"
    )


@contextlib.contextmanager
def one_thread():
    """Within the block OpenCV and hopmatch run on one thread each (``cv2.setNumThreads(1)``,
    ``hopmatch.setNumThreads(1)``); their counts of before are restored on the way out."""
    old_cv, old_hop = cv2.getNumThreads(), getNumThreads()
    cv2.setNumThreads(1)
    setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(old_cv)
        setNumThreads(old_hop)


def run_method(method, scene) -> MethodResult:
    """Run one method (a name of :data:`METHODS` or a callable) on one scene, one thread."""
    _, fn = _method(method)
    with one_thread():
        out = fn(_scene(scene))
    return MethodResult(*out)


def _warm_scene() -> StereoScene:
    rng = np.random.default_rng(0)
    left = cv2.GaussianBlur((rng.random((96, 128)) * 255).astype(np.uint8), (3, 3), 0)
    right = np.roll(left, -4, axis=1)
    disp = np.full(left.shape, 4.0, np.float32)
    return StereoScene("warm-up", left, right, disp, None, "")


def _score_row(scene: StereoScene, name: str, res: MethodResult, dmax: int) -> dict:
    s = score_matches(res.left_pts, res.right_pts, scene.disparity, thresholds=THRESHOLDS,
                      right_keypoints=res.keypoints_right, left_keypoints=res.keypoints_left)
    rec = s.as_dict()
    row = {
        "scene": scene.name, "method": name,
        "keypoints_left": int(len(res.keypoints_left)),
        "keypoints_right": int(len(res.keypoints_right)),
        "matches": rec["n_matches"], "scored": rec["n_scored"],
    }
    for t in THRESHOLDS:
        for k in ("correct", "precision", "matchable", "recall"):
            row[f"{k}@{t:g}"] = rec[f"{k}@{t:g}"]
    row.update(mean_abs_error=rec["mean_abs_error"], median_abs_error=rec["median_abs_error"],
               max_disparity=dmax, time_ms=res.seconds * 1e3)
    row["result"] = res
    row["score"] = s
    return row


def compare(scenes, methods=None, *, progress: Callable[[str], None] | None = None,
            warmup: bool = True, repeat: int = 1) -> list[dict]:
    """Run ``methods`` on ``scenes`` and score them: one row per (scene, method).

    Parameters
    ----------
    scenes : sequence of str or StereoScene
        Scene names (:func:`hopmatch.datasets.list_scenes`) or loaded scenes.
    methods : sequence of str or callable, optional
        Names of :data:`METHODS` (default: all of them, in its order) or functions
        ``(scene) -> MethodResult``.
    progress : callable, optional
        Called with a short message (``"motorcycle: sift-ratio (5/12)"``) before each run.
    warmup : bool
        First run every method once, untimed, on a tiny synthetic pair (Numba kernels,
        OpenCV's first-call set-up), so the times are steady-state.
    repeat : int
        Run each method this many times per scene and report the shortest time (the
        matches are those of the last run; every method is deterministic).

    Returns
    -------
    rows : list of dict
        The :data:`COLUMNS` (``time_ms``: this run, one OpenCV thread), plus ``"result"``
        (the :class:`MethodResult`) and ``"score"`` (the
        :class:`~hopmatch.evaluate.MatchScore`) for pictures.
    """
    if isinstance(scenes, (str, StereoScene)):
        scenes = [scenes]
    chosen = [_method(m) for m in (list(METHODS) if methods is None else methods)]
    if not chosen:
        raise InvalidArgumentError("`methods` is empty; give at least one method")
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise InvalidArgumentError(f"`repeat` must be a positive integer, got {repeat!r}")
    loaded = [_scene(s) for s in scenes]
    with one_thread():
        if warmup:
            from .. import warmup as compile_kernels

            compile_kernels()
            warm = _warm_scene()
            for name, fn in chosen:
                if progress:
                    progress(f"warming up {name}")
                fn(warm)
        rows = []
        total = len(loaded) * len(chosen)
        for scene in loaded:
            dmax = disparity_range(scene)
            for name, fn in chosen:
                if progress:
                    progress(f"{scene.name}: {name} ({len(rows) + 1}/{total})")
                runs = [MethodResult(*fn(scene)) for _ in range(repeat)]
                best = min(r.seconds for r in runs)
                rows.append(_score_row(scene, name, runs[-1]._replace(seconds=best), dmax))
    return rows
