"""The commands demo, match and detect (hopmatch.cli.commands), through the real entry point."""

from __future__ import annotations

import json
import re
from importlib.metadata import version

import cv2
import numpy as np
import pytest
from cli_helpers import DISPARITY, MATCH_FIELDS, assert_bad_input, files_in, printed, read_csv, run

from hopmatch import DericheMoravecDetector

# --------------------------------------------------------------------------------------
# demo


# --------------------------------------------------------------------------------------


def test_demo(tmp_path):
    out = tmp_path / "demo"
    res = run("demo", "--out", out, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert files_in(out) == ["disparity.png", "matches.csv", "matches.png", "run.json"]
    n_matches = int(printed(res.stdout, "matches"))
    left, right = printed(res.stdout, "keypoints").split(",")
    assert int(left.split()[0]) > n_matches and int(right.split()[0]) > n_matches
    correct, scored = re.match(r"(\d+) of (\d+)", printed(res.stdout, "correct@1px")).groups()
    assert 0 <= int(correct) <= int(scored) <= n_matches
    assert 0.0 <= float(printed(res.stdout, "precision")) <= 1.0
    assert re.match(r"\d+ ms", printed(res.stdout, "time"))
    # numbers a user can reproduce: steady-state time and the ratio to ORB timed right there
    steady = re.match(r"(\d+) ms per pair in steady state \(best of 5 rounds, one thread; "
                      r"the first call took \d+ ms", printed(res.stdout, "time"))
    assert steady, printed(res.stdout, "time")
    speed = re.match(r"([\d.]+)x the time of ORB\(3000\) \+ BFMatcher ratio test \((\d+) ms\)"
                     r", timed here", printed(res.stdout, "speed"))
    assert speed, printed(res.stdout, "speed")
    ratio, orb_ms = float(speed.group(1)), float(speed.group(2))
    assert 0.05 < ratio < 20 and orb_ms > 0
    assert ratio == pytest.approx(float(steady.group(1)) / orb_ms, rel=0.1, abs=0.02)

    header, rows = read_csv(out / "matches.csv")
    assert header == MATCH_FIELDS
    assert len(rows) == n_matches > 100
    table = np.array(rows, dtype=np.float64)
    np.testing.assert_allclose(table[:, 4], table[:, 0] - table[:, 2], atol=1e-3)
    # the pictures of hopmatch.viz.overview: matches over a caption, keypoints beside a
    # colour bar (80 px)
    pic = cv2.imread(str(out / "matches.png"))
    assert pic is not None and pic.shape[1:] == (2 * 741, 3) and pic.shape[0] > 500 + 40
    assert cv2.imread(str(out / "disparity.png")).shape == (500, 741 + 80, 3)
    info = json.loads((out / "run.json").read_text())
    assert info["counts"]["matches"] == n_matches
    assert info["counts"]["correct_at_1px"] == int(correct)
    t = info["timings_ms"]
    assert info["speed"]["ratio_to_orb"] == pytest.approx(
        t["steady_state"] / t["orb_ratio_steady_state"], abs=1e-3)
    assert info["speed"]["threads"] == 1 and info["speed"]["rounds"] == 5


# --------------------------------------------------------------------------------------
# match


# --------------------------------------------------------------------------------------


def test_match_csv(pair, tmp_path):
    out = tmp_path / "new" / "nested" / "out"  # created with its parents
    res = run("match", pair["left"], pair["right"], "--out", out, "--max-disparity", 12)
    assert res.returncode == 0, res.stderr
    assert res.stderr == ""  # no progress line when stderr is not a terminal
    assert files_in(out) == ["disparity.png", "matches.csv", "matches.png", "run.json"]
    header, rows = read_csv(out / "matches.csv")
    assert header == MATCH_FIELDS
    n = int(printed(res.stdout, "matches"))
    assert len(rows) == n > 20
    table = np.array(rows, dtype=np.float64)
    assert np.median(table[:, 4]) == pytest.approx(DISPARITY, abs=0.25)
    assert (table[:, 5] >= 0).all() and (table[:, 5] <= 1).all()
    pic = cv2.imread(str(out / "matches.png"))
    assert pic.shape[1:] == (320, 3) and pic.shape[0] > 120 + 40  # a caption below
    assert cv2.imread(str(out / "disparity.png")).shape == (120, 160 + 80, 3)

    info = json.loads((out / "run.json").read_text())
    assert info["command"] == "match"
    assert set(info["versions"]) >= {"hopmatch", "opencv", "numpy", "numba"}
    assert info["versions"]["hopmatch"] == version("hopmatch")
    assert info["parameters"]["given"] == {"max_disparity": 12.0}
    assert info["parameters"]["matcher"]["max_disparity"] == 12.0
    assert info["parameters"]["detector"]["window_size"] == DericheMoravecDetector().getWindowSize()
    assert info["counts"]["matches"] == n
    assert info["counts"]["keypoints_left"] > 0
    assert {"detect_left", "detect_right", "match", "total"} <= set(info["timings_ms"])
    assert info["inputs"]["left"]["shape"] == [120, 160]


def test_match_json_no_draw_and_parameters(pair, tmp_path):
    out = tmp_path / "out"
    res = run("match", pair["left"], pair["right"], "--out", out, "--format", "json",
              "--no-draw", "--preset", "paper", "--no-subpixel", "--window-size", 7,
              "--max-disparity", 12, "--min-disparity", 0, "--similarity-gate", "none",
              "--no-cross-check")
    assert res.returncode == 0, res.stderr
    assert files_in(out) == ["matches.json", "run.json"]
    records = json.loads((out / "matches.json").read_text())
    assert isinstance(records, list) and len(records) == int(printed(res.stdout, "matches"))
    assert records and all(list(r) == MATCH_FIELDS for r in records)
    assert np.median([r["disparity"] for r in records]) == pytest.approx(DISPARITY, abs=0.25)
    params = json.loads((out / "run.json").read_text())["parameters"]
    assert params["detector"]["preset"] == "paper"
    assert params["detector"]["nms_size"] == 20  # from the preset
    assert params["detector"]["window_size"] == 7  # explicit option wins
    assert params["detector"]["subpixel"] is False
    assert params["matcher"]["similarity_gate"] is None
    assert params["matcher"]["cross_check"] is False
    assert params["matcher"]["min_disparity"] == 0.0  # explicit option wins over the preset


def test_match_plot_energy(pair, tmp_path):
    pytest.importorskip("matplotlib")
    out = tmp_path / "out"
    res = run("match", pair["left"], pair["right"], "--out", out, "--plot-energy",
              "--no-draw", "--max-disparity", 12)
    assert res.returncode == 0, res.stderr
    assert files_in(out) == ["energy.png", "matches.csv", "run.json"]
    assert cv2.imread(str(out / "energy.png")) is not None
    assert json.loads((out / "run.json").read_text())["parameters"]["record_energy"] is True


def test_match_without_matches_writes_empty_tables(tmp_path):
    flat = tmp_path / "flat.png"
    assert cv2.imwrite(str(flat), np.full((60, 80), 90, np.uint8))
    for fmt in ("csv", "json"):
        out = tmp_path / fmt
        res = run("match", flat, flat, "--out", out, "--format", fmt, "--max-disparity", 4)
        assert res.returncode == 0, res.stderr
        assert printed(res.stdout, "matches") == "0"
        if fmt == "csv":
            assert read_csv(out / "matches.csv") == (MATCH_FIELDS, [])
            assert cv2.imread(str(out / "disparity.png")).shape == (60, 80 + 80, 3)
        else:
            assert json.loads((out / "matches.json").read_text()) == []


# --------------------------------------------------------------------------------------
# detect


# --------------------------------------------------------------------------------------


def test_detect(pair, tmp_path):
    out = tmp_path / "det"
    res = run("detect", pair["left"], "--out", out, "--nms-size", 7)
    assert res.returncode == 0, res.stderr
    assert files_in(out) == ["keypoints.csv", "keypoints.png", "run.json"]
    header, rows = read_csv(out / "keypoints.csv")
    assert header == ["x", "y", "response", "size"]
    assert len(rows) == int(printed(res.stdout, "keypoints")) > 10
    table = np.array(rows, dtype=np.float64)
    assert (table[:, 0] >= 0).all() and (table[:, 0] < 160).all()
    assert (table[:, 1] >= 0).all() and (table[:, 1] < 120).all()
    assert (table[:, 3] == DericheMoravecDetector().getWindowSize()).all()
    assert cv2.imread(str(out / "keypoints.png")).shape == (120, 160, 3)
    info = json.loads((out / "run.json").read_text())
    assert info["parameters"]["detector"]["nms_size"] == 7
    assert info["counts"]["keypoints"] == len(rows)


# --------------------------------------------------------------------------------------
# Bad images: one line, exit status 2, no traceback, no files left


# --------------------------------------------------------------------------------------


BAD_IMAGES = [  # (which input is bad, key of the bad file in `pair`, words of the message)
    ("right", "missing", "no such file"),
    ("right", "garbage", "not an image OpenCV can read"),
    ("left", "truncated", "not an image OpenCV can read"),
    ("right", "empty", "empty"),
    ("left", "folder", "is a folder"),
    ("right", "short", "height 100 differs"),
]


@pytest.mark.parametrize("side, key, words", BAD_IMAGES, ids=[b[1] for b in BAD_IMAGES])
def test_bad_image(pair, tmp_path, side, key, words):
    bad = pair.get(key, tmp_path / "missing.png")
    left, right = (bad, pair["right"]) if side == "left" else (pair["left"], bad)
    out = tmp_path / "out"
    res = run("match", left, right, "--out", out, *(("--max-disparity", 12)
                                                      if key == "short" else ()))
    assert_bad_input(res, str(bad), words)
    assert not out.exists()


def test_views_of_two_heights_are_matched_as_unrectified_by_the_defaults(pair, tmp_path):
    """Without a range the pair of two heights is matched as --unrectified matches it
    (the warning line says so; fundamental_matrix.txt when a geometry was found)."""
    res = run("match", pair["left"], pair["short"], "--out", tmp_path / "o")
    assert res.returncode == 0, res.stderr
    assert re.search(r"hopmatch: warning: \S*left.png has 120 rows and \S*short.png 100, "
                     r"so they are not a rectified pair", res.stderr), res.stderr


def test_warmup_prints_its_time_and_where_the_kernels_went():
    res = run("warmup")
    assert res.returncode == 0, res.stderr
    assert re.fullmatch(r"warmup: \d+\.\d s, (kernels cached in .+|on-disk cache off.+)\n",
                        res.stdout), res.stdout
    assert run("--quiet", "warmup").stdout == ""
    assert run("warmup", "--processes", "1").returncode == 0
    res = run("warmup", "--processes", "0")
    assert res.returncode == 2 and "--processes" in res.stderr


@pytest.mark.parametrize("key", ["garbage", "folder"])
def test_detect_bad_image(pair, tmp_path, key):
    out = tmp_path / "out"
    assert_bad_input(run("detect", pair[key], "--out", out), str(pair[key]))
    assert not out.exists()


# --------------------------------------------------------------------------------------
# Unrectified pairs: --fundamental-matrix (the CLI form of setFundamentalMatrix)
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("form", ["txt", "npy", "yml"])
def test_match_with_a_fundamental_matrix(unrectified, tmp_path, form):
    left, right, f_txt = unrectified
    F = np.loadtxt(f_txt)
    path = tmp_path / f"F.{form}"
    if form == "txt":
        path = f_txt
    elif form == "npy":
        np.save(path, F)
    else:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
        fs.write("F", F)
        fs.release()
    out = tmp_path / "out"
    res = run("match", left, right, "--out", out, "--max-disparity", 12,
              "--fundamental-matrix", path)
    assert res.returncode == 0, res.stderr
    assert res.stderr == ""  # matched along the epipolar lines: nothing to warn about
    n = int(printed(res.stdout, "matches"))
    assert n > 300
    _, rows = read_csv(out / "matches.csv")
    table = np.array(rows, dtype=np.float64)
    assert np.median(table[:, 3] - table[:, 1]) == pytest.approx(8, abs=0.25)
    info = json.loads((out / "run.json").read_text())
    assert np.allclose(info["parameters"]["fundamental_matrix"], F)
    plain = run("match", left, right, "--out", tmp_path / "plain", "--max-disparity", 12)
    assert int(printed(plain.stdout, "matches")) < n / 10


def test_fundamental_matrix_lets_the_heights_differ(pair, unrectified, tmp_path):
    res = run("match", pair["left"], pair["short"], "--out", tmp_path / "o",
              "--fundamental-matrix", unrectified[2], "--max-disparity", 12)
    assert res.returncode == 0, res.stderr


BAD_F = [  # (file content, or None for a missing file; words of the message)
    (None, "no such file"),
    ("1 2 3\n", "9 numbers"),
    ("not a matrix\n", "not a matrix file"),
    ("0 0 0\n0 0 0\n0 0 0\n", "not all zeros"),
]


@pytest.mark.parametrize("content, words", BAD_F, ids=[w for _, w in BAD_F])
def test_bad_fundamental_matrix_file_exits_2(pair, tmp_path, content, words):
    path = tmp_path / "F.txt"
    if content is not None:
        path.write_text(content)
    out = tmp_path / "out"
    res = run("match", pair["left"], pair["right"], "--out", out, "--fundamental-matrix", path)
    assert_bad_input(res, str(path), words)
    assert not out.exists()


def _write_deep_yaml(path):
    path.write_text("%YAML:1.0\n---\nF: " + "[" * 50_000 + "]" * 50_000 + "\n")


BAD_F_FILES = [  # (file name, how to write it or None for a folder, words of the message)
    # OpenCV 4's parser overflowed its stack here (refused before: "crashes"); OpenCV 5's
    # refuses the file itself ("is not a matrix file")
    ("F.yml", _write_deep_yaml, ""),
    ("F.yml", lambda p: p.write_text('%YAML:1.0\n---\nF: "a string"\n'),
     "holds no matrix named F"),
    ("F.npy", lambda p: np.save(p, np.eye(3) * (1 + 1j)), "real numbers"),
    ("F.txt", None, "is a folder"),
]


@pytest.mark.parametrize("name, write, words", BAD_F_FILES,
                         ids=[w or "nested too deep" for *_, w in BAD_F_FILES])
def test_bad_fundamental_matrix_files_of_every_kind_exit_2(pair, tmp_path, name, write,
                                                           words):
    path = tmp_path / name
    path.mkdir() if write is None else write(path)
    out = tmp_path / "out"
    res = run("match", pair["left"], pair["right"], "--out", out, "--fundamental-matrix", path)
    assert_bad_input(res, str(path), words)
    assert not out.exists()


# --------------------------------------------------------------------------------------
# Exit status 2 for every bad input (issue 19, point 5)
# --------------------------------------------------------------------------------------


def test_file_names_too_long_are_bad_input(pair, tmp_path):
    long_name = str(tmp_path / ("a" * 300 + ".png"))
    assert_bad_input(run("match", long_name, pair["right"], "--out", tmp_path / "o"),
                     "too long")
    assert_bad_input(run("detect", long_name, "--out", tmp_path / "o"), "too long")
    assert_bad_input(run("match", pair["left"], pair["right"], "--out",
                         tmp_path / ("b" * 300)), "too long")


@pytest.mark.parametrize("command", ["match", "detect", "demo"])
def test_empty_output_folder_is_bad_input(pair, tmp_path, command):
    args = {"match": [pair["left"], pair["right"]], "detect": [pair["left"]], "demo": []}
    res = run(command, *args[command], "--out", "", cwd=tmp_path)
    assert_bad_input(res, "--out", "empty")
    assert files_in(tmp_path) == []  # nothing written into the working directory


def test_not_a_stereo_pair_warns_in_one_line(pair, tmp_path):
    """Two unrelated images (here random textures that share nothing) of one size."""
    other = tmp_path / "other.png"
    rng = np.random.default_rng(7)
    cv2.imwrite(str(other), cv2.resize((rng.random((30, 40)) * 255).astype(np.uint8),
                                       (160, 120)))
    res = run("match", pair["left"], other, "--out", tmp_path / "o", "--max-disparity", 12)
    assert res.returncode == 0, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        "hopmatch: warning: the pair does not look like a stereo pair"), res.stderr
    assert "--fundamental-matrix FILE" in lines[0] and "setFundamentalMatrix" not in lines[0]
