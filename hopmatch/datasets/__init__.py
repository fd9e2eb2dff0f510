"""Stereo scenes with ground truth: file readers and a small scene catalogue.

Every reader returns arrays in hopmatch's conventions:

* images as ``cv2.imread`` gives them: uint8, grey ``(H, W)`` or BGR ``(H, W, 3)``;
* disparity as a float32 ``(H, W)`` array **in pixels, for the left image**, with
  ``NaN`` where there is no ground truth (``np.isnan(scene.disparity)`` is the unknown
  mask). The left pixel ``(x, y)`` corresponds to the right pixel ``(x - d, y)``; the
  tests check it on every shared scene by warping the right image into the left view.

A scene is a :class:`StereoScene`. :func:`load` gives one by name: ``"motorcycle"`` is
built in (from scikit-image) and always available; the others (``"middlebury/tsukuba"``,
``"aloe"``, ``"kitti2012/000070"``, ...) are folders with a ``meta.json`` under the shared
data directory (:func:`shared_data_dir`). :func:`list_scenes` lists them.

The readers raise :class:`hopmatch.errors.InvalidArgumentError` (a ``ValueError``) naming
the file and what was expected when a file is missing or malformed.

The package has three modules: :mod:`hopmatch.datasets.readers` (images, disparity maps
and masks), :mod:`hopmatch.datasets.calibration` (``calib.txt`` files) and
:mod:`hopmatch.datasets.catalogue` (the scene record and the catalogue); every name is
importable from ``hopmatch.datasets`` itself.

References
----------
.. [1] D. Scharstein, R. Szeliski. A taxonomy and evaluation of dense two-frame stereo
       correspondence algorithms. IJCV 47(1/2/3):7-42, 2002.
.. [2] D. Scharstein et al. High-resolution stereo datasets with subpixel-accurate ground
       truth. GCPR 2014. (Middlebury 2014, PFM and ``calib.txt`` formats.)
.. [3] A. Geiger, P. Lenz, R. Urtasun. Are we ready for autonomous driving? The KITTI vision
       benchmark suite. CVPR 2012.

Examples
--------
>>> from hopmatch import datasets
>>> scene = datasets.load("motorcycle")
>>> scene.image_size, scene.left.dtype, bool(scene.valid.any())
((741, 500), dtype('uint8'), True)
"""

from __future__ import annotations

from .calibration import read_kitti_calib, read_middlebury_calib
from .catalogue import (
    MOTORCYCLE,
    SHARED_DATA_ENV,
    StereoScene,
    list_scenes,
    load,
    load_motorcycle,
    load_scene,
    shared_data_dir,
)
from .readers import (
    read_kitti_disparity,
    read_middlebury_disparity,
    read_pfm,
)

__all__ = [
    "MOTORCYCLE",
    "SHARED_DATA_ENV",
    "StereoScene",
    "list_scenes",
    "load",
    "load_motorcycle",
    "load_scene",
    "read_kitti_calib",
    "read_kitti_disparity",
    "read_middlebury_calib",
    "read_middlebury_disparity",
    "read_pfm",
    "shared_data_dir",
]
