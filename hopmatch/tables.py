"""Result tables as text: the matches table of ``hopmatch match`` (and of every pair of
``hopmatch batch``), and the float32 columns it is made of.

One writer, so that the command line and the Dask plugin write the same file: a CSV with a
header (or a JSON list of objects), each number the shortest decimal string that reads back
as the same float32 value.
"""

from __future__ import annotations

import csv
import io
import json

import numpy as np

from ._validate import describe
from .errors import InvalidArgumentError, InvalidTypeError

__all__ = ["MATCH_COLUMNS", "float32_strings", "format_table", "matches_table"]

#: Columns of matches.csv / matches.json, in order.
MATCH_COLUMNS = ("left_x", "left_y", "right_x", "right_y", "disparity", "distance")

#: Formats of :func:`format_table`.
FORMATS = ("csv", "json")


def float32_strings(values) -> list[str]:
    """Shortest decimal strings that read back as the same float32 values (flattened)."""
    return [str(v) for v in np.asarray(values, dtype=np.float32).reshape(-1)]


def format_table(columns: dict, fmt: str = "csv") -> str:
    """CSV (with a header) or a JSON list of objects, from equal-length float columns.

    Parameters
    ----------
    columns : dict of str to array_like
        Column name -> values (converted to float32, see :func:`float32_strings`).
    fmt : {'csv', 'json'}
        ``"csv"``: header line, then one line per row, ``\\n`` line ends. ``"json"``: a list
        of ``{column: number}`` objects, indented by one space, and a final newline.

    Raises
    ------
    InvalidTypeError, InvalidArgumentError
        A column that is not 1-D real numbers, or columns of different lengths (named).

    Examples
    --------
    >>> print(format_table({"x": [1, 2.5], "y": [0.1, 3]}), end="")
    x,y
    1.0,0.1
    2.5,3.0
    """
    if fmt not in FORMATS:
        raise InvalidArgumentError(f"`fmt` must be one of {list(FORMATS)}, got {fmt!r}",
                                   argument="fmt")
    names = list(columns)
    cols = [float32_strings(_column(columns[n], n)) for n in names]
    lengths = {n: len(c) for n, c in zip(names, cols)}
    if len(set(lengths.values())) > 1:
        raise InvalidArgumentError(f"the columns must have one value per row each, got "
                                   f"lengths {lengths}", argument=names[0])
    rows = list(zip(*cols)) if cols else []
    if fmt == "json":
        records = [{n: float(v) for n, v in zip(names, row)} for row in rows]
        return json.dumps(records, indent=1) + "\n"
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(names)
    writer.writerows(rows)
    return buf.getvalue()


def _column(values, name: str) -> np.ndarray:
    """``values`` as a 1-D float64 array of real numbers (one per row), or an error naming
    the column ``name``."""
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise InvalidTypeError(f"column `{name}` must hold numbers, got {describe(values)}: "
                               f"{exc}", argument=name) from None
    if arr.dtype == np.bool_ or arr.dtype.kind not in "iuf":
        raise InvalidTypeError(f"column `{name}` must hold real numbers, got "
                               f"{describe(values)}", argument=name)
    if arr.ndim > 1:
        raise InvalidArgumentError(f"column `{name}` must be 1-D (one value per row), got "
                                   f"shape {arr.shape}", argument=name)
    return arr.reshape(-1).astype(np.float64)


def _points(values, name: str) -> np.ndarray:
    """``values`` as an (M, 2) float32 array of (x, y), or an error naming ``name``."""
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise InvalidTypeError(f"`{name}` must be an (M, 2) array of (x, y), got "
                               f"{describe(values)}: {exc}", argument=name) from None
    if arr.size == 0:
        return np.zeros((0, 2), np.float32)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise InvalidArgumentError(f"`{name}` must be an (M, 2) array of (x, y), got shape "
                                   f"{arr.shape}", argument=name)
    return _column(arr.reshape(-1), name).astype(np.float32).reshape(-1, 2)


def matches_table(matched_left, matched_right, disparities, distances, fmt: str = "csv") -> str:
    """The text of ``hopmatch match``'s matches.csv (or matches.json): the columns
    :data:`MATCH_COLUMNS`, from the arrays of a :class:`~hopmatch.StereoMatchResult`.

    Parameters
    ----------
    matched_left, matched_right : (M, 2) array_like
        (x, y) of each match in the left and right images.
    disparities, distances : (M,) array_like
        ``x_left - x_right`` and the matcher's distance of each match.
    fmt : {'csv', 'json'}
        As :func:`format_table`.

    Raises
    ------
    InvalidTypeError, InvalidArgumentError
        An argument that is not numbers of the shape above, or arguments of different
        lengths (each named).

    Examples
    --------
    >>> print(matches_table([[10, 5]], [[4, 5]], [6], [0.25]), end="")
    left_x,left_y,right_x,right_y,disparity,distance
    10.0,5.0,4.0,5.0,6.0,0.25
    """
    ml, mr = _points(matched_left, "matched_left"), _points(matched_right, "matched_right")
    disp, dist = _column(disparities, "disparities"), _column(distances, "distances")
    counts = {"matched_left": len(ml), "matched_right": len(mr), "disparities": len(disp),
              "distances": len(dist)}
    if len(set(counts.values())) > 1:
        raise InvalidArgumentError(f"one row per match in each argument, got {counts}",
                                   argument=min(counts, key=counts.get))
    values = (ml[:, 0], ml[:, 1], mr[:, 0], mr[:, 1], disp, dist)
    return format_table(dict(zip(MATCH_COLUMNS, values)), fmt)
