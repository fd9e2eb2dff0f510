"""Shared fixtures: the motorcycle pair and the location of ../shared/data."""

from __future__ import annotations

from pathlib import Path

import pytest
from shared_data import NO_SHARED_DATA, SHARED_DATA


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip(NO_SHARED_DATA)
    return SHARED_DATA


@pytest.fixture(scope="session")
def motorcycle():
    """scikit-image's Middlebury 2014 motorcycle pair: (left RGB, right RGB, disparity)."""
    from skimage.data import stereo_motorcycle

    return stereo_motorcycle()
