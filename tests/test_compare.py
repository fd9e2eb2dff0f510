"""The comparison runner (hopmatch.compare), its tables and plots, and ``hopmatch eval``."""

from __future__ import annotations

import csv
import io
import math
import subprocess
import sys

import cv2
import numpy as np
import pytest

from hopmatch import compare, datasets, viz
from hopmatch.compare import COLUMNS, METHODS, MethodResult

CLI = [sys.executable, "-m", "hopmatch.cli"]


def synthetic_scene(disparity: int = 5, shape=(96, 128)) -> datasets.StereoScene:
    """A blurred random-texture pair with one disparity everywhere (right = left shifted)."""
    rng = np.random.default_rng(3)
    left = cv2.GaussianBlur((rng.random(shape) * 255).astype(np.uint8), (3, 3), 0)
    right = np.roll(left, -disparity, axis=1)
    disp = np.full(shape, float(disparity), np.float32)
    disp[:, :disparity] = np.nan  # no correspondent inside the right image
    return datasets.StereoScene("synthetic", left, right, disp, None, "")


@pytest.fixture(scope="module")
def tsukuba_rows(shared_data):
    scene = datasets.load("middlebury/tsukuba", root=shared_data)
    rows = compare.compare([scene], ["hopmatch", "sift-ratio-band", "sgbm"])
    return scene, rows


# --------------------------------------------------------------------------------------
# End to end on a real scene
# --------------------------------------------------------------------------------------


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

    def test_draw_row(self, tsukuba_rows):
        scene, rows = tsukuba_rows
        pic = compare.draw_row(rows[0], scene)
        h, w = scene.shape
        assert pic.shape == (h, 2 * w, 3) and pic.dtype == np.uint8
        correct, known = compare.correct_flags(rows[0])
        assert int(correct.sum()) == rows[0]["correct@1"]
        assert int(known.sum()) == rows[0]["scored"]

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

    def test_results_doc(self, tsukuba_rows):
        scene, rows = tsukuba_rows
        text = compare.format_results_doc(
            rows, [scene], pictures={"img/x.png": "a caption"},
            machine=compare.machine_description(), created="now", elapsed=1.0)
        assert compare.DOCS_COMMAND in text.splitlines()[2]
        assert "### middlebury/tsukuba" in text and "![a caption](img/x.png)" in text
        assert "0 .. ceil(1.1" in text and scene.source in text


# --------------------------------------------------------------------------------------
# The methods, on a synthetic pair
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(METHODS))
def test_every_method_on_a_constant_disparity(name):
    scene = synthetic_scene()
    res = compare.run_method(name, scene)
    assert isinstance(res, MethodResult) and res.seconds > 0
    for arr in res[:2] + res[3:]:
        assert arr.dtype == np.float32 and arr.ndim == 2 and arr.shape[1] == 2
    assert res.left_pts.shape == res.right_pts.shape
    assert len(res.keypoints_left) >= len(np.unique(res.left_pts, axis=0))


@pytest.mark.parametrize("name", ["hopmatch", "ncc-wta", "sgbm", "sift-ratio-band"])
def test_methods_find_the_disparity(name):
    res = compare.run_method(name, synthetic_scene())
    d = res.left_pts[:, 0] - res.right_pts[:, 0]
    assert len(d) > 10 and np.median(np.abs(d - 5)) < 0.5


def test_ncc_matches_cv2_match_template():
    """The vectorised NCC equals cv2.matchTemplate(TM_CCOEFF_NORMED) point by point."""
    rng = np.random.default_rng(0)
    left = (rng.random((40, 60)) * 255).astype(np.uint8)
    right = (rng.random((40, 60)) * 255).astype(np.uint8)
    pts = np.array([[30, 10], [20, 25], [8, 30], [50, 5]], np.intp)
    dmax, h = 12, compare.NCC_HALF
    keep, disp = compare._ncc_wta(left, right, pts, dmax)
    for (x, y), k, d in zip(pts, keep, disp):
        tpl = left[y - h:y + h + 1, x - h:x + h + 1]
        lo = max(x - dmax, h)
        band = right[y - h:y + h + 1, lo - h:x + h + 1]
        score = cv2.matchTemplate(band, tpl, cv2.TM_CCOEFF_NORMED)[0][::-1]  # d = 0, 1, ...
        assert k and abs(float(d) - int(np.argmax(score))) <= 0.5  # winner + parabola shift


def test_band_mask_equals_the_dense_test():
    rng = np.random.default_rng(1)
    kl = (rng.random((300, 2)) * [100, 20]).astype(np.float32)
    kr = (rng.random((250, 2)) * [100, 20]).astype(np.float32)
    dy = np.abs(kl[:, None, 1] - kr[None, :, 1])
    d = kl[:, None, 0] - kr[None, :, 0]
    want = ((dy <= 1) & (d >= 0) & (d <= 30)).astype(np.uint8)
    np.testing.assert_array_equal(compare._band_mask(kl, kr, 30), want)


def test_disparity_range():
    scene = synthetic_scene(disparity=9)
    assert compare.disparity_range(scene) == 10  # ceil(9 * 1.1)


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


def test_markdown_shows_nan_as_a_dash():
    row = {"scene": "s", "method": "m", "matches": 0, "correct@1": 0,
           "precision@1": float("nan"), "recall@1": float("nan"), "time_ms": 1.4}
    assert compare.format_markdown([row]).splitlines()[-1] == "| s | m | 0 | 0 | – | – | 1 |"
    text = compare.format_csv([row])
    got = next(csv.DictReader(io.StringIO(text)))
    assert got["precision@1"] == "nan" and got["keypoints_left"] == ""


# --------------------------------------------------------------------------------------
# hopmatch eval
# --------------------------------------------------------------------------------------


def run(*args, cwd=None):
    return subprocess.run([*CLI, *map(str, args)], cwd=cwd, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, timeout=300)


def test_eval_writes_tables_and_plots(shared_data, tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "ev"
    res = run("eval", "--scene", "middlebury/tsukuba", "--method", "hopmatch",
              "--method", "ncc-wta", "--out", out, "--draw")
    assert res.returncode == 0, res.stderr
    assert res.stderr == ""  # progress only on a terminal
    assert sorted(p.name for p in out.iterdir()) == [
        "error_histogram.png", "matches_middlebury_tsukuba_hopmatch.png",
        "matches_middlebury_tsukuba_ncc-wta.png", "precision_vs_correct.png",
        "results.csv", "results.md"]
    assert "| middlebury/tsukuba | ncc-wta |" in res.stdout
    assert (out / "results.md").read_text() in res.stdout
    table = list(csv.DictReader((out / "results.csv").open()))
    assert [r["method"] for r in table] == ["hopmatch", "ncc-wta"]
    for png in out.glob("*.png"):
        assert cv2.imread(str(png)) is not None, png.name


@pytest.mark.parametrize("args, where, words", [
    (["--scene", "nowhere"], "--scene", "unknown scene 'nowhere'"),
    (["--method", "magic"], "--method", "unknown method 'magic'"),
])
def test_eval_bad_input(tmp_path, args, where, words):
    out = tmp_path / "ev"
    res = run("eval", *args, "--out", out)
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"hopmatch: error: {where}: "), lines
    assert words in lines[0] and "Traceback" not in res.stderr
    assert not out.exists()


def test_eval_unwritable_output_leaves_nothing(tmp_path):
    (tmp_path / "file").write_text("x")
    res = run("eval", "--method", "sgbm", "--out", tmp_path / "file" / "sub")
    assert res.returncode == 2
    assert res.stderr.startswith("hopmatch: error: ")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]
