"""Fixtures of the hopmatch.compare tests."""

from __future__ import annotations

import pytest

from hopmatch import compare, datasets


@pytest.fixture(scope="session")
def tsukuba_rows(shared_data):
    """(scene, rows of hopmatch, sift-ratio-band and sgbm) on middlebury/tsukuba, once."""
    scene = datasets.load("middlebury/tsukuba", root=shared_data)
    rows = compare.compare([scene], ["hopmatch", "sift-ratio-band", "sgbm"])
    return scene, rows
