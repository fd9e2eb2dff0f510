"""Tables and pictures of the rows (hopmatch.compare.tables), and the plots of viz they feed."""

from __future__ import annotations

import csv
import io

import cv2
import numpy as np
import pytest

from hopmatch import compare, viz


class TestTablesOnTsukuba:
    def test_draw_row(self, tsukuba_rows):
        scene, rows = tsukuba_rows
        pic = compare.draw_row(rows[0], scene)
        h, w = scene.shape
        # the overview: both images side by side, a caption below
        assert pic.shape[1:] == (2 * w, 3) and pic.shape[0] > h and pic.dtype == np.uint8
        correct, known = compare.correct_flags(rows[0])
        assert int(correct.sum()) == rows[0]["correct@1"]
        assert int(known.sum()) == rows[0]["scored"]
        # a magenta cross (viz.overview.WRONG) on each wrong match with ground truth, and
        # none without wrong matches
        wrong = known & ~correct
        magenta = np.all(pic[:h] == viz.overview.WRONG, axis=2)
        assert magenta.any() == bool(wrong.any())

    def test_tables(self, tsukuba_rows, tmp_path):
        _, rows = tsukuba_rows
        md = compare.write_markdown(rows, tmp_path / "r.md").read_text()
        assert md.splitlines()[0] == ("| scene | method | matches | correct@1 | precision@1 | "
                                      "recall@1 | time ms |")
        assert len(md.splitlines()) == 2 + len(rows)
        assert f"| middlebury/tsukuba | sgbm | {rows[2]['matches']} | " in md
        table = list(csv.DictReader(compare.write_csv(rows, tmp_path / "r.csv").open()))
        assert len(table) == len(rows)
        for got, want in zip(table, rows):
            assert got["method"] == want["method"]
            assert int(got["correct@1"]) == want["correct@1"]
            assert float(got["precision@1"]) == pytest.approx(want["precision@1"], abs=1e-6)
        assert sorted(p.name for p in tmp_path.iterdir()) == ["r.csv", "r.md"]

    def test_plots_are_pngs(self, tsukuba_rows, tmp_path):
        pytest.importorskip("matplotlib")
        _, rows = tsukuba_rows
        p1 = viz.plot_precision_vs_correct(rows, tmp_path / "prec.png")
        p2 = viz.plot_error_histogram(compare.errors_by_method(rows), tmp_path / "hist.png")
        for p in (p1, p2):
            assert p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
            img = cv2.imread(str(p))
            assert img is not None and img.shape[0] > 200 and img.shape[1] > 300


def test_markdown_shows_nan_as_a_dash():
    row = {"scene": "s", "method": "m", "matches": 0, "correct@1": 0,
           "precision@1": float("nan"), "recall@1": float("nan"), "time_ms": 1.4}
    assert compare.format_markdown([row]).splitlines()[-1] == "| s | m | 0 | 0 | – | – | 1 |"
    text = compare.format_csv([row])
    got = next(csv.DictReader(io.StringIO(text)))
    assert got["precision@1"] == "nan" and got["keypoints_left"] == ""
