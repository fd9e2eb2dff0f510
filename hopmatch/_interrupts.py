"""Ctrl-C (``KeyboardInterrupt``) kept as itself when it lands in a Numba kernel's return.

A compiled kernel builds its Python results (boxing) with a call back into Python
(Numba's ``_numba_unpickle``); when a signal handler raises there (SIGINT's
``KeyboardInterrupt``, or the command line's :class:`~hopmatch.cli.outputs.Terminated`),
Numba reports ``SystemError: CPUDispatcher(...) returned a result with an exception set``,
the interrupt as its cause. A user who pressed Ctrl-C would get an internal-looking error
(and the command line exit 1, "internal error", rather than 130, "interrupted"). The public
entry points that run kernels are wrapped in :func:`keeps_interrupts`, which raises the
interrupt itself instead.
"""

from __future__ import annotations

import functools

__all__ = ["interrupt_in", "keeps_interrupts"]


def interrupt_in(exc: BaseException) -> KeyboardInterrupt | None:
    """The ``KeyboardInterrupt`` (a subclass included) among ``exc`` and the exceptions it
    was raised from or while handling (``__cause__``, else ``__context__``), nearest
    first; None when there is none."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def keeps_interrupts(func):
    """``func``, raising the ``KeyboardInterrupt`` a ``SystemError`` carries
    (:func:`interrupt_in`) instead of that ``SystemError``; other errors pass unchanged."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except SystemError as exc:
            interrupt = interrupt_in(exc)
            if interrupt is None:
                raise
            raise interrupt from None
    return wrapper
