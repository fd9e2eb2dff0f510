"""Helpers of the hopmatch.compare tests: a synthetic scene (the fixture ``tsukuba_rows`` is
in conftest.py)."""

from __future__ import annotations

import cv2
import numpy as np

from hopmatch import datasets


def synthetic_scene(disparity: int = 5, shape=(96, 128)) -> datasets.StereoScene:
    """A blurred random-texture pair with one disparity everywhere (right = left shifted)."""
    rng = np.random.default_rng(3)
    left = cv2.GaussianBlur((rng.random(shape) * 255).astype(np.uint8), (3, 3), 0)
    right = np.roll(left, -disparity, axis=1)
    disp = np.full(shape, float(disparity), np.float32)
    disp[:, :disparity] = np.nan  # no correspondent inside the right image
    return datasets.StereoScene("synthetic", left, right, disp, None, "")
