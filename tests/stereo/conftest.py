"""Fixtures of the hopmatch.stereo tests: scenes of 3-D points and the rig's calibration."""

from __future__ import annotations

import numpy as np
import pytest
from stereo_rig import K1, K2, NO_DIST, SIZE, R, T

from hopmatch.stereo import StereoCalibration


@pytest.fixture
def scene():
    """60 random 3-D points in front of both cameras, in the left camera's frame."""
    rng = np.random.default_rng(7)
    n = 60
    xyz = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(-0.7, 0.7, n), rng.uniform(2, 6, n)])
    return xyz


@pytest.fixture
def calibration():
    return StereoCalibration(K1, NO_DIST, K2, NO_DIST, R, T, image_size=SIZE)


@pytest.fixture
def blob_scene():
    gx, gy = np.meshgrid(np.linspace(-0.5, 0.5, 5), np.linspace(-0.35, 0.35, 4))
    z = 3.0 + 0.5 * gx  # a slanted plane of dots
    return np.column_stack([gx.ravel() * z.ravel() / 3, gy.ravel() * z.ravel() / 3, z.ravel()])
