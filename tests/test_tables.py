"""The matches table writer (hopmatch.tables), shared by hopmatch match and hopmatch batch."""

from __future__ import annotations

import csv
import io
import json

import numpy as np
import pytest

from hopmatch.tables import MATCH_COLUMNS, float32_strings, format_table, matches_table


def test_float32_strings_read_back_exactly():
    values = np.random.default_rng(0).normal(size=50).astype(np.float32)
    assert np.array_equal(np.array(float32_strings(values), np.float32), values)


def test_matches_table_csv_and_json():
    ml = np.float32([[10, 5], [20.5, 7]])
    mr = np.float32([[4, 5], [1.25, 7]])
    disp, dist = ml[:, 0] - mr[:, 0], np.float32([0.25, 0.125])
    text = matches_table(ml, mr, disp, dist)
    rows = list(csv.reader(io.StringIO(text)))
    assert tuple(rows[0]) == MATCH_COLUMNS and rows[1] == ["10.0", "5.0", "4.0", "5.0", "6.0",
                                                           "0.25"]
    records = json.loads(matches_table(ml, mr, disp, dist, "json"))
    assert [list(r) for r in records] == [list(MATCH_COLUMNS)] * 2
    assert records[1]["right_x"] == 1.25 and records[1]["disparity"] == 19.25
    assert matches_table(np.zeros((0, 2)), np.zeros((0, 2)), [], []) == ",".join(
        MATCH_COLUMNS) + "\n"
    assert matches_table(np.zeros((0, 2)), np.zeros((0, 2)), [], [], "json") == "[]\n"


def test_format_table_refuses_unknown_formats():
    with pytest.raises(ValueError, match="fmt") as info:
        format_table({"x": [1]}, "xml")
    assert info.value.argument == "fmt"


def test_matches_table_refuses_rows_of_different_counts_and_non_numbers_by_name():
    """Arrays of different lengths were cut to the shortest (zip), silently."""
    from hopmatch.errors import InvalidArgumentError, InvalidTypeError

    lp = np.float32([[10, 10], [20, 20]])
    with pytest.raises(InvalidArgumentError, match="one row per match") as e:
        matches_table(lp, lp[:1] - [5, 0], np.ones(2), np.ones(2))
    assert e.value.argument == "matched_right"
    with pytest.raises(InvalidTypeError, match="`disparities`"):
        matches_table(lp, lp, ["a", "b"], np.ones(2))
    with pytest.raises(InvalidArgumentError, match=r"`matched_right` must be an \(M, 2\)"):
        matches_table(lp, np.zeros((2, 3)), np.ones(2), np.ones(2))
    with pytest.raises(InvalidArgumentError, match="one value per row"):
        format_table({"x": [1, 2], "y": [3]})
    assert matches_table([], [], [], []) == ",".join(MATCH_COLUMNS) + "\n"
