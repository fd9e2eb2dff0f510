"""The ``hopmatch`` command line, run through its real entry points in subprocesses.

``python -m hopmatch.cli`` everywhere, and the installed ``hopmatch`` console script (next
to ``sys.executable``) when it exists. Also the atomic writers the commands rely on, as
:mod:`hopmatch.viz` exports them (the drawing functions are tested in ``tests/viz/``).
"""

from __future__ import annotations

import csv
import json
import os
import re
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import cv2
import numpy as np
import pytest

from hopmatch import DericheMoravecDetector, HopfieldMatcher, viz

CLI = [sys.executable, "-m", "hopmatch.cli"]
SCRIPT = Path(sys.executable).with_name("hopmatch.exe" if os.name == "nt" else "hopmatch")
DISPARITY = 6
MATCH_FIELDS = ["left_x", "left_y", "right_x", "right_y", "disparity", "distance"]


def run(*args, cwd=None, cmd=CLI, stderr=subprocess.PIPE, timeout=180):
    return subprocess.run([*cmd, *map(str, args)], cwd=cwd, stdout=subprocess.PIPE,
                          stderr=stderr, text=True, timeout=timeout)


def files_in(folder: Path) -> list[str]:
    """Every entry of ``folder`` (hidden temporary files included); [] if it does not exist."""
    return sorted(p.name for p in folder.iterdir()) if folder.exists() else []


def assert_bad_input(res, *needles):
    """Exit status 2 and one line ``hopmatch: error: <where>: <problem>`` naming the input."""
    assert res.returncode == 2, (res.returncode, res.stdout, res.stderr)
    assert "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert re.match(r"^hopmatch: error: .+: .+", lines[0]), lines[0]
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])
    return lines[0]


def read_csv(path: Path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], rows[1:]


