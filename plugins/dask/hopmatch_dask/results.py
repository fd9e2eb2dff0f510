"""Result files: the matches table (as ``hopmatch match`` writes it) and the summary."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from hopmatch.viz import write_text_atomic

__all__ = ["COLUMNS", "SUMMARY_COLUMNS", "complete_rows", "matches_table", "summary_table",
           "write_text_atomic"]

#: Columns of ``<name>.csv``: those of ``hopmatch match``'s matches.csv.
COLUMNS = ("left_x", "left_y", "right_x", "right_y", "disparity", "distance")
#: Columns of ``summary.csv``.
SUMMARY_COLUMNS = ("name", "status", "matches", "seconds", "error")


def _f32(values) -> list[str]:
    """Shortest decimal strings that read back as the same float32 values."""
    return [str(v) for v in np.asarray(values, dtype=np.float32).reshape(-1)]


def matches_table(matched_left, matched_right, disparities, distances) -> str:
    """The CSV text of ``hopmatch match``'s matches.csv, from the arrays of a result.

    Examples
    --------
    >>> print(matches_table([[10, 5]], [[4, 5]], [6], [0.25]), end="")
    left_x,left_y,right_x,right_y,disparity,distance
    10.0,5.0,4.0,5.0,6.0,0.25
    """
    ml = np.asarray(matched_left, np.float32).reshape(-1, 2)
    mr = np.asarray(matched_right, np.float32).reshape(-1, 2)
    cols = [_f32(ml[:, 0]), _f32(ml[:, 1]), _f32(mr[:, 0]), _f32(mr[:, 1]),
            _f32(disparities), _f32(distances)]
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS)
    writer.writerows(zip(*cols))
    return buf.getvalue()


def complete_rows(path) -> int | None:
    """The number of matches in the result file ``path`` if it is complete, else None.

    Complete: it exists, has the header of :data:`COLUMNS`, ends with a newline and every
    line holds six numbers. Files are renamed into place only when fully written, so an
    incomplete one was damaged afterwards; it is computed again.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "pair.csv")
    >>> with open(path, "w") as f:
    ...     _ = f.write(matches_table([[10, 5]], [[4, 5]], [6], [0.25]))
    >>> complete_rows(path)
    1
    >>> with open(path, "a") as f:
    ...     _ = f.write("1.0,2.0")             # cut short
    >>> complete_rows(path) is None
    True
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None
    if not text.endswith("\n"):
        return None
    lines = text.splitlines()
    if not lines or lines[0] != ",".join(COLUMNS):
        return None
    for line in lines[1:]:
        cells = line.split(",")
        if len(cells) != len(COLUMNS):
            return None
        try:
            [float(c) for c in cells]
        except ValueError:
            return None
    return len(lines) - 1


def summary_table(outcomes) -> str:
    """CSV text of summary.csv: one line per outcome (see :class:`~hopmatch_dask.Outcome`)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(SUMMARY_COLUMNS)
    for o in outcomes:
        writer.writerow([o.name, o.status, "" if o.matches is None else o.matches,
                         "" if o.seconds is None else f"{o.seconds:.3f}", o.error])
    return buf.getvalue()
