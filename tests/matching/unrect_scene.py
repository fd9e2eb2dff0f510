"""A synthetic unrectified pair with a known fundamental matrix, for the tests of this
folder: two textured planes (a background and a nearer square) seen by a verged rig with
known K, R, T, rendered by the planes' homographies; and similarity perturbations of a
rectified pair (what the held-out perturbed scenes are).

Imported by the test modules of this folder (pytest puts this folder, which has no
``__init__.py``, on ``sys.path``).
"""

from __future__ import annotations

import cv2
import numpy as np

SIZE = (480, 360)  # (width, height)
K1 = np.array([[420.0, 0, 236.0], [0, 418.0, 182.0], [0, 0, 1]])
K2 = np.array([[415.0, 0, 243.0], [0, 416.0, 177.0], [0, 0, 1]])
R = cv2.Rodrigues(np.array([0.015, -0.05, 0.03]))[0]   # verged and rolled
T = np.array([-0.12, 0.004, 0.01])
#: (depth, half side in metres) of the background plane and of the nearer square.
PLANES = ((2.0, 2.0), (1.1, 0.25))
TEXELS = 2.0e-3  # metres per texture pixel


def fundamental(K1_=K1, K2_=K2, R_=R, T_=T) -> np.ndarray:
    """``F = K2^-T [T]x R K1^-1`` (``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``), unit norm."""
    tx = np.array([[0, -T_[2], T_[1]], [T_[2], 0, -T_[0]], [-T_[1], T_[0], 0]])
    f = np.linalg.inv(K2_).T @ tx @ R_ @ np.linalg.inv(K1_)
    return f / np.linalg.norm(f)


def texture(rng, side: int) -> np.ndarray:
    """Smoothed noise, uint8, ``side`` x ``side``: corners for Moravec and blobs for SIFT."""
    noise = rng.random((side, side)).astype(np.float32)
    img = cv2.GaussianBlur(noise, (0, 0), 2.0)
    img = (img - img.min()) / (img.max() - img.min())
    return (img * 255).astype(np.uint8)


def plane_homography(K, R_, T_, depth, half):
    """Texture pixels ``(s, t)`` of the plane ``Z = depth`` (centred, ``half`` metres) to
    image pixels of the camera ``K [R | T]``."""
    side = int(round(2 * half / TEXELS))
    to_plane = np.array([[TEXELS, 0, -half], [0, TEXELS, -half], [0, 0, 1.0]])
    H = K @ np.c_[R_[:, 0], R_[:, 1], R_[:, 2] * depth + T_]
    return H @ to_plane, side


def render_pair(seed: int = 0):
    """``(left, right, F)``: the two planes through both cameras (uint8 grey)."""
    rng = np.random.default_rng(seed)
    images = []
    textures = [texture(rng, int(round(2 * half / TEXELS))) for _, half in PLANES]
    for K, R_, T_ in ((K1, np.eye(3), np.zeros(3)), (K2, R, T)):
        out = np.zeros(SIZE[::-1], np.uint8)
        for (depth, half), tex in zip(PLANES, textures):
            H, side = plane_homography(K, R_, T_, depth, half)
            warped = cv2.warpPerspective(tex, H, SIZE, flags=cv2.INTER_LINEAR)
            inside = cv2.warpPerspective(np.full(tex.shape, 255, np.uint8), H, SIZE,
                                         flags=cv2.INTER_NEAREST) > 0
            out[inside] = warped[inside]
        images.append(out)
    return images[0], images[1], fundamental()


def plane_correspondences(n: int = 400, seed: int = 1):
    """``(left, right)`` projections of ``n`` random points of the two planes that both
    cameras see in front of the nearer plane (the square occludes the background)."""
    rng = np.random.default_rng(seed)
    pts = []
    for depth, half in PLANES:
        uv = rng.uniform(-half, half, (n, 2))
        pts.append(np.c_[uv, np.full(n, depth)])
    xyz = np.concatenate(pts)
    near_depth, near_half = PLANES[1]
    out = []
    for K, R_, T_ in ((K1, np.eye(3), np.zeros(3)), (K2, R, T)):
        cam = xyz @ R_.T + T_
        p = cam @ K.T
        out.append(p[:, :2] / p[:, 2:])
    left, right = out
    w, h = SIZE
    inside = ((left >= 10) & (left < [w - 10, h - 10]) & (right >= 10)
              & (right < [w - 10, h - 10])).all(axis=1)
    # a background point is hidden when the square covers it in either view
    square = []
    for K, R_, T_ in ((K1, np.eye(3), np.zeros(3)), (K2, R, T)):
        H, _ = plane_homography(K, R_, T_, near_depth, near_half)
        corners = np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1.0]])
        corners[:, :2] *= 2 * near_half / TEXELS
        c = corners @ H.T
        square.append(c[:, :2] / c[:, 2:])
    hidden = np.zeros(len(xyz), bool)
    for view, poly in zip((left, right), square):
        path = poly.astype(np.float32).reshape(-1, 1, 2)
        hidden |= np.array([cv2.pointPolygonTest(path, (float(x), float(y)), True) > -3
                            for x, y in view])
    hidden[len(xyz) // 2:] = False  # the square itself is never hidden
    keep = inside & ~hidden
    return left[keep], right[keep]


def perturbation(size, angle, dy, scale) -> np.ndarray:
    """The 2 x 3 map of the right image: rotation about the centre, scale, vertical shift."""
    w, h = size
    A = cv2.getRotationMatrix2D(((w - 1) / 2, (h - 1) / 2), angle, scale)
    A[1, 2] += dy
    return A


def perturbed_truth(left_pts, disparity, A):
    """``(true right points, known)`` of left points of a rectified pair whose right image
    was warped by ``A``: ``A (xl - d, yl)``."""
    h, w = disparity.shape
    xi = np.clip(np.floor(left_pts[:, 0] + 0.5).astype(int), 0, w - 1)
    yi = np.clip(np.floor(left_pts[:, 1] + 0.5).astype(int), 0, h - 1)
    d = disparity[yi, xi]
    t = np.c_[left_pts[:, 0] - d, left_pts[:, 1], np.ones(len(left_pts))] @ A.T
    known = np.isfinite(d) & (t[:, 0] >= 0) & (t[:, 0] <= w - 1) & (t[:, 1] >= 0) & (
        t[:, 1] <= h - 1)
    return t[:, :2], known
