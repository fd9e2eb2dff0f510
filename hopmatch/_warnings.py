"""Warnings that point at the user's code.

hopmatch warns from deep inside its own call chains (``HopfieldMatcher.match`` ->
``match_pair`` ...), whose depth differs by entry point, so no fixed ``stacklevel`` is right
for all of them: :func:`warn` attributes each warning to the first frame outside the
hopmatch package, the line of the user's code that called hopmatch.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import warnings
from typing import NamedTuple

_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep
#: The list :func:`warn` appends to instead of warning, within :func:`deferred_warnings`.
_deferred: contextvars.ContextVar = contextvars.ContextVar("hopmatch_deferred_warnings",
                                                           default=None)


def caller_stacklevel() -> int:
    """The ``stacklevel`` that makes ``warnings.warn``, called by the caller of this
    function, report the first frame whose code lies outside the hopmatch package and its
    plugins (modules named ``hopmatch_*``: ``hopmatch_gapi``, ``hopmatch_dask``)."""
    frame = sys._getframe(1)  # the frame that will call warnings.warn: stacklevel 1
    level = 1
    while frame is not None and (
            os.path.abspath(frame.f_code.co_filename).startswith(_PACKAGE_DIR)
            or str(frame.f_globals.get("__name__", "")).startswith("hopmatch_")):
        frame = frame.f_back
        level += 1
    return level


class PendingWarning(NamedTuple):
    """A warning kept for later by :func:`deferred_warnings`: its ``category`` and
    ``message``; calling it gives it (:func:`warn`), with any keyword arguments ignored
    (the lists the matching steps hand on are called with ``kept=`` or ``exposure=``)."""

    category: type[Warning]
    message: str

    def __call__(self, **_) -> None:
        warn(self.message, self.category)


def warn(message: str, category: type[Warning]) -> None:
    """``warnings.warn(message, category)`` attributed to the user's line of code; within
    :func:`deferred_warnings`, kept for later instead."""
    pending = _deferred.get()
    if pending is not None:
        pending.append(PendingWarning(category, message))
        return
    warnings.warn(message, category, stacklevel=caller_stacklevel())


@contextlib.contextmanager
def deferred_warnings():
    """Within the block (this context, and the worker threads that copy it), :func:`warn`
    appends each warning, as a :class:`PendingWarning` (calling it gives it), to the list
    the block yields instead of giving it: for a caller that runs two matches and gives
    the warnings of the one it keeps (:mod:`hopmatch.matching.channels`), and for
    :func:`hopmatch.errors.collect_warnings`."""
    pending: list = []
    token = _deferred.set(pending)
    try:
        yield pending
    finally:
        _deferred.reset(token)


@contextlib.contextmanager
def deferring(later: list | None):
    """Within the block, :func:`warn` appends each warning to the list ``later`` as a
    callable that gives it (and takes and ignores keyword arguments, as the callables of
    the lists the matching steps hand on take ``kept=`` or ``exposure=``); with ``later``
    None the warnings are given as usual. For a step whose caller may keep another result
    instead: the warnings of a result that is not kept are never given. A block that
    raises drops its warnings."""
    if later is None:
        yield
        return
    with deferred_warnings() as pending:
        yield
    later.extend(pending)


def give_or_defer(pending: list, warnings_later: list | None) -> None:
    """Give the warnings ``pending`` (callables of no argument) now, or append them to
    ``warnings_later``, for a caller that may keep another result instead and give its
    warnings only (``hopmatch.matching.stereo_match``)."""
    if warnings_later is not None:
        warnings_later.extend(pending)
    else:
        for give in pending:
            give()
