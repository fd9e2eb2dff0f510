"""Running and scoring the methods (hopmatch.compare.runner)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from compare_helpers import synthetic_scene

from hopmatch import compare
from hopmatch.compare import COLUMNS, MethodResult


class TestCompareOnTsukuba:
    def test_rows(self, tsukuba_rows):
        scene, rows = tsukuba_rows
        assert [r["method"] for r in rows] == ["hopmatch", "sift-ratio-band", "sgbm"]
        dmax = math.ceil(np.nanmax(scene.disparity) * 1.1)
        for r in rows:
            assert r["scene"] == "middlebury/tsukuba"
            assert set(COLUMNS) <= set(r)
            assert r["max_disparity"] == dmax == 16
            assert 0 < r["scored"] <= r["matches"]
            assert r["correct@0.5"] <= r["correct@1"] <= r["correct@2"] <= r["scored"]
            assert 0.0 <= r["precision@1"] <= 1.0 and 0.0 <= r["recall@1"] <= 1.0
            assert r["precision@1"] == pytest.approx(r["correct@1"] / r["scored"])
            assert r["time_ms"] > 0
            res = r["result"]
            assert isinstance(res, MethodResult)
            assert res.left_pts.dtype == res.right_pts.dtype == np.float32
            assert res.left_pts.shape == res.right_pts.shape == (r["matches"], 2)
        by = {r["method"]: r for r in rows}
        # every method keeps to the rectified band and the disparity range
        for name in ("sift-ratio-band", "sgbm", "hopmatch"):
            res = by[name]["result"]
            d = res.left_pts[:, 0] - res.right_pts[:, 0]
            assert d.min() >= -1e-3 and d.max() <= dmax + 1e-3, name
            assert np.abs(res.left_pts[:, 1] - res.right_pts[:, 1]).max() <= 1.0 + 1e-3, name
        assert by["hopmatch"]["precision@1"] > 0.8  # a sanity floor, not a tuning target
        assert by["sgbm"]["precision@1"] > 0.8


def test_bad_arguments():
    with pytest.raises(ValueError, match="unknown method 'nope'.*hopmatch"):
        compare.compare([synthetic_scene()], ["nope"])
    with pytest.raises(TypeError, match="scenes"):
        compare.compare([42], ["hopmatch"])
    with pytest.raises(ValueError, match="empty"):
        compare.compare([synthetic_scene()], [])
    with pytest.raises(ValueError, match="repeat"):
        compare.compare([synthetic_scene()], ["sgbm"], repeat=0)


def test_repeat_keeps_the_shortest_time():
    calls = []

    def fake(scene):
        calls.append(1)
        t = 0.3 if len(calls) % 2 else 0.1
        return compare.MethodResult(np.zeros((0, 2), np.float32), np.zeros((0, 2), np.float32),
                                    t, np.zeros((0, 2), np.float32), np.zeros((0, 2), np.float32))

    rows = compare.compare([synthetic_scene()], [fake], repeat=3, warmup=False)
    assert len(calls) == 3 and rows[0]["time_ms"] == pytest.approx(100.0)
    assert rows[0]["method"] == "fake" and rows[0]["matches"] == 0
    assert math.isnan(rows[0]["precision@1"])
