"""Result files: the matches table (written by ``hopmatch match``'s writer,
:func:`hopmatch._tables.matches_table`) and the summary."""

from __future__ import annotations

import csv
import io
from pathlib import Path

from hopmatch._files import write_text_atomic
from hopmatch._tables import MATCH_COLUMNS, matches_table

__all__ = ["COLUMNS", "SUMMARY_COLUMNS", "complete_rows", "matches_table", "summary_table",
           "write_text_atomic"]

#: Columns of ``<name>.csv``: those of ``hopmatch match``'s matches.csv
#: (:func:`matches_table` is the writer both use).
COLUMNS = MATCH_COLUMNS
#: Columns of ``summary.csv``.
SUMMARY_COLUMNS = ("name", "status", "matches", "seconds", "error")


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
