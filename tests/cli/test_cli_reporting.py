"""What the command line tells (hopmatch.cli.reporting): the status line and errors."""

from __future__ import annotations

import os

import pytest
from cli_helpers import run


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


def test_debug_shows_the_traceback(pair, tmp_path):
    res = run("--debug", "match", pair["left"], pair["right"], "--out", tmp_path / "o",
              "--max-neurons", "1")
    assert res.returncode == 2
    assert "Traceback" in res.stderr
    assert res.stderr.strip().splitlines()[-1].startswith("hopmatch: error: --max-neurons: ")


# --------------------------------------------------------------------------------------
# explain: library errors -> "<option or file>: <problem>"
# --------------------------------------------------------------------------------------

LABELS = {"": "l.png, r.png", "left": "l.png", "right": "r.png",
          "max_disparity": "--max-disparity", "min_disparity": "--min-disparity",
          "max_neurons": "--max-neurons", "on": "--on"}


def test_explain_uses_the_argument_attribute():
    from hopmatch.cli.reporting import explain
    from hopmatch.errors import InvalidArgumentError

    # the attribute wins over the name quoted first in the message
    exc = InvalidArgumentError("`min_disparity` (20.0) is above `max_disparity` (10.0)",
                               argument="max_disparity")
    err = explain(exc, LABELS)
    assert err.where == "--max-disparity"
    assert err.problem == "--min-disparity (20.0) is above --max-disparity (10.0)"
    exc = InvalidArgumentError("`left` must not be empty", argument="left")
    assert (explain(exc, LABELS).where, explain(exc, LABELS).problem) == (
        "l.png", "must not be empty")


def test_explain_falls_back_to_the_message():
    from hopmatch.cli.reporting import explain
    from hopmatch.errors import BudgetExceededError, InvalidArgumentError

    exc = BudgetExceededError("the network would have 9 neurons, more than max_neurons=1")
    err = explain(exc, LABELS)
    assert (err.where, err.problem) == (
        "--max-neurons", "the network would have 9 neurons, more than --max-neurons=1")
    # an argument the command does not know: as if there were none
    err = explain(InvalidArgumentError("`right` is odd", argument="margin"), LABELS)
    assert (err.where, err.problem) == ("r.png", "is odd")
    # bare short words ("on") are not taken for parameter names
    err = explain(InvalidArgumentError("nothing to match on"), LABELS)
    assert (err.where, err.problem) == ("l.png, r.png", "nothing to match on")


def test_explain_gives_the_command_line_advice(tmp_path):
    """An error whose advice is written for Python (``rectified=True``) reads as what to do
    on the command line: a pair too wide for OpenCV's warps given to --unrectified."""
    import cv2
    import numpy as np

    from hopmatch.cli.reporting import explain
    from hopmatch.errors import InvalidArgumentError

    exc = InvalidArgumentError("`left` is 40000 x 40 px: ...; crop or downscale the pair, or "
                               "rectify it and pass rectified=True")
    err = explain(exc, LABELS)
    assert (err.where, err.problem) == (
        "l.png", "is 40000 x 40 px: ...; crop or downscale the images, or rectify them and "
                 "match them without --unrectified")
    img = np.zeros((24, 32767), np.uint8)
    img[:, ::7] = 255
    for name in ("l.png", "r.png"):
        cv2.imwrite(str(tmp_path / name), img)
    res = run("match", str(tmp_path / "l.png"), str(tmp_path / "r.png"), "-o",
              str(tmp_path / "out"), "--unrectified")
    assert res.returncode == 2
    assert "l.png: is 32767 x 24 px" in res.stderr
    assert "rectify them and match them without --unrectified" in res.stderr
    assert "cv2.error" not in res.stderr and "rectified=True" not in res.stderr
    assert not (tmp_path / "out").exists()  # refused before any output was made


def test_guard_aborts_outputs_and_translates(tmp_path):
    from hopmatch.cli.outputs import Outputs
    from hopmatch.cli.reporting import CLIError, guard
    from hopmatch.errors import InvalidArgumentError

    out = Outputs(str(tmp_path / "new" / "out"))
    out.open()
    out.add_text("a.txt", "x")

    def body():
        raise InvalidArgumentError("`on` must be one of ['gradient', 'intensity'], got 'x'",
                                   argument="on")

    with pytest.raises(CLIError) as info:
        guard(out, LABELS, body)
    assert info.value.where == "--on" and info.value.problem.startswith("must be one of")
    assert not (tmp_path / "new").exists()
    with pytest.raises(ValueError, match="a bug"):  # not hopmatch's: left alone
        guard(None, LABELS, lambda: (_ for _ in ()).throw(ValueError("a bug")))


# --------------------------------------------------------------------------------------
# Warnings: one line, advice in command-line terms (issue 19, point 5)
# --------------------------------------------------------------------------------------

#: What a warning line must not hold: Python's location and source line, calls of the
#: Python API, parameter names instead of options.
PYTHON_ONLY = (".py:", "setFundamentalMatrix", "hopmatch.stereo", "fundamental_matrix=",
               "max_vertical", "max_disparity", "DericheMoravecDetector.create(", "return f(")


