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
