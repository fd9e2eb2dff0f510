"""hopmatch_gapi: hopmatch's detector and matcher as OpenCV G-API operations.

- :class:`GDetect`: ``GMat -> (GArray<Point2f>, GArray<float>)`` (points, responses);
- :class:`GMatch`: ``(GMat, GMat) -> (GArray<Point2f>, GArray<Point2f>, GArray<float>)``
  (matched left points, matched right points, disparities);
- :class:`GMatchPoints`: ``(GMat, GArray<Point2f>, GMat, GArray<Point2f>) -> (same)``;
- :func:`kernels` ``(**params)``: their kernel package; :func:`stereo_graph`: the ready
  ``GComputation``; :func:`match_pair`: compile once, apply.

Needs OpenCV's Python G-API custom operations (``cv2.gapi.op``/``cv2.gapi.kernel``): the
OpenCV 4.x wheels have them, the 5.0 wheels do not; on those, importing this package raises
``ImportError`` saying what to install. See ``docs/gapi.md``.

Examples
--------
>>> import numpy as np, cv2 as cv, hopmatch_gapi
>>> rng = np.random.default_rng(1)
>>> left = (rng.random((120, 160)) * 255).astype(np.uint8)
>>> right = np.roll(left, -6, axis=1)
>>> ml, mr, d = hopmatch_gapi.match_pair(left, right, max_disparity=12)
>>> round(float(np.median(d)), 1)
6.0
"""

from __future__ import annotations

from ._compat import require_gapi

require_gapi()

from .graph import as_arrays, match_pair, stereo_graph  # noqa: E402
from .kernels import kernels  # noqa: E402
from .ops import GDetect, GMatch, GMatchPoints  # noqa: E402

__all__ = ["GDetect", "GMatch", "GMatchPoints", "as_arrays", "kernels", "match_pair",
           "stereo_graph"]
