"""Shared fixtures: the motorcycle pair and the location of ../shared/data."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("HOPMATCH_SHARED_DATA", ROOT.parent / "shared" / "data"))
NO_SHARED_DATA = (
    f"../shared/data is absent (looked in {SHARED_DATA}); these tests need the shared stereo "
    "data beside the project, or HOPMATCH_SHARED_DATA pointing at it"
)


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
