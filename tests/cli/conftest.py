"""Fixtures of the command-line tests."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from cli_helpers import DISPARITY


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """A random-texture rectified pair with disparity 6 everywhere, as PNG files."""
    folder = tmp_path_factory.mktemp("pair")
    rng = np.random.default_rng(1)
    left = (rng.random((120, 160)) * 255).astype(np.uint8)
    right = np.roll(left, -DISPARITY, axis=1)
    paths = {"left": folder / "left.png", "right": folder / "right.png",
             "short": folder / "short.png", "garbage": folder / "garbage.png",
             "truncated": folder / "truncated.png", "empty": folder / "empty.png",
             "folder": folder / "a_folder.png"}
    assert cv2.imwrite(str(paths["left"]), left)
    assert cv2.imwrite(str(paths["right"]), right)
    assert cv2.imwrite(str(paths["short"]), right[:100])
    paths["garbage"].write_bytes(b"this is not an image at all")
    data = paths["left"].read_bytes()
    paths["truncated"].write_bytes(data[: len(data) // 2])
    paths["empty"].write_bytes(b"")
    paths["folder"].mkdir()
    return paths


@pytest.fixture(scope="module")
def unrectified(tmp_path_factory):
    """The random-texture pair with the right image also shifted down by 8 rows, and the
    fundamental matrix of that shift (y_right = y_left + 8) as a text file:
    (left, right, F file)."""
    folder = tmp_path_factory.mktemp("unrectified")
    rng = np.random.default_rng(1)
    left = (rng.random((120, 160)) * 255).astype(np.uint8)
    right = np.roll(np.roll(left, -DISPARITY, axis=1), 8, axis=0)
    paths = (folder / "left.png", folder / "right.png", folder / "F.txt")
    assert cv2.imwrite(str(paths[0]), left) and cv2.imwrite(str(paths[1]), right)
    np.savetxt(paths[2], [[0, 0, 0], [0, 0, 1], [0, -1, -8]])
    return paths