def _library_warnings():
    """The messages of every warning the library gives on a pair, through its entry
    points: (category, message)."""
    import warnings

    import cv2
    import numpy as np

    import hopmatch

    rng = np.random.default_rng(1)
    left = (rng.random((120, 160)) * 255).astype(np.uint8)
    unrect = np.roll(np.roll(left, -6, axis=1), 8, axis=0)
    other = cv2.resize((rng.random((30, 40)) * 255).astype(np.uint8), (160, 120))
    calls = [
        lambda: hopmatch.match_stereo(left, unrect, max_disparity=12),          # unrectified
        lambda: hopmatch.match_stereo(left, left[:, :150], max_disparity=12),   # widths
        lambda: hopmatch.match_stereo(left, np.roll(left, -6, axis=1),
                                      max_disparity=400),                     # range
        lambda: hopmatch.match_stereo(left, other, max_disparity=12),           # unrelated
    ]
    det = hopmatch.DericheMoravecDetector()
    kp1, d1 = det.detectAndCompute(left, None)
    kp2, d2 = det.detectAndCompute(cv2.resize(left, (200, 150)), None)
    m = hopmatch.HopfieldMatcher(max_disparity=12)
    m.setPairInfo(kp1, kp2, (160, 120), (200, 150))
    calls.append(lambda: m.match(d1, d2))                                        # sizes
    out = []
    for call in calls:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            call()
        out += [(w.category, str(w.message)) for w in caught]
    return out


def test_every_library_warning_reads_in_cli_terms():
    from hopmatch import DericheMoravecDetector, HopfieldMatcher
    from hopmatch.cli.options import param_labels
    from hopmatch.cli.reporting import warning_line
    from hopmatch.errors import (
        DisparityRangeWarning,
        ImageSizeWarning,
        UnrectifiedPairWarning,
    )
    from hopmatch.matching.diagnostics import NotStereoPairWarning

    labels = {"": "l.png, r.png", "left": "l.png", "right": "r.png",
              **param_labels(DericheMoravecDetector, HopfieldMatcher)}
    seen = _library_warnings()
    assert {c for c, _ in seen} >= {UnrectifiedPairWarning, ImageSizeWarning,
                                     DisparityRangeWarning, NotStereoPairWarning}
    for category, message in seen:
        line = warning_line(message, category, labels)
        assert line.startswith("hopmatch: warning: ") and "\n" not in line
        for bad in PYTHON_ONLY:
            assert bad not in line, (bad, line)
    unrect = next(m for c, m in seen if c is UnrectifiedPairWarning)
    line = warning_line(unrect, UnrectifiedPairWarning, labels)
    assert "--max-vertical 1" in line and "--fundamental-matrix FILE" in line
    width = next(m for c, m in seen if c is ImageSizeWarning and "`left`" in m)
    assert "l.png is 160 px wide and r.png 150 px" in warning_line(width, ImageSizeWarning,
                                                                  labels)


def test_plain_text_drops_sphinx_markup():
    from hopmatch.cli.reporting import plain_text

    assert plain_text(":func:`~hopmatch.feature.moravec_response`") == "moravec_response"
    assert plain_text(":class:`hopmatch.errors.BudgetExceededError`") \
        == "hopmatch.errors.BudgetExceededError"
    assert plain_text(":ref:`the docs <parameters>` and ``x``\n  y") == "the docs and x y"
    assert plain_text("`descriptor_size` ** 2", {"descriptor_size": "--descriptor-size"}) \
        == "--descriptor-size ** 2"


def test_unrectified_pair_warns_in_one_line(unrectified, tmp_path):
    left, right, _ = unrectified
    res = run("match", left, right, "--out", tmp_path / "o", "--max-disparity", 12)
    assert res.returncode == 0, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    line = lines[0]
    assert line.startswith("hopmatch: warning: the pair does not look rectified")
    assert "--fundamental-matrix FILE" in line and "--max-vertical 1" in line
    for bad in PYTHON_ONLY:
        assert bad not in line, (bad, line)
    # --quiet silences the summary, not the warning
    quiet = run("--quiet", "match", left, right, "--out", tmp_path / "q", "--max-disparity", 12)
    assert quiet.stdout == "" and quiet.stderr.startswith("hopmatch: warning: ")
    # --debug says where it came from
    debug = run("--debug", "match", left, right, "--out", tmp_path / "d", "--max-disparity", 12)
    assert "(UnrectifiedPairWarning at " in debug.stderr


def test_python_warning_filters_still_apply(unrectified, tmp_path):
    import subprocess
    import sys

    left, right, _ = unrectified
    res = subprocess.run([sys.executable, "-W", "ignore", "-m", "hopmatch.cli", "match",
                          str(left), str(right), "--out", str(tmp_path / "o"),
                          "--max-disparity", "12"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=180)
    assert res.returncode == 0 and res.stderr == ""
