"""G-API operations of hopmatch: what each node takes and gives (no implementation here).

Points are ``GArray<Point2f>`` in (x, y), as everywhere in OpenCV; responses and
disparities are ``GArray<float>``. The implementations are in :mod:`hopmatch_gapi.kernels`.
"""

from __future__ import annotations

import cv2 as cv

__all__ = ["GDetect", "GMatch", "GMatchPoints"]


@cv.gapi.op("hopmatch.detect", in_types=[cv.GMat],
            out_types=[cv.GArray.Point2f, cv.GArray.Float])
class GDetect:
    """``image -> (points, responses)``: Moravec points on the Canny-Deriche gradient.

    What :meth:`hopmatch.DericheMoravecDetector.detect_points` returns, as
    ``GArray<Point2f>`` (x, y) and ``GArray<float>`` (V of eq. 1).
    """

    @staticmethod
    def outMeta(image_desc):  # noqa: N802 (G-API name)
        return cv.empty_array_desc(), cv.empty_array_desc()


@cv.gapi.op("hopmatch.match", in_types=[cv.GMat, cv.GMat],
            out_types=[cv.GArray.Point2f, cv.GArray.Point2f, cv.GArray.Float])
class GMatch:
    """``(left, right) -> (matched left points, matched right points, disparities)``.

    :func:`hopmatch.match_stereo` on a rectified pair: ``res.matched_left``,
    ``res.matched_right``, ``res.disparities``.
    """

    @staticmethod
    def outMeta(left_desc, right_desc):  # noqa: N802
        return cv.empty_array_desc(), cv.empty_array_desc(), cv.empty_array_desc()


@cv.gapi.op("hopmatch.match_points",
            in_types=[cv.GMat, cv.GArray.Point2f, cv.GMat, cv.GArray.Point2f],
            out_types=[cv.GArray.Point2f, cv.GArray.Point2f, cv.GArray.Float])
class GMatchPoints:
    """``(left, left points, right, right points) -> (matched left, matched right, disparities)``.

    Describes the given points (eqs. 8-9; points whose descriptor window leaves the image
    are dropped) and matches them with the Hopfield network. Fed with :class:`GDetect`'s
    points it gives exactly what :class:`GMatch` gives; it also takes points from any other
    node, e.g. ``cv.gapi.goodFeaturesToTrack``.
    """

    @staticmethod
    def outMeta(left_desc, left_pts_desc, right_desc, right_pts_desc):  # noqa: N802
        return cv.empty_array_desc(), cv.empty_array_desc(), cv.empty_array_desc()
