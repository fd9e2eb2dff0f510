"""The rows of :func:`~hopmatch.compare.compare` as tables (Markdown, CSV) and pictures."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from ..datasets import StereoScene
from ..evaluate import correct_matches
from ..files import write_text_atomic
from .runner import THRESHOLDS

__all__ = ["COLUMNS", "MARKDOWN_COLUMNS", "cell", "correct_flags", "draw_row",
           "errors_by_method", "format_csv", "format_markdown", "write_csv", "write_markdown"]

#: Columns of :func:`format_csv`, in order (``format_markdown`` shows a subset).
COLUMNS = (
    "scene", "method", "keypoints_left", "keypoints_right", "matches", "scored",
    *(f"{k}@{t:g}" for t in THRESHOLDS for k in ("correct", "precision", "matchable",
                                                 "recall")),
    "mean_abs_error", "median_abs_error", "max_disparity", "time_ms",
)

#: Columns of :func:`format_markdown`: (row key, header, format).
MARKDOWN_COLUMNS = (
    ("scene", "scene", "{}"),
    ("method", "method", "{}"),
    ("matches", "matches", "{}"),
    ("correct@1", "correct@1", "{}"),
    ("precision@1", "precision@1", "{:.3f}"),
    ("recall@1", "recall@1", "{:.3f}"),
    ("time_ms", "time ms", "{:.0f}"),
)


def cell(value, fmt: str) -> str:
    """``fmt.format(value)``, or "–" for NaN."""
    if isinstance(value, float) and math.isnan(value):
        return "–"
    return fmt.format(value)


def format_markdown(rows: Sequence[Mapping]) -> str:
    """A Markdown table: scene, method, matches, correct@1, precision@1, recall@1, time ms.

    Numbers are right-aligned; NaN (e.g. precision without any scored match) shows as "–".
    """
    lines = ["| " + " | ".join(h for _, h, _ in MARKDOWN_COLUMNS) + " |",
             "|" + "|".join("---" if k in ("scene", "method") else "---:"
                            for k, _, _ in MARKDOWN_COLUMNS) + "|"]
    for row in rows:
        lines.append("| " + " | ".join(cell(row[k], f) for k, _, f in MARKDOWN_COLUMNS)
                     + " |")
    return "\n".join(lines) + "\n"


def format_csv(rows: Sequence[Mapping]) -> str:
    """CSV with a header of :data:`COLUMNS`; floats at full precision, NaN as ``nan``."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    for row in rows:
        writer.writerow([_csv_value(row.get(c, "")) for c in COLUMNS])
    return buf.getvalue()


def _csv_value(value):
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(round(value, 6))
    return value


def write_markdown(rows: Sequence[Mapping], path):
    """Write :func:`format_markdown` to ``path`` atomically; return the path."""
    return write_text_atomic(path, format_markdown(rows))


def write_csv(rows: Sequence[Mapping], path):
    """Write :func:`format_csv` to ``path`` atomically; return the path."""
    return write_text_atomic(path, format_csv(rows))


def correct_flags(row: Mapping, tolerance: float = 1.0):
    """(correct, known) bool arrays of a row's matches at ``tolerance`` px (as scored)."""
    res = row["result"]
    return correct_matches(row["score"], res.left_pts, res.right_pts, tolerance)


def draw_row(row: Mapping, scene: StereoScene, tolerance: float = 1.0) -> np.ndarray:
    """The matches of one row as :func:`hopmatch.viz.draw_match_overview` draws them:
    every match a dot coloured by its disparity on the scale of the scene's ground truth
    (0 to its largest disparity), a spread-out subset as lines, the wrong ones at
    ``tolerance`` px (among those with ground truth) marked with a magenta cross, and a
    caption with the counts below. Returns a BGR image ``(H + caption, 2 W, 3)``."""
    from ..viz import draw_match_overview

    res = row["result"]
    correct, known = correct_flags(row, tolerance)
    pairs = np.repeat(np.arange(len(res.left_pts))[:, None], 2, axis=1)
    truth = np.asarray(scene.disparity)[scene.valid]
    hi = float(np.max(truth)) if truth.size and np.max(truth) > 0 else None  # else automatic
    return draw_match_overview(scene.left, scene.right, res.left_pts, res.right_pts, pairs,
                               correct=correct, known=known,
                               min_disparity=None if hi is None else 0.0, max_disparity=hi)


def errors_by_method(rows: Iterable[Mapping], scene: str | None = None) -> dict:
    """``{method: signed disparity errors}`` of the rows (of one scene, or pooled)."""
    out: dict = {}
    for row in rows:
        if scene is None or row["scene"] == scene:
            out.setdefault(row["method"], []).append(row["score"].errors)
    return {k: np.concatenate(v) for k, v in out.items()}
