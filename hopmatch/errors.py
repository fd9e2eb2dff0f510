"""hopmatch's error vocabulary.

Every error raised at the public boundary is one of these, and every warning hopmatch emits
is a :class:`HopmatchWarning` (see ``docs/robustness.md``). They subclass the built-in
``ValueError`` / ``TypeError`` so that code written for OpenCV or NumPy catches them as it
already does; each message names the argument, what was expected and what came, and
:attr:`HopmatchError.argument` holds that argument's name for programs (the command line
maps it to its option).
"""

from __future__ import annotations

import contextlib
import os

from ._warnings import deferred_warnings

__all__ = [
    "collect_warnings",
    "HopmatchError",
    "InvalidArgumentError",
    "InvalidTypeError",
    "BudgetExceededError",
    "PairInfoError",
    "ConcurrentPairInfoError",
    "FileReadError",
    "FileWriteError",
    "HopmatchWarning",
    "ImageSizeWarning",
    "DisparityRangeWarning",
    "UnrectifiedPairWarning",
    "FewMatchesWarning",
    "NotStereoPairWarning",
    "GeometryWarning",
    "BudgetExceededWarning",
]


class HopmatchError(Exception):
    """Base class of every error hopmatch raises on purpose.

    Attributes
    ----------
    argument : str or None
        The name of the parameter or argument the error is about (``"window_size"``,
        ``"left"``), as the message spells it between backticks; None when the error is
        not about one argument (or was raised where that is not known). Given as the
        keyword ``argument=`` or set afterwards by the code that validated the value.

    Examples
    --------
    >>> import hopmatch
    >>> try:
    ...     hopmatch.DericheMoravecDetector.create(window_size=4)
    ... except HopmatchError as exc:
    ...     print(exc.argument, "|", exc)
    window_size | `window_size` must be odd, got 4
    """

    argument: str | None = None

    def __init__(self, *args, argument: str | None = None):
        super().__init__(*args)
        self.argument = argument


class InvalidArgumentError(HopmatchError, ValueError):
    """An argument has the right type but a value hopmatch cannot use.

    Examples
    --------
    >>> import hopmatch
    >>> try:
    ...     hopmatch.DericheMoravecDetector.create(window_size=4)
    ... except ValueError as exc:          # code written for OpenCV/NumPy catches it
    ...     print(type(exc).__name__, isinstance(exc, InvalidArgumentError))
    InvalidArgumentError True
    """


class InvalidTypeError(HopmatchError, TypeError):
    """An argument has a type hopmatch does not accept."""


class BudgetExceededError(InvalidArgumentError):
    """A problem would need more neurons, interactions or pixels than the configured budget.

    Raised before any large allocation, so the process is never killed for lack of memory.
    """


class PairInfoError(InvalidArgumentError):
    """``HopfieldMatcher.match`` was called without, or with inconsistent, pair information."""


class ConcurrentPairInfoError(PairInfoError):
    """A ``HopfieldMatcher`` shared by threads had its pair information replaced by another
    thread (``setPairInfo``, ``setFundamentalMatrix``, ``clearPairInfo``) after this
    thread set its own, or while this thread was matching: the matches would belong to
    another thread's keypoints, so none are returned. Give each thread its own matcher
    (``matcher.clone(emptyTrainData=True)``)."""


class FileReadError(InvalidArgumentError):
    """A file to read is missing, not a regular file, too large or refused by the system.

    ``path`` and ``problem`` hold the two halves of the message ``"<path>: <problem>"``;
    ``kind`` is one of the keys of :data:`hopmatch.files.READ_KINDS` (or None).
    """

    def __init__(self, path, problem: str, kind: str | None = None,
                 argument: str | None = None):
        self.path = os.fspath(path)
        self.problem = problem
        self.kind = kind
        super().__init__(f"{self.path}: {problem}", argument=argument)


