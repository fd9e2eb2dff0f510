"""Synthetic textures and a layered stereo pair with a depth edge, shared by the matching
tests (tests/matching/)."""

from __future__ import annotations

import cv2
import numpy as np


def texture(h, w, seed=0, sigma=1.2):
    """A smooth random texture: Gaussian noise blurred by ``sigma``, float64 in 20..220."""
    rng = np.random.default_rng(seed)
    t = cv2.GaussianBlur(rng.normal(size=(h, w)), (0, 0), sigma)
    return (t - t.min()) / (t.max() - t.min()) * 200 + 20


def occlusion_pair(seed, noise=10.0, d_bg=4, d_fg=16):
    """A textured rectangle (rows 60-140, columns 80-200 of the 200x300 left image) at
    disparity ``d_fg`` in front of a textured background at ``d_bg`` (the background it
    hides in the right image has no match), Gaussian noise of standard deviation ``noise``
    on the right image; ``(left, right, ground truth)``, the images uint8."""
    h, w = 200, 300
    bg = texture(h, w + 40, seed).astype(np.float32)
    fg = texture(h, w + 40, seed + 7).astype(np.float32)
    y0, y1, x0, x1 = 60, 140, 80, 200
    left = bg[:, d_bg:d_bg + w].copy()
    right = bg[:, :w].copy()
    gt = np.full((h, w), float(d_bg))
    left[y0:y1, x0:x1] = fg[y0:y1, x0:x1]
    right[y0:y1, x0 - d_fg:x1 - d_fg] = fg[y0:y1, x0:x1]
    gt[y0:y1, x0:x1] = d_fg
    right = right + np.random.default_rng(seed + 100).normal(0, noise, right.shape)
    return (np.clip(left, 0, 255).astype(np.uint8), np.clip(right, 0, 255).astype(np.uint8),
            gt)
