"""The output folder of a run (hopmatch.cli.outputs): reused, staged, left as it was on failure."""

from __future__ import annotations

import os
import sys

import pytest
from cli_helpers import MATCH_FIELDS, assert_bad_input, files_in, read_csv, run


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
