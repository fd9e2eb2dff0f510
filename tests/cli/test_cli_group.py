"""The command group (hopmatch.cli.group): help, version, the console script, plugin commands."""

from __future__ import annotations

from importlib.metadata import version

import pytest
from cli_helpers import SCRIPT, assert_bad_input, files_in, run


def test_help_lists_commands():
    res = run("--help")
    assert res.returncode == 0, res.stderr
    for command in ("demo", "match", "detect"):
        assert command in res.stdout


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


def test_batch_is_attached_from_the_dask_plugin(tmp_path):
    """`hopmatch batch` comes from hopmatch_dask, through the real entry point."""
    res = run("--help")
    assert res.returncode == 0 and "batch" in res.stdout
    res = run("batch", tmp_path / "missing.csv", "--out", tmp_path / "out")
    assert res.returncode == 2
    assert "missing.csv" in res.stderr and "Traceback" not in res.stderr
