"""``hopmatch eval`` (hopmatch.cli.eval_command), through the real entry point."""

from __future__ import annotations

import csv
import subprocess
import sys

import cv2
import pytest

CLI = [sys.executable, "-m", "hopmatch.cli"]


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
        "matches_middlebury_tsukuba_ncc-wta.png", "precision_curves.png",
        "precision_vs_correct.png", "results.csv", "results.md"]
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
