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
