"""Precision against the number of correct matches as each method's own threshold moves:
hopmatch by a threshold on ``result.distances``, SIFT + band by Lowe's ratio, StereoSGBM by
its uniqueness ratio (the density-against-error curves stereo methods are compared with).

:func:`precision_curves` pools the scenes: at each threshold, the correct@1 matches and the
scored matches of every scene are summed, and precision@1 is their ratio. Matches are scored
as :func:`hopmatch.compare.compare` scores them (:func:`hopmatch.evaluate.score_matches` at
1 px, vertical tolerance 1 px).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from ..datasets import StereoScene
from ..evaluate import score_matches
from .methods import hopmatch_scored, sgbm_uniqueness, sift_ratio_scored

__all__ = ["CURVE_METHODS", "DISTANCE_THRESHOLDS", "SGBM_UNIQUENESS", "SIFT_RATIOS",
           "format_curves_markdown", "precision_curves"]

#: Thresholds on hopmatch's ``distances`` (keep ``distance <= t``); with the default
#: refinement a distance estimates the probability that the match is wrong.
DISTANCE_THRESHOLDS = (0.002, 0.003, 0.005, 0.0075, 0.01, 0.015, 0.02, 0.03, 0.05, 0.1, 1.0)
#: Lowe ratios of SIFT + band (keep ``ratio < t``; 0.75 is ``sift-ratio-band``).
SIFT_RATIOS = (0.4, 0.5, 0.6, 0.7, 0.75, 0.8, 0.85, 0.9, 0.95, 1.01)
#: ``uniquenessRatio`` values of StereoSGBM (10 is ``sgbm``), strictest first.
SGBM_UNIQUENESS = (90, 70, 50, 30, 20, 15, 10, 5, 2, 0)
#: The methods that have a curve, with the parameter each one sweeps.
CURVE_METHODS = {"hopmatch": "distance <=", "sift-ratio-band": "ratio <",
                 "sgbm": "uniqueness"}


def _correct(scene: StereoScene, res) -> tuple[np.ndarray, np.ndarray]:
    """``(scored, correct)`` flags of each match of ``res`` at 1 px."""
    sc = score_matches(res.left_pts, res.right_pts, scene.disparity, thresholds=(1.0,))
    correct = np.zeros(len(res.left_pts), dtype=bool)
    dy = np.abs(res.left_pts[sc.scored, 1] - res.right_pts[sc.scored, 1])
    correct[np.flatnonzero(sc.scored)] = (np.abs(sc.errors) <= 1.0) & (dy <= 1.0)
    return sc.scored, correct


def _thresholded(method: str, parameter: str, thresholds, scored_by_scene,
                 strict: bool) -> list[dict]:
    rows = []
    for t in thresholds:
        c = s = m = 0
        for scored, correct, score in scored_by_scene:
            keep = score < t if strict else score <= t
            m += int(keep.sum())
            s += int((keep & scored).sum())
            c += int((keep & correct).sum())
        rows.append({"method": method, "parameter": parameter, "value": float(t),
                     "matches": m, "scored": s, "correct@1": c,
                     "precision@1": c / s if s else float("nan")})
    return rows


def precision_curves(scenes: Sequence[StereoScene], methods: Sequence[str] | None = None,
                     *, progress: Callable[[str], None] | None = None) -> list[dict]:
    """One row per (method, threshold), pooled over ``scenes``.

    Parameters
    ----------
    scenes : sequence of StereoScene
        Loaded scenes with ground truth.
    methods : sequence of str, optional
        Names among :data:`CURVE_METHODS` (default: all of them); other names are skipped.
    progress : callable, optional
        Called with a short message before each run.

    Returns
    -------
    list of dict
        ``method``, ``parameter`` (what is thresholded), ``value``, and the pooled
        ``matches``, ``scored``, ``correct@1`` and ``precision@1`` of the matches kept,
        in the order of the method's thresholds (from strictest to most lenient).
    """
    wanted = [m for m in (methods or CURVE_METHODS) if m in CURVE_METHODS]
    say = progress or (lambda _msg: None)
    rows: list[dict] = []
    for method in wanted:
        per_scene = []
        for scene in scenes:
            say(f"curves: {scene.name}: {method}")
            if method == "sgbm":
                # one run per uniqueness: the score is the strictest value a match survives
                keep_at = {}
                for u in SGBM_UNIQUENESS:
                    res = sgbm_uniqueness(scene, u)
                    scored, correct = _correct(scene, res)
                    keep_at[u] = (len(res.left_pts), int(scored.sum()), int(correct.sum()))
                per_scene.append(keep_at)
                continue
            fn = hopmatch_scored if method == "hopmatch" else sift_ratio_scored
            res, score = fn(scene)
            per_scene.append((*_correct(scene, res), score))
        if method == "sgbm":
            for u in SGBM_UNIQUENESS:
                m = sum(k[u][0] for k in per_scene)
                s = sum(k[u][1] for k in per_scene)
                c = sum(k[u][2] for k in per_scene)
                rows.append({"method": method, "parameter": CURVE_METHODS[method],
                             "value": float(u), "matches": m, "scored": s, "correct@1": c,
                             "precision@1": c / s if s else float("nan")})
        elif method == "hopmatch":
            rows += _thresholded(method, CURVE_METHODS[method], DISTANCE_THRESHOLDS,
                                 per_scene, strict=False)
        else:
            rows += _thresholded(method, CURVE_METHODS[method], SIFT_RATIOS, per_scene,
                                 strict=True)
    return rows


def format_curves_markdown(rows: Sequence[dict]) -> str:
    """The rows of :func:`precision_curves` as a Markdown table."""
    lines = ["| method | threshold | matches | correct@1 | precision@1 |",
             "|---|---|---:|---:|---:|"]
    for r in rows:
        v = f"{r['value']:g}"
        p = "" if np.isnan(r["precision@1"]) else f"{r['precision@1']:.4f}"
        lines.append(f"| {r['method']} | {r['parameter']} {v} | {r['matches']} | "
                     f"{r['correct@1']} | {p} |")
    return "\n".join(lines) + "\n"