class FileWriteError(InvalidArgumentError, OSError):
    """A file cannot be written: its folder is missing or unwritable, its name too long,
    or a folder stands where it should go. Also an ``OSError`` (``errno`` set when the
    system gave one), so that code catching either keeps working; the message names the
    destination, never the temporary file used on the way."""

    def __str__(self) -> str:  # the message, not OSError's "[Errno n] ..." of errno
        return str(self.args[0]) if self.args else ""


# -- warnings ------------------------------------------------------------------------------
#
# A warning means: the call worked, but the input looks like a mistake that would give poor
# matches without any error. Silence one kind with
# ``warnings.simplefilter("ignore", hopmatch.errors.UnrectifiedPairWarning)``, or turn all of
# them into errors with ``warnings.simplefilter("error", hopmatch.errors.HopmatchWarning)``.


class HopmatchWarning(UserWarning):
    """Base class of every warning hopmatch emits."""


class ImageSizeWarning(HopmatchWarning):
    """The two images of a pair said to be rectified differ in size (``match_stereo``
    refuses different heights outright; a different width, or a matcher given different
    sizes through ``setPairInfo``, is warned about)."""


class DisparityRangeWarning(HopmatchWarning):
    """The disparity range cannot fit the image: ``max_disparity`` or ``-min_disparity`` is
    at least the left image's width, so part of the range can never hold a match."""


class UnrectifiedPairWarning(HopmatchWarning):
    """The pair does not look rectified: the points' best look-alikes in a generous band lie
    well above or below them (see ``docs/robustness.md``, "Rectification check")."""


class FewMatchesWarning(HopmatchWarning):
    """A pair with enough keypoints gave no or almost no matches; the message says the
    likely cause (different gain or dtype of the two images, an empty search window, no
    neighbours, no active neuron...). See ``docs/robustness.md``, "Few matches"."""


class NotStereoPairWarning(FewMatchesWarning):
    """The two images do not look like two views of one scene: almost no left point has a
    look-alike anywhere near its row in the right image (see
    :func:`hopmatch.matching.diagnostics.stereo_pair_evidence`). A
    :class:`FewMatchesWarning` whose cause is that diagnosis."""


class BudgetExceededWarning(HopmatchWarning):
    """An optional step of the call was left out because it would exceed a budget
    (:class:`BudgetExceededError`: ``max_neurons``, ``max_interactions``...) that the call's
    other steps fit: with ``both_features=True``, the second run, on the other feature
    image. The result is that of the steps made; raise the budget the message names or
    narrow the disparity range to have the step."""


class GeometryWarning(HopmatchWarning):
    """No epipolar geometry could be estimated from the pair (``match_stereo(...,
    rectified=False)``, ``HopfieldMatcher.estimateFundamentalMatrix``): too few
    correspondences, or too few of them agree on one fundamental matrix. The result is
    empty (no matches) rather than built on a wrong F."""


@contextlib.contextmanager
def collect_warnings():
    """Keep the warnings hopmatch gives within the block instead of giving them.

    Yields a list to which each :class:`HopmatchWarning` that hopmatch gives in this
    context (this thread, and the threads hopmatch hands part of its work to) is appended
    as a ``(category, message)`` named tuple, not shown and not subject to the warning
    filters; other warnings are given as usual. Calling an item gives it then (attributed
    to the caller's line). For code that matches on behalf of someone else and hands the
    warnings on with the result: a worker process of a cluster (the Dask plugin), a
    server. A block that raises hands its warnings to no one.

    Examples
    --------
    >>> import numpy as np, hopmatch
    >>> flat = np.zeros((64, 64), np.uint8)
    >>> with collect_warnings() as caught:
    ...     result = hopmatch.match_stereo(flat, flat)
    >>> [(category.__name__, len(result.disparities)) for category, message in caught]
    [('FewMatchesWarning', 0)]
    """
    with deferred_warnings() as pending:
        yield pending
