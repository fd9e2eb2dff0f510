"""The synthetic stereo rig of the hopmatch.stereo tests: two cameras with known K, R, T,
projection of 3-D points through them, and images of Gaussian blobs at sub-pixel points.

Imported by the test modules of this folder and by its conftest.py (pytest puts this
folder, which has no ``__init__.py``, on ``sys.path``).
"""

from __future__ import annotations

import cv2
import numpy as np

SIZE = (640, 480)  # (width, height)
K1 = np.array([[520.0, 0, 318.0], [0, 515.0, 242.0], [0, 0, 1]])
K2 = np.array([[510.0, 0, 325.0], [0, 512.0, 238.0], [0, 0, 1]])
R = cv2.Rodrigues(np.array([0.01, -0.02, 0.005]))[0]
T = np.array([-0.1, 0.003, -0.002])  # baseline ~0.1 m, right camera to the right
NO_DIST = np.zeros(5)


def relative_error(got, want):
    return np.linalg.norm(got - want, axis=1) / np.linalg.norm(want, axis=1)


def project(xyz, K, R_=np.eye(3), T_=np.zeros(3), D=NO_DIST):
    rvec = cv2.Rodrigues(R_)[0]
    pts, _ = cv2.projectPoints(xyz.reshape(-1, 1, 3), rvec, np.asarray(T_, float), K, D)
    return pts.reshape(-1, 2)


def render_blobs(points, shape, sigma=1.6, channels=0):
    """Gaussian blobs at sub-pixel (x, y), as uint8."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    img = np.zeros((h, w), np.float32)
    for x, y in points:
        x0, y0 = int(round(x)), int(round(y))
        sl = np.s_[max(y0 - 8, 0):y0 + 9, max(x0 - 8, 0):x0 + 9]
        img[sl] += 250 * np.exp(-((xx[sl] - x) ** 2 + (yy[sl] - y) ** 2) / (2 * sigma**2))
    img = np.clip(img, 0, 255).astype(np.uint8)
    return np.dstack([img] * channels) if channels else img


def centroids(img, points, r=4):
    out = []
    g = img.astype(np.float64) if img.ndim == 2 else img[..., 0].astype(np.float64)
    for x, y in points:
        x0, y0 = int(round(x)), int(round(y))
        win = g[y0 - r:y0 + r + 1, x0 - r:x0 + r + 1]
        yy, xx = np.mgrid[y0 - r:y0 + r + 1, x0 - r:x0 + r + 1]
        out.append([(win * xx).sum() / win.sum(), (win * yy).sum() / win.sum()])
    return np.array(out)
