"""Files and checks shared by the tests of hopmatch.datasets: calibration texts as the
datasets ship them, a PFM writer, a tiny scene folder, and the photometric check of a
scene's ground truth. (Imported by the test modules beside it, whose folder pytest puts on
``sys.path``.)"""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np

from hopmatch.datasets import StereoScene

KITTI_CALIB = """\
P0: 7.188560e+02 0.000000e+00 6.071928e+02 0.000000e+00 0.000000e+00 7.188560e+02 1.852157e+02 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
P1: 7.188560e+02 0.000000e+00 6.071928e+02 -3.861448e+02 0.000000e+00 7.188560e+02 1.852157e+02 0.000000e+00 0.000000e+00 0.000000e+00 1.000000e+00 0.000000e+00
P2: 7.188560e+02 0.000000e+00 6.071928e+02 4.538225e+01 0.000000e+00 7.188560e+02 1.852157e+02 -1.130887e-01 0.000000e+00 0.000000e+00 1.000000e+00 3.779761e-03
P3: 7.188560e+02 0.000000e+00 6.071928e+02 -3.372877e+02 0.000000e+00 7.188560e+02 1.852157e+02 2.369057e+00 0.000000e+00 0.000000e+00 1.000000e+00 4.915215e-03
"""

MIDDLEBURY_CALIB = """\
cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 1]
cam1=[3997.684 0 1307.839; 0 3997.684 1011.728; 0 0 1]
doffs=131.111
baseline=193.001
width=2964
height=1988
ndisp=280
isint=0
vmin=31
vmax=257
dyavg=0.918
dymax=1.516
"""


def write_pfm(path: Path, top_to_bottom: np.ndarray, byteorder: str, scale: float = 1.0):
    """Write a PFM the way Middlebury does: rows bottom to top, sign of scale = endianness."""
    arr = np.asarray(top_to_bottom, dtype=np.float32)
    magic = b"PF" if arr.ndim == 3 else b"Pf"
    h, w = arr.shape[:2]
    signed = -abs(scale) if byteorder == "<" else abs(scale)
    data = arr[::-1].astype(byteorder + "f4").tobytes()
    path.write_bytes(magic + b"\n" + f"{w} {h}\n{signed}\n".encode() + data)
    return path


def grey(img):
    return cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img


def photometric_error(scene: StereoScene, sign: int) -> float:
    """Mean |left - right warped with xr = xl + sign * d| over pixels with ground truth."""
    left = grey(scene.left).astype(np.float32)
    right = grey(scene.right).astype(np.float32)
    h, w = scene.shape
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    d = np.nan_to_num(scene.disparity, nan=0.0)
    map_x = xs + sign * d
    warped = cv2.remap(right, map_x, ys, cv2.INTER_LINEAR)
    ok = scene.valid & (map_x >= 0) & (map_x <= w - 1)
    return float(np.abs(warped - left)[ok].mean())


def make_scene(folder: Path, **meta_overrides) -> Path:
    """A 6x10 scene: right = left shifted by 2 px, disparity 2 (stored 4 at scale 2)."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    left = rng.integers(0, 255, (6, 10, 3), dtype=np.uint8)
    right = np.roll(left, -2, axis=1)
    disp = np.full((6, 10), 4, np.uint8)
    disp[:, :2] = 0
    cv2.imwrite(str(folder / "left.png"), left)
    cv2.imwrite(str(folder / "right.png"), right)
    cv2.imwrite(str(folder / "disp_left.pgm"), disp)
    cv2.imwrite(str(folder / "disp_right.pgm"), disp)
    cv2.imwrite(str(folder / "mask.png"), np.where(disp > 0, 255, 0).astype(np.uint8))
    meta = {
        "left": "left.png",
        "right": "right.png",
        "disp": "disp_left.pgm",
        "scale": 2,
        "unknown_value": 0,
        "dataset": "tiny",
        "cite": "nobody, 2024",
    }
    meta.update(meta_overrides)
    meta = {k: v for k, v in meta.items() if v is not None}
    (folder / "meta.json").write_text(json.dumps(meta))
    return folder
