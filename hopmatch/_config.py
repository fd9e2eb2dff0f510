"""The single Numba policy of hopmatch: every kernel is compiled through :func:`jit`.

- ``fastmath`` is on without ``nnan``/``ninf``: NaN and infinity keep their IEEE meaning, so
  kernels that see NaN (masked or unknown values) stay correct.
- Kernels whose results are compared bit-for-bit with a NumPy reference use
  ``jit(exact=True)``: no fastmath at all, so the order of floating-point operations is the
  one written in the source.
- So do kernels with a loop that writes a buffer while it sums floats. With ``reassoc``
  LLVM vectorises such a sum only behind a runtime check that the buffers the loop reads
  and writes lie apart in memory, and runs the scalar loop, which sums in another order,
  when they do not: the last bits of the result then depend on where the allocator put
  the kernel's scratch arrays, which differs between calls (and more so between threads).
  The guided pass's row search did this (fields 1 ulp apart between runs); the test
  ``tests/test_determinism.py::test_no_kernel_sums_in_a_loop_vectorised_behind_a_memory_check``
  scans every kernel's compiled code for such a loop.
- ``cache=True`` writes compiled machine code next to the package (or to
  ``NUMBA_CACHE_DIR``); set ``HOPMATCH_NUMBA_CACHE=0`` to turn it off. When the package
  folder is read-only (a system-wide install) and ``NUMBA_CACHE_DIR`` is unset, caching is
  off rather than failing at import.
- Every kernel is ``nogil``, so hopmatch objects can run in concurrent threads.
- A helper whose callers must round as if its body were written in place is compiled
  ``jit(inline=True)`` (inlined in Numba's IR, before fastmath can reassociate it apart).
- The moment Numba starts compiling one of hopmatch's kernels (not when it loads one from
  the cache), one line says so on stderr, once per process (:class:`CompileNotice`);
  ``HOPMATCH_COMPILE_NOTICE=0`` silences it. The same moment starts a second Python
  process that compiles the kernels the pipeline needs last into the on-disk cache
  (``hopmatch._warmup.start_background_helper``; ``HOPMATCH_COMPILE_HELPER=0`` turns it
  off).
"""

from __future__ import annotations

import os
import sys
import threading
from pathlib import Path

import numba
from numba.core import event as numba_event

FASTMATH: frozenset[str] = frozenset({"nsz", "arcp", "contract", "afn", "reassoc"})

#: Seconds of the "about N s" in the first-run notice: what compiling every kernel in one
#: process takes on a 2-core machine (23-25 s on the development machine, 35 s on a slower
#: one: ``hopmatch.warmup(1)`` in docs/performance.md, "The first run") ...
COMPILE_SECONDS = 30
#: ... and with the helper process compiling the kernels needed last (a cold first
#: ``match_stereo`` 12.5-14 s there, ``warmup()`` 13.7-15.9 s).
COMPILE_SECONDS_WITH_HELPER = 20

_OFF = {"0", "false", "no", "off"}


def switched_off(variable: str) -> bool:
    """Whether the environment variable ``variable`` turns its switch off (``0``,
    ``false``, ``no`` or ``off``, any case; unset means on)."""
    return os.environ.get(variable, "1").strip().lower() in _OFF


def _cache_wanted() -> bool:
    if switched_off("HOPMATCH_NUMBA_CACHE"):
        return False
    if os.environ.get("NUMBA_CACHE_DIR"):
        return True
    return os.access(Path(__file__).resolve().parent / "_kernels", os.W_OK)


CACHE: bool = _cache_wanted()


def compile_notice_text(helper: bool = False) -> str:
    """The line :class:`CompileNotice` writes (without the newline); ``helper``: a helper
    process compiles part of the kernels (``hopmatch._warmup``)."""
    if CACHE:
        where = os.environ.get("NUMBA_CACHE_DIR") or "the package folder"
        seconds = COMPILE_SECONDS_WITH_HELPER if helper else COMPILE_SECONDS
        return (f"hopmatch: compiling hopmatch's kernels for this CPU, first run only, about "
                f"{seconds} s (cached in {where}; `hopmatch warmup` compiles them all "
                "ahead)")
    return (f"hopmatch: compiling hopmatch's kernels for this CPU, about {COMPILE_SECONDS} s "
            "(the on-disk cache is off, so every process compiles them; set NUMBA_CACHE_DIR "
            "to a writable folder to keep them)")


class CompileNotice(numba_event.Listener):
    """Writes :func:`compile_notice_text` to stderr when Numba starts compiling a kernel of
    hopmatch, once per process.

    Numba broadcasts a ``"numba:compile"`` event only when it compiles a specialisation,
    never when it loads one from the on-disk cache (``Dispatcher.compile`` returns the
    cached entry point before the event), so a warm cache prints nothing, wherever
    ``NUMBA_CACHE_DIR`` points. Kernels of other packages are ignored.
    """

    def __init__(self):
        self._lock = threading.Lock()
        self.shown = False

    @staticmethod
    def is_ours(ev) -> bool:
        data = ev.data if isinstance(ev.data, dict) else {}
        func = getattr(data.get("dispatcher"), "py_func", None)
        return (getattr(func, "__module__", None) or "").split(".")[0] == "hopmatch"

    def on_start(self, ev) -> None:
        if self.shown or not self.is_ours(ev):
            return
        with self._lock:
            if self.shown:
                return
            self.shown = True
        from ._warmup import start_background_helper

        helper = start_background_helper()  # a second process for the kernels needed last
        if switched_off("HOPMATCH_COMPILE_NOTICE"):
            return
        try:
            stream = sys.stderr
            clear = "\r\033[K" if stream.isatty() else ""  # over a CLI status line
            stream.write(f"{clear}{compile_notice_text(helper)}\n")
            stream.flush()
        except (AttributeError, OSError, ValueError):  # no usable stderr (pythonw, closed)
            pass

    def on_end(self, ev) -> None:
        pass


#: The listener of this process, registered before any kernel is defined.
COMPILE_NOTICE = CompileNotice()
numba_event.register("numba:compile", COMPILE_NOTICE)


def jit(*signature, exact: bool = False, inline: bool = False):
    """Decorate a kernel with hopmatch's Numba policy (``nopython``, ``nogil``, cached).

    ``inline=True`` inlines the kernel into its callers in Numba's IR, before LLVM sees
    either: the callers' code is then what it would be with the body written in place, so a
    small helper shared by two loops rounds exactly as the loops did when each held its own
    copy (compiled apart, fastmath may reassociate the helper's sums another way).
    """
    return numba.njit(
        *signature,
        cache=CACHE,
        nogil=True,
        fastmath=False if exact else set(FASTMATH),
        error_model="numpy",
        inline="always" if inline else "never",
    )
