"""Whether ``match_stereo(left, right)`` (``rectified=None``) keeps its second try of a pair
as an unrectified one: a pair whose matches along its rows are few
(:func:`~hopmatch.matching.diagnostics.still_few`) is matched again as ``rectified=False``
does (:mod:`hopmatch.matching.unrectified`), and that match replaces the rows' when it
found a geometry of two views side by side and more matches (docs/robustness.md,
"Rectification check")."""

from __future__ import annotations

from .._warnings import deferred_warnings
from ..errors import BudgetExceededError
from .geometry import alignment_turn

#: ``match_stereo(rectified=None)``: a pair whose matches along its rows are few
#: (:func:`~.diagnostics.still_few`) is matched as an unrectified pair too, and that match
#: is kept when it found a geometry and more than this many times as many matches.
UNRECTIFIED_FALLBACK_GAIN = 2.0
#: ... and when the similarity that lines up its rows turns the right image by at most
#: this many degrees and scales it by at most :data:`UNRECTIFIED_FALLBACK_SCALE` (or its
#: inverse): two views side by side, not an object seen in another scene.
UNRECTIFIED_FALLBACK_TURN = 15.0
UNRECTIFIED_FALLBACK_SCALE = 1.25


def fallback_kept(kept_on_rows: int, other) -> bool:
    """Whether ``match_stereo`` (``rectified=None``) keeps ``other`` (a StereoMatchResult),
    the match of a pair as an unrectified one, over the ``kept_on_rows`` matches along its
    rows: it found a geometry, more than :data:`UNRECTIFIED_FALLBACK_GAIN` times as many
    matches, and a pair side by side (:data:`UNRECTIFIED_FALLBACK_TURN`,
    :data:`UNRECTIFIED_FALLBACK_SCALE`)."""
    if other.fundamental_matrix is None or other.geometry is None:
        return False
    if len(other.query_idx) <= UNRECTIFIED_FALLBACK_GAIN * max(kept_on_rows, 1):
        return False
    degrees, scale = alignment_turn(other.geometry)
    return (abs(degrees) <= UNRECTIFIED_FALLBACK_TURN
            and 1 / UNRECTIFIED_FALLBACK_SCALE <= scale <= UNRECTIFIED_FALLBACK_SCALE)


def fallback_if_kept(kept_on_rows: int, match_unrectified):
    """``(result, warnings)`` of ``match_unrectified()`` (the pair matched as an
    unrectified one, a second try after ``kept_on_rows`` matches along its rows) when
    :func:`fallback_kept` keeps it, its warnings (callables of no argument) held back until
    then; else None, and its warnings dropped with it. A second try that exceeds a budget
    (:class:`~hopmatch.errors.BudgetExceededError`) leaves the match along the rows
    standing: None."""
    with deferred_warnings() as pending:
        try:
            other = match_unrectified()
        except BudgetExceededError:
            return None
    return (other, pending) if fallback_kept(kept_on_rows, other) else None
