"""G-API operations of hopmatch: what each node takes and gives (no implementation here).

Points are ``GArray<Point2f>`` in (x, y), as everywhere in OpenCV; responses and
disparities are ``GArray<float>``. The implementations are in :mod:`hopmatch_gapi.kernels`.

Each operation's ``on`` checks its arguments (G-API's own check raises a bare
``Exception``): what is not the graph object it takes raises
:class:`~hopmatch.errors.InvalidTypeError` naming the argument, e.g. ``GMatch.on(1, 2)``:
"`left` of GMatch.on must be a cv2.GMat ...".
"""

from __future__ import annotations

import inspect

import cv2 as cv

from hopmatch.errors import InvalidTypeError

__all__ = ["GDetect", "GMatch", "GMatchPoints"]

#: What an ``on`` argument must be: ``(check, words for the message)``.
_GMAT = (lambda a: type(a) is cv.GMat, "a cv2.GMat (an image of a G-API graph, cv2.GMat())")
_POINTS = (lambda a: isinstance(a, cv.GArrayT) and a.type() == cv.gapi.CV_POINT2F,
           "a cv2.GArray of Point2f (cv2.GArray.Point2f(), GDetect.on(...)[0], "
           "cv2.gapi.goodFeaturesToTrack(...))")


def _what(value) -> str:
    if isinstance(value, cv.GArrayT):
        kinds = {getattr(cv.gapi, n): n for n in dir(cv.gapi) if n.startswith("CV_")}
        return f"a cv2.GArray of {kinds.get(value.type(), value.type())}"
    return f"{type(value).__name__} {value!r}"[:100]


def _checked_on(cls, *arguments):
    """Replace ``cls.on`` (set by ``cv.gapi.op``) by one that checks ``arguments``
    (``(name, (check, words))`` in order) and raises :class:`InvalidTypeError` naming the
    argument, then calls G-API's."""
    gapi_on = cls.on
    names = [name for name, _ in arguments]
    signature = inspect.Signature([inspect.Parameter(n, inspect.Parameter.POSITIONAL_OR_KEYWORD)
                                   for n in names])

    def on(*args, **kwargs):
        try:
            bound = signature.bind(*args, **kwargs)
        except TypeError as exc:
            raise InvalidTypeError(f"{cls.__name__}.on({', '.join(names)}): {exc}") from None
        for name, (check, words) in arguments:
            value = bound.arguments[name]
            if not check(value):
                raise InvalidTypeError(f"`{name}` of {cls.__name__}.on must be {words}, got "
                                       f"{_what(value)}", argument=name)
        return gapi_on(*(bound.arguments[n] for n in names))

    on.__signature__ = signature
    on.__name__, on.__qualname__ = "on", f"{cls.__name__}.on"
    on.__doc__ = (f"The outputs of a {cls.__name__} node on ``{', '.join(names)}`` (graph "
                  "objects); others raise InvalidTypeError naming the argument.")
    cls.on = staticmethod(on)
    return cls


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


_checked_on(GDetect, ("image", _GMAT))


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


_checked_on(GMatch, ("left", _GMAT), ("right", _GMAT))


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


_checked_on(GMatchPoints, ("left", _GMAT), ("left_points", _POINTS), ("right", _GMAT),
            ("right_points", _POINTS))
