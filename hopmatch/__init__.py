"""hopmatch: sparse stereo matching with the 2D Hopfield network of Achour & Mahiddine (2002).

The public face of the package. See ``docs/`` and ``README.md``.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from . import errors
from .feature import (
    DericheMoravecDetector,
    deriche_gradient,
    gradient_windows,
    moravec_points,
    moravec_response,
)
from .matching import (
    HopfieldMatcher,
    NetworkResult,
    StereoMatchResult,
    hopfield_match,
    match_stereo,
)

try:
    __version__ = version("hopmatch")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0"

__all__ = [
    "DericheMoravecDetector",
    "HopfieldMatcher",
    "NetworkResult",
    "StereoMatchResult",
    "hopfield_match",
    "match_stereo",
    "warmup",
    "deriche_gradient",
    "errors",
    "gradient_windows",
    "moravec_points",
    "moravec_response",
]


def warmup() -> float:
    """Compile every Numba kernel now (on tiny inputs) and return the seconds it took.

    With the on-disk cache warm (``cache=True``, the default) this only loads machine code.

    Examples
    --------
    >>> seconds = warmup()
    >>> seconds >= 0.0
    True
    """
    from ._warmup import warmup as _warmup

    return _warmup()
