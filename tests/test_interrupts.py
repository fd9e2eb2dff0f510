"""Ctrl-C stays KeyboardInterrupt when it lands in a Numba kernel (hopmatch._interrupts).

A signal handler that raises while a compiled kernel boxes its results makes Numba report
``SystemError: CPUDispatcher(...) returned a result with an exception set`` (the interrupt
as its cause): the public entry points raise the interrupt itself.
"""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest

import hopmatch
from hopmatch import DericheMoravecDetector, HopfieldMatcher, StereoHopfield
from hopmatch._interrupts import interrupt_in, keeps_interrupts


def _numba_like_error(interrupt: BaseException) -> SystemError:
    """A SystemError raised from ``interrupt`` through a second SystemError, as Numba chains
    them (the interrupt inside ``_numba_unpickle``, then the dispatcher's own)."""
    try:
        try:
            try:
                raise interrupt
            except BaseException as exc:
                raise SystemError("_numba_unpickle returned a result with an exception set") \
                    from exc
        except SystemError as exc:
            raise SystemError("CPUDispatcher(<function k>) returned a result with an "
                              "exception set") from exc
    except SystemError as exc:
        return exc


class Stop(KeyboardInterrupt):
    """Like the command line's Terminated: a KeyboardInterrupt subclass."""


def test_interrupt_in_finds_the_interrupt_along_the_chain():
    ki = KeyboardInterrupt()
    assert interrupt_in(_numba_like_error(ki)) is ki
    stop = Stop()
    assert interrupt_in(_numba_like_error(stop)) is stop
    assert interrupt_in(ki) is ki
    assert interrupt_in(SystemError("no cause")) is None
    assert interrupt_in(_numba_like_error(ValueError("x"))) is None
    looped = SystemError("a")  # a cycle of contexts ends the walk
    other = SystemError("b")
    looped.__context__, other.__context__ = other, looped
    assert interrupt_in(looped) is None


def test_keeps_interrupts_raises_the_interrupt_itself_and_nothing_else():
    ki = KeyboardInterrupt()

    @keeps_interrupts
    def interrupted(error):
        """Docs kept."""
        raise error

    with pytest.raises(KeyboardInterrupt) as info:
        interrupted(_numba_like_error(ki))
    assert info.value is ki
    assert interrupted.__doc__ == "Docs kept." and interrupted.__name__ == "interrupted"
    plain = SystemError("a SystemError of another kind")
    with pytest.raises(SystemError) as info:
        interrupted(plain)
    assert info.value is plain
    with pytest.raises(ValueError):
        interrupted(ValueError("v"))
    assert keeps_interrupts(lambda x: x + 1)(1) == 2


#: The public callables that run kernels: each must be wrapped by keeps_interrupts.
ENTRY_POINTS = {
    "match_stereo": hopmatch.match_stereo,
    "hopfield_match": hopmatch.hopfield_match,
    "deriche_gradient": hopmatch.deriche_gradient,
    "moravec_response": hopmatch.moravec_response,
    "moravec_points": hopmatch.moravec_points,
    "gradient_windows": hopmatch.gradient_windows,
    **{f"DericheMoravecDetector.{m}": getattr(DericheMoravecDetector, m) for m in (
        "feature_image", "gray_and_feature_image", "points_on", "detect_points",
        "describe_points", "detect_and_describe", "detect", "compute", "detectAndCompute")},
    **{f"HopfieldMatcher.{m}": getattr(HopfieldMatcher, m) for m in (
        "setPairInfo", "estimateFundamentalMatrix", "run", "match", "knnMatch",
        "radiusMatch")},
    "StereoHopfield.compute": StereoHopfield.compute,
}


@pytest.mark.parametrize("name", sorted(ENTRY_POINTS))
def test_entry_points_that_run_kernels_keep_interrupts(name):
    wrapper_code = keeps_interrupts(len).__code__
    assert ENTRY_POINTS[name].__code__ is wrapper_code, name
    assert ENTRY_POINTS[name].__wrapped__.__name__ == name.rsplit(".", 1)[-1]


def test_the_command_line_keeps_interrupts(monkeypatch, capsys):
    # the command line's Terminated is a KeyboardInterrupt: exit 128 + its signal, not an
    # internal error, when it reaches main() inside Numba's SystemError
    from hopmatch import cli
    from hopmatch.cli.outputs import Terminated

    def interrupted(*args, **kwargs):
        raise _numba_like_error(Terminated(signal.SIGTERM))

    monkeypatch.setattr(cli.cli, "main", interrupted)
    assert cli.main(["demo"]) == 128 + signal.SIGTERM
    assert "hopmatch: interrupted" in capsys.readouterr().err


REAL_SIGNALS = """
import signal, sys
import numpy as np
import hopmatch
rng = np.random.default_rng(0)
left = rng.integers(0, 256, (600, 600)).astype(np.uint8)
right = np.roll(left, -6, axis=1)
hopmatch.match_stereo(left, right, max_disparity=16)  # compiled, and how long one takes
def handler(signum, frame):
    raise KeyboardInterrupt
signal.signal(signal.SIGALRM, handler)
kinds = []
for i in range(int(sys.argv[1])):
    signal.setitimer(signal.ITIMER_REAL, 0.002 + 0.011 * i)
    try:
        hopmatch.match_stereo(left, right, max_disparity=16)
        kinds.append("none")
    except BaseException as exc:
        kinds.append(type(exc).__name__)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
print(" ".join(kinds))
"""


@pytest.mark.skipif(not hasattr(signal, "setitimer"), reason="needs signal.setitimer (POSIX)")
def test_a_real_interrupt_during_matching_is_a_keyboard_interrupt():
    # SIGALRM's handler raises KeyboardInterrupt at 30 moments spread over a match: many land
    # while a kernel runs (before the fix about two thirds of them came out as SystemError)
    res = subprocess.run([sys.executable, "-c", REAL_SIGNALS, "30"], capture_output=True,
                         text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    kinds = res.stdout.split()
    assert len(kinds) == 30
    assert set(kinds) <= {"KeyboardInterrupt", "none"}, kinds
    assert kinds.count("KeyboardInterrupt") >= 10