def printed(stdout: str, key: str) -> str:
    m = re.search(rf"^{re.escape(key)}: (.*)$", stdout, re.M)
    assert m, (key, stdout)
    return m.group(1)


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """A random-texture rectified pair with disparity 6 everywhere, as PNG files."""
    folder = tmp_path_factory.mktemp("pair")
    rng = np.random.default_rng(1)
    left = (rng.random((120, 160)) * 255).astype(np.uint8)
    right = np.roll(left, -DISPARITY, axis=1)
    paths = {"left": folder / "left.png", "right": folder / "right.png",
             "short": folder / "short.png", "garbage": folder / "garbage.png",
             "truncated": folder / "truncated.png", "empty": folder / "empty.png",
             "folder": folder / "a_folder.png"}
    assert cv2.imwrite(str(paths["left"]), left)
    assert cv2.imwrite(str(paths["right"]), right)
    assert cv2.imwrite(str(paths["short"]), right[:100])
    paths["garbage"].write_bytes(b"this is not an image at all")
    data = paths["left"].read_bytes()
    paths["truncated"].write_bytes(data[: len(data) // 2])
    paths["empty"].write_bytes(b"")
    paths["folder"].mkdir()
    return paths


# --------------------------------------------------------------------------------------
# Help and version
# --------------------------------------------------------------------------------------


def test_help_lists_commands():
    res = run("--help")
    assert res.returncode == 0, res.stderr
    for command in ("demo", "match", "detect"):
        assert command in res.stdout


def test_match_help_has_an_option_for_every_parameter():
    res = run("match", "--help")
    assert res.returncode == 0, res.stderr
    for spec in DericheMoravecDetector.PARAMS + HopfieldMatcher.PARAMS:
        flag = "--" + spec.name.replace("_", "-")
        assert flag in res.stdout, flag
        if isinstance(spec.default, bool):
            assert "--no-" + spec.name.replace("_", "-") in res.stdout
    for flag in ("--out", "--format", "--no-draw", "--plot-energy", "--preset"):
        assert flag in res.stdout
    detect_help = run("detect", "--help").stdout
    assert "--window-size" in detect_help and "--max-disparity" not in detect_help


def test_version():
    res = run("--version")
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"hopmatch {version('hopmatch')} ")
    for name in ("opencv", "numpy", "numba"):
        assert name in res.stdout


@pytest.mark.skipif(not SCRIPT.exists(), reason=f"no installed console script at {SCRIPT}")
def test_installed_console_script(pair, tmp_path):
    res = run("--version", cmd=[str(SCRIPT)])
    assert res.returncode == 0, res.stderr
    assert version("hopmatch") in res.stdout
    out = tmp_path / "out"
    bad = run("match", pair["left"], tmp_path / "missing.png", "--out", out, cmd=[str(SCRIPT)])
    assert_bad_input(bad, "missing.png", "no such file")
    assert files_in(out) == []


def test_no_command_prints_help():
    res = run()
    assert "Usage:" in res.stdout + res.stderr
    assert "Traceback" not in res.stderr


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

    header, rows = read_csv(out / "matches.csv")
    assert header == MATCH_FIELDS
    assert len(rows) == n_matches > 100
    table = np.array(rows, dtype=np.float64)
    np.testing.assert_allclose(table[:, 4], table[:, 0] - table[:, 2], atol=1e-3)
    for name, width in (("matches.png", 2 * 741), ("disparity.png", 741)):
        img = cv2.imread(str(out / name))
        assert img is not None and img.shape == (500, width, 3), name
    info = json.loads((out / "run.json").read_text())
    assert info["counts"]["matches"] == n_matches
    assert info["counts"]["correct_at_1px"] == int(correct)


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
    assert cv2.imread(str(out / "matches.png")).shape == (120, 320, 3)
    assert cv2.imread(str(out / "disparity.png")).shape == (120, 160, 3)

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
            assert cv2.imread(str(out / "disparity.png")).shape == (60, 80, 3)
        else:
            assert json.loads((out / "matches.json").read_text()) == []


def test_existing_folder_is_reused(pair, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / "matches.csv").write_text("old")
    res = run("--quiet", "match", pair["left"], pair["right"], "-o", out, "--no-draw",
              "--max-disparity", 12)
    assert res.returncode == 0, res.stderr
    assert res.stdout == "" and res.stderr == ""  # --quiet
    assert files_in(out) == ["matches.csv", "notes.txt", "run.json"]
    assert (out / "notes.txt").read_text() == "mine"
    assert read_csv(out / "matches.csv")[0] == MATCH_FIELDS


@pytest.mark.skipif(os.name != "posix", reason="needs a pseudo-terminal")
def test_progress_line_only_on_a_terminal_and_not_quiet(pair, tmp_path):
    import pty

    def stderr_on_tty(*args):
        master, slave = pty.openpty()
        try:
            res = run(*args, stderr=slave)
            os.close(slave)
            slave = None
            chunks = []
            while True:
                try:
                    chunk = os.read(master, 4096)
                except OSError:
                    break
                if not chunk:
                    break
                chunks.append(chunk)
            return res, b"".join(chunks).decode(errors="replace")
        finally:
            if slave is not None:
                os.close(slave)
            os.close(master)

    args = ("match", pair["left"], pair["right"], "--out", tmp_path / "a", "--no-draw",
            "--max-disparity", 12)
    res, text = stderr_on_tty(*args)
    assert res.returncode == 0
    assert "hopmatch: detecting and matching" in text
    res, text = stderr_on_tty("--quiet", *args)
    assert res.returncode == 0 and "hopmatch:" not in text


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
# Bad input: one line, exit status 2, no traceback, no files left
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
    res = run("match", left, right, "--out", out)
    assert_bad_input(res, str(bad), words)
    assert not out.exists()


@pytest.mark.parametrize("key", ["garbage", "folder"])
def test_detect_bad_image(pair, tmp_path, key):
    out = tmp_path / "out"
    assert_bad_input(run("detect", pair[key], "--out", out), str(pair[key]))
    assert not out.exists()


BAD_OPTIONS = [  # (extra arguments, words the message must hold)
    (["--window-size", "4"], ["--window-size", "odd", "4"]),
    (["--window-size", "abc"], ["--window-size", "abc"]),
    (["--preset", "fancy"], ["--preset", "fancy", "paper"]),
    (["--on", "colour"], ["--on", "gradient"]),
    (["--alpha", "0"], ["--alpha"]),
    (["--similarity-gate", "-1"], ["--similarity-gate"]),
    (["--max-disparity", "nan"], ["--max-disparity"]),
    (["--format", "xml"], ["--format", "xml"]),
    (["--bogus"], ["--bogus", "no such option"]),
    # only found while running: the output folder exists by then and must be cleaned up
    (["--min-disparity", "20", "--max-disparity", "10"], ["--max-disparity", "--min-disparity"]),
    (["--max-neurons", "1"], ["--max-neurons"]),
]


@pytest.mark.parametrize("extra, words", BAD_OPTIONS, ids=[" ".join(b[0]) for b in BAD_OPTIONS])
def test_bad_option(pair, tmp_path, extra, words):
    out = tmp_path / "a" / "out"
    res = run("match", pair["left"], pair["right"], "--out", out, *extra)
    line = assert_bad_input(res, *words)
    assert line.startswith(f"hopmatch: error: {words[0]}: ")
    assert not (tmp_path / "a").exists()  # folders created by the failed run are removed


def test_missing_out_option(pair):
    assert_bad_input(run("match", pair["left"], pair["right"]), "--out", "missing")


def test_failure_in_existing_folder_leaves_it_as_it_was(pair, tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "matches.csv").write_text("from an earlier run")
    res = run("match", pair["left"], pair["right"], "--out", out, "--max-neurons", "1")
    assert_bad_input(res, "--max-neurons")
    assert files_in(out) == ["matches.csv"]  # no temporary files either
    assert (out / "matches.csv").read_text() == "from an earlier run"


def test_output_path_under_a_file(pair, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    out = blocker / "sub"
    assert_bad_input(run("match", pair["left"], pair["right"], "--out", out), str(out),
                     "not a folder")
    res = run("match", pair["left"], pair["right"], "--out", blocker)
    assert_bad_input(res, str(blocker), "not a folder")
    assert blocker.read_text() == "x"


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0,
                    reason="needs POSIX permissions and a non-root user")
def test_read_only_output_folder(pair, tmp_path):
    out = tmp_path / "ro"
    out.mkdir()
    out.chmod(0o555)
    try:
        res = run("match", pair["left"], pair["right"], "--out", out)
        assert_bad_input(res, str(out), "permission denied")
        assert files_in(out) == []
    finally:
        out.chmod(0o755)


@pytest.mark.skipif(not sys.platform.startswith("linux") or not os.path.isdir("/proc/self"),
                    reason="needs Linux /proc (a folder nobody can write in, even root)")
def test_unwritable_output_folder(pair):
    res = run("match", pair["left"], pair["right"], "--out", "/proc/self")
    assert_bad_input(res, "/proc/self", "cannot write")


def test_debug_shows_the_traceback(pair, tmp_path):
    res = run("--debug", "match", pair["left"], pair["right"], "--out", tmp_path / "o",
              "--max-neurons", "1")
    assert res.returncode == 2
    assert "Traceback" in res.stderr
    assert res.stderr.strip().splitlines()[-1].startswith("hopmatch: error: --max-neurons: ")


# --------------------------------------------------------------------------------------
# hopmatch.viz.write_image_atomic, write_text_atomic
# --------------------------------------------------------------------------------------


class TestAtomicWriters:
    img = np.zeros((40, 50), np.uint8)

    def test_atomic_writers_leave_nothing_on_failure(self, tmp_path):
        path = viz.write_image_atomic(tmp_path / "a.png", self.img)
        assert cv2.imread(str(path), cv2.IMREAD_GRAYSCALE).shape == (40, 50)
        viz.write_text_atomic(tmp_path / "a.txt", "hello")
        assert (tmp_path / "a.txt").read_text() == "hello"
        with pytest.raises(ValueError, match="encode"):
            viz.write_image_atomic(tmp_path / "b.unknownext", self.img)
        with pytest.raises(OSError):  # the destination is a folder: os.replace fails
            (tmp_path / "dir.txt").mkdir()
            viz.write_text_atomic(tmp_path / "dir.txt", "x")
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "a.txt", "dir.txt"]


def test_batch_is_attached_from_the_dask_plugin(tmp_path):
    """`hopmatch batch` comes from hopmatch_dask, through the real entry point."""
    res = run("--help")
    assert res.returncode == 0 and "batch" in res.stdout
    res = run("batch", tmp_path / "missing.csv", "--out", tmp_path / "out")
    assert res.returncode == 2
    assert "missing.csv" in res.stderr and "Traceback" not in res.stderr
