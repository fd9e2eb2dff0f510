"""hopmatch: sparse stereo matching with the 2D Hopfield network of Achour & Mahiddine (2002).

The public face of the package. See ``docs/`` and ``README.md``.

The classes and functions below are imported with the package; its submodules
(:mod:`hopmatch.stereo`, :mod:`hopmatch.datasets`, :mod:`hopmatch.evaluate`,
:mod:`hopmatch.viz`, :mod:`hopmatch.compare`, :mod:`hopmatch.cli`, :mod:`hopmatch.imageio`)
are imported on first use (a module ``__getattr__``, PEP 562, as scikit-image does with
``lazy_loader``): ``import hopmatch`` then ``hopmatch.stereo.rectify(...)`` works, and the
import does not pay for modules a program never touches.

Examples
--------
>>> import hopmatch
>>> callable(hopmatch.stereo.rectify), hopmatch.datasets.MOTORCYCLE
(True, 'motorcycle')
>>> "viz" in dir(hopmatch)
True
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version

from . import errors
from ._threads import getNumThreads, setNumThreads
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
from .stereo_matcher import StereoHopfield

try:
    __version__ = version("hopmatch")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0"

#: Submodules imported on first attribute access (``hopmatch.stereo`` ...).
LAZY_SUBMODULES = ("cli", "compare", "datasets", "evaluate", "imageio", "stereo", "viz")

__all__ = [
    "DericheMoravecDetector",
    "HopfieldMatcher",
    "NetworkResult",
    "StereoHopfield",
    "StereoMatchResult",
    "hopfield_match",
    "match_stereo",
    "warmup",
    "deriche_gradient",
    "errors",
    "getNumThreads",
    "setNumThreads",
    "gradient_windows",
    "moravec_points",
    "moravec_response",
]


def __getattr__(name: str):
    """Import the submodule ``name`` of :data:`LAZY_SUBMODULES` on first access."""
    if name in LAZY_SUBMODULES:
        module = importlib.import_module(f"{__name__}.{name}")
        globals()[name] = module  # the import system set it too; later lookups skip this
        return module
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(LAZY_SUBMODULES))


def warmup(processes: int | None = None) -> float:
    """Compile every Numba kernel now (on tiny inputs) and return the seconds it took.

    With the on-disk cache warm (``cache=True``, the default) this only loads machine code.

    Parameters
    ----------
    processes : int, optional
        2 (or more): a second Python interpreter (``sys.executable``) compiles the
        detector's kernels and those of the steps after the network into the on-disk
        cache meanwhile, and this process loads them from it: Numba compiles one kernel
        at a time per process, so this is how a cold compile uses two cores (about 40 %
        less time on a 2-core machine; docs/performance.md, "The first run"). 1: this
        process only. None (default): 2 when hopmatch may use two or more threads
        (:func:`getNumThreads`), else 1. Without the on-disk cache, or with
        ``HOPMATCH_COMPILE_HELPER=0``, it compiles in this process alone.

    Examples
    --------
    >>> seconds = warmup()
    >>> seconds >= 0.0
    True
    """
    from ._params import integer
    from ._warmup import warmup as _warmup

    return _warmup(integer(1, 4096, optional=True)("processes", processes))
