"""Precision against correct matches as each method's threshold moves
(hopmatch.compare.curves): the curves pass through the methods' own settings."""

from __future__ import annotations

import numpy as np
import pytest

from hopmatch import compare, datasets
from hopmatch.compare.curves import DISTANCE_THRESHOLDS, SGBM_UNIQUENESS, SIFT_RATIOS


@pytest.fixture(scope="module")
def motorcycle_curves():
    scene = datasets.load("motorcycle")
    rows = compare.precision_curves([scene])
    return scene, rows


def test_one_row_per_threshold_and_more_matches_as_it_loosens(motorcycle_curves):
    _, rows = motorcycle_curves
    for method, values in (("hopmatch", DISTANCE_THRESHOLDS), ("sift-ratio-band", SIFT_RATIOS),
                           ("sgbm", SGBM_UNIQUENESS)):
        mine = [r for r in rows if r["method"] == method]
        assert [r["value"] for r in mine] == [float(v) for v in values]
        # thresholds on one run keep nested sets; SGBM's runs differ (its speckle filter
        # sees other pixels), so only its match count is expected to grow
        keys = ("matches",) if method == "sgbm" else ("matches", "scored", "correct@1")
        for key in keys:
            assert np.all(np.diff([r[key] for r in mine]) >= 0), (method, key)
        for r in mine:
            assert r["precision@1"] == pytest.approx(r["correct@1"] / r["scored"])


def test_curves_pass_through_the_methods_settings(motorcycle_curves):
    scene, rows = motorcycle_curves
    table = {r["method"]: r for r in compare.compare([scene], ["hopmatch", "sift-ratio-band",
                                                               "sgbm"], warmup=False)}
    at = {(r["method"], r["value"]): r for r in rows}
    for method, value in (("hopmatch", 1.0), ("sift-ratio-band", 0.75), ("sgbm", 10.0)):
        assert at[method, value]["matches"] == table[method]["matches"], method
        assert at[method, value]["correct@1"] == table[method]["correct@1"], method


def test_unknown_methods_have_no_curve_and_the_table_formats():
    assert compare.precision_curves([], ["ncc-wta"]) == []
    text = compare.format_curves_markdown([
        {"method": "sgbm", "parameter": "uniqueness", "value": 10.0, "matches": 3,
         "scored": 0, "correct@1": 0, "precision@1": float("nan")}])
    assert "| sgbm | uniqueness 10 | 3 | 0 |  |" in text
