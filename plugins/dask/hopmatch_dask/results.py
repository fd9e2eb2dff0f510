"""Result files: the matches table (written by ``hopmatch match``'s writer,
:func:`hopmatch.tables.matches_table`) and the summary."""

from __future__ import annotations

import csv
import io
import math

from hopmatch.errors import FileReadError, InvalidTypeError
from hopmatch.files import MAX_FILE_BYTES, read_input_bytes, write_text_atomic
from hopmatch.tables import MATCH_COLUMNS, matches_table

__all__ = ["COLUMNS", "MAX_MESSAGE_CHARS", "SUMMARY_COLUMNS", "complete_rows",
           "finished_counts", "matches_table", "short_text", "summary_table",
           "write_text_atomic"]

#: Columns of ``<name>.csv``: those of ``hopmatch match``'s matches.csv
#: (:func:`matches_table` is the writer both use).
COLUMNS = MATCH_COLUMNS
#: Columns of ``summary.csv``: ``error`` says why a ``failed`` pair failed, ``warning``
#: what matching warned about for an ``ok`` pair (why it has no or few matches...).
SUMMARY_COLUMNS = ("name", "status", "matches", "seconds", "error", "warning")
#: Longest error or warning text recorded for a pair (longer ones are cut, ending in
#: "..."): every field of summary.csv stays far below the 128 KiB the ``csv`` module reads.
MAX_MESSAGE_CHARS = 2000


def short_text(text, limit: int = MAX_MESSAGE_CHARS) -> str:
    """``text`` on one line (runs of white space as one space), cut to ``limit`` characters.

    Examples
    --------
    >>> short_text(" no  such   file ")
    'no such file'
    >>> short_text("x" * 10, limit=8)
    'xxxxx...'
    """
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def complete_rows(path, expected: int | None = None) -> int | None:
    """The number of matches in the result file ``path`` if it is complete, else None.

    Complete: it is a regular file (a named pipe or device is not read: never blocks) of at
    most 1 GiB, has the header of :data:`COLUMNS`, ends with a newline, every line holds six
    finite numbers (the writer never writes NaN or inf) and, when ``expected`` is given,
    it holds exactly ``expected`` rows (a file cut at a line boundary has fewer: the
    batch passes the count its summary recorded, :func:`finished_counts`). Files are
    renamed into place only when fully written, so an incomplete one was damaged
    afterwards; it is computed again. ``expected`` must be None or an int
    (:class:`~hopmatch.errors.InvalidTypeError` otherwise: ``"1"``, ``1.0`` or ``True``).

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "pair.csv")
    >>> with open(path, "w") as f:
    ...     _ = f.write(matches_table([[10, 5]], [[4, 5]], [6], [0.25]))
    >>> complete_rows(path), complete_rows(path, expected=2)
    (1, None)
    >>> with open(path, "a") as f:
    ...     _ = f.write("1.0,2.0")             # cut short
    >>> complete_rows(path) is None
    True
    """
    if expected is not None and (isinstance(expected, bool) or not isinstance(expected, int)):
        raise InvalidTypeError(f"`expected` must be None or an int (a row count), got "
                               f"{type(expected).__name__} {expected!r}"[:200],
                               argument="expected")
    try:
        text = read_input_bytes(path, MAX_FILE_BYTES).decode("utf-8")
    except (FileReadError, UnicodeDecodeError):
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
            if not all(math.isfinite(float(c)) for c in cells):
                return None
        except ValueError:
            return None
    rows = len(lines) - 1
    if expected is not None and rows != expected:
        return None
    return rows


def finished_counts(path) -> dict[str, int]:
    """``{name: matches}`` of the pairs that ``summary.csv`` at ``path`` records as done
    (``ok`` or ``skipped``); empty when it is missing or unreadable. A result file counts
    as complete on a rerun only if its row count is the one recorded here."""
    try:
        text = read_input_bytes(path, MAX_FILE_BYTES).decode("utf-8")
    except (FileReadError, UnicodeDecodeError):
        return {}
    counts = {}
    try:
        for row in csv.DictReader(io.StringIO(text)):
            try:
                if row.get("status") in ("ok", "skipped") and row.get("name"):
                    counts[row["name"]] = int(row["matches"])
            except (TypeError, ValueError):
                continue
    except csv.Error:  # a field over the csv module's limit (128 KiB): not a summary we wrote
        return {}
    return counts


def summary_table(outcomes) -> str:
    """CSV text of summary.csv: one line per outcome (see :class:`~hopmatch_dask.Outcome`)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(SUMMARY_COLUMNS)
    for o in outcomes:
        writer.writerow([o.name, o.status, "" if o.matches is None else o.matches,
                         "" if o.seconds is None else f"{o.seconds:.3f}",
                         short_text(o.error), short_text(getattr(o, "warning", ""))])
    return buf.getvalue()
