"""hopmatch's error vocabulary.

Every error raised at the public boundary is one of these. They subclass the built-in
``ValueError`` / ``TypeError`` so that code written for OpenCV or NumPy catches them as it
already does; each message names the argument, what was expected and what came.
"""

from __future__ import annotations

__all__ = [
    "HopmatchError",
    "InvalidArgumentError",
    "InvalidTypeError",
    "BudgetExceededError",
    "PairInfoError",
]


class HopmatchError(Exception):
    """Base class of every error hopmatch raises on purpose."""


class InvalidArgumentError(HopmatchError, ValueError):
    """An argument has the right type but a value hopmatch cannot use."""


class InvalidTypeError(HopmatchError, TypeError):
    """An argument has a type hopmatch does not accept."""


class BudgetExceededError(InvalidArgumentError):
    """A problem would need more neurons, interactions or pixels than the configured budget.

    Raised before any large allocation, so the process is never killed for lack of memory.
    """


class PairInfoError(InvalidArgumentError):
    """``HopfieldMatcher.match`` was called without, or with inconsistent, pair information."""
