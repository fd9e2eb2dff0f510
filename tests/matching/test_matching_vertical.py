"""The residual vertical-offset model: a robust plane recovers an injected rotation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hopmatch.matching.disambiguate import vertically_consistent
from hopmatch.matching.vertical import PLANE_MIN_MATCHES, RowOffset, fit_row_offset


def rotated_offsets(points, degrees, centre, shift=0.0):
    """``yl - yr`` when the right image is the left one rotated by ``degrees`` about
    ``centre`` and moved down by ``shift`` (right = R (left - centre) + centre)."""
    t = math.radians(degrees)
    x, y = points[:, 0] - centre[0], points[:, 1] - centre[1]
    yr = centre[1] + math.sin(t) * x + math.cos(t) * y + shift
    return points[:, 1] - yr


def test_plane_recovers_an_injected_rotation_despite_outliers():
    rng = np.random.default_rng(0)
    pts = np.c_[rng.uniform(0, 1200, 800), rng.uniform(0, 400, 800)]
    dy = rotated_offsets(pts, 0.2, (600, 200), shift=0.3) + rng.normal(0, 0.1, 800)
    bad = rng.random(800) < 0.2
    dy[bad] += rng.uniform(-6, 6, bad.sum())
    model = fit_row_offset(pts, dy)
    t = math.radians(0.2)
    assert model.b == pytest.approx(-math.sin(t), abs=2e-4)
    assert model.c == pytest.approx(1 - math.cos(t), abs=2e-4)
    truth = rotated_offsets(pts, 0.2, (600, 200), shift=0.3)
    assert np.abs(model.at(pts) - truth).max() < 0.05
    # the plane keeps the correct pairs at the sides that the median rejects
    plane = vertically_consistent(dy, 1.0, pts)
    median = vertically_consistent(dy, 1.0)
    assert plane[~bad].all() and not median[~bad].all()


def test_few_matches_give_the_median():
    pts = np.c_[np.arange(10.0), np.arange(10.0)]
    dy = np.linspace(-1, 1, 10) + 0.25
    assert PLANE_MIN_MATCHES > 10
    model = fit_row_offset(pts, dy)
    assert model == RowOffset(float(np.median(dy)))
    np.testing.assert_array_equal(vertically_consistent(dy, 1.0, pts),
                                  vertically_consistent(dy, 1.0))


def test_collinear_points_give_the_median():
    pts = np.c_[np.arange(100.0), np.zeros(100)]
    model = fit_row_offset(pts, np.full(100, 0.4))
    assert model.b == 0.0 and model.c == 0.0 and model.a == pytest.approx(0.4)
