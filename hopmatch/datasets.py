"""Stereo scenes with ground truth: file readers and a small scene catalogue.

Every reader returns arrays in hopmatch's conventions:

* images as ``cv2.imread`` gives them: uint8, grey ``(H, W)`` or BGR ``(H, W, 3)``;
* disparity as a float32 ``(H, W)`` array **in pixels, for the left image**, with
  ``NaN`` where there is no ground truth (``np.isnan(scene.disparity)`` is the unknown
  mask). The left pixel ``(x, y)`` corresponds to the right pixel ``(x - d, y)``;
  this was checked on every bundled scene by warping the right image into the left view.

A scene is a :class:`StereoScene`. :func:`load` gives one by name: ``"motorcycle"`` is
built in (from scikit-image) and always available; the others (``"middlebury/tsukuba"``,
``"aloe"``, ``"kitti2012/000070"``, ...) are folders with a ``meta.json`` under the shared
data directory (:func:`shared_data_dir`). :func:`list_scenes` lists them.

The readers raise :class:`hopmatch.errors.InvalidArgumentError` (a ``ValueError``) naming
the file and what was expected when a file is missing or malformed.

References
----------
.. [1] D. Scharstein, R. Szeliski. A taxonomy and evaluation of dense two-frame stereo
       correspondence algorithms. IJCV 47(1/2/3):7-42, 2002.
.. [2] D. Scharstein et al. High-resolution stereo datasets with subpixel-accurate ground
       truth. GCPR 2014. (Middlebury 2014, PFM and ``calib.txt`` formats.)
.. [3] A. Geiger, P. Lenz, R. Urtasun. Are we ready for autonomous driving? The KITTI vision
       benchmark suite. CVPR 2012.
"""

from __future__ import annotations

import json
import math
import numbers
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from ._validate import as_real
from .errors import InvalidArgumentError, InvalidTypeError

__all__ = [
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

#: Environment variable that overrides where the shared stereo data is looked for.
SHARED_DATA_ENV = "HOPMATCH_SHARED_DATA"

#: Name of the built-in scene (scikit-image's Middlebury 2014 motorcycle, quarter size).
MOTORCYCLE = "motorcycle"

_MOTORCYCLE_CITE = (
    "D. Scharstein, H. Hirschmueller, Y. Kitajima, G. Krathwohl, N. Nesic, X. Wang, "
    "P. Westling. High-resolution stereo datasets with subpixel-accurate ground truth. "
    "GCPR 2014. (Middlebury 2014 Motorcycle, down-sampled 4x, as shipped by scikit-image.)"
)


# --------------------------------------------------------------------------------------
# The scene record
# --------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class StereoScene:
    """A rectified stereo pair with ground-truth disparity for the left image.

    Attributes
    ----------
    name : str
        Catalogue name, e.g. ``"middlebury/tsukuba"`` or ``"motorcycle"``.
    left, right : (H, W) or (H, W, 3) uint8 ndarray
        The images as ``cv2.imread`` loads them: grey, or colour in **BGR** order.
    disparity : (H, W) float32 ndarray
        Ground-truth disparity of the left image, in pixels. ``NaN`` means unknown (no
        ground truth, e.g. occluded or unmeasured). The left pixel ``(x, y)`` shows the
        same scene point as the right pixel ``(x - disparity[y, x], y)``.
    calibration : dict or None
        Camera parameters when the dataset gives them (see :func:`read_middlebury_calib`,
        :func:`read_kitti_calib`), else None.
    source : str
        The citation the dataset's authors ask for.
    dataset : str
        A short description of the dataset and image size.
    disparity_right : (H, W) float32 ndarray or None
        Ground truth for the right image (right ``(x, y)`` matches left ``(x + d, y)``),
        when shipped; NaN = unknown.
    disparity_all : (H, W) float32 ndarray or None
        KITTI only: ground truth including occluded pixels (``disp_occ``); ``disparity``
        then holds the non-occluded one (``disp_noc``).
    nonoccluded_mask : (H, W) bool ndarray or None
        True where the left pixel is visible in the right image, when shipped.
    folder : pathlib.Path or None
        Where the scene was read from (None for built-in scenes).
    meta : dict
        The scene's ``meta.json`` as read, plus ``dmin`` from ``dmin.txt`` when present
        (Middlebury 2005: full-size disparity offset, needed for depth only).
    """

    name: str
    left: np.ndarray
    right: np.ndarray
    disparity: np.ndarray
    calibration: dict | None
    source: str
    dataset: str = ""
    disparity_right: np.ndarray | None = None
    disparity_all: np.ndarray | None = None
    nonoccluded_mask: np.ndarray | None = None
    folder: Path | None = None
    meta: dict = field(default_factory=dict)

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)``, the image height and width."""
        return tuple(self.disparity.shape)

    @property
    def image_size(self) -> tuple[int, int]:
        """``(width, height)``, in cv2's order."""
        return (self.disparity.shape[1], self.disparity.shape[0])

    @property
    def valid(self) -> np.ndarray:
        """(H, W) bool ndarray: True where the left image has ground truth."""
        return np.isfinite(self.disparity)

    def __repr__(self) -> str:
        d = self.disparity[np.isfinite(self.disparity)]
        rng = f"{d.min():.3g}..{d.max():.3g} px" if d.size else "none"
        return (
            f"StereoScene(name={self.name!r}, size={self.image_size}, "
            f"left={self.left.dtype}{self.left.shape}, disparity={rng}, "
            f"known={d.size / max(self.disparity.size, 1):.0%}, "
            f"calibration={'yes' if self.calibration else 'no'})"
        )


# --------------------------------------------------------------------------------------
# Small private helpers
# --------------------------------------------------------------------------------------


def _as_path(path, name: str = "path") -> Path:
    if isinstance(path, Path):
        return path
    if isinstance(path, (str, os.PathLike)):
        return Path(path)
    raise InvalidTypeError(
        f"`{name}` must be a str or pathlib.Path, got {type(path).__name__} {path!r}"[:200]
    )


def _existing_file(path, what: str) -> Path:
    p = _as_path(path)
    if not p.exists():
        raise InvalidArgumentError(f"{what} file {str(p)!r} does not exist")
    if not p.is_file():
        raise InvalidArgumentError(f"{what} path {str(p)!r} is not a file")
    return p


def _imread(path, flags: int, what: str) -> np.ndarray:
    p = _existing_file(path, what)
    # np.fromfile + imdecode: no silent None for non-ASCII paths, and no stderr noise.
    data = np.fromfile(str(p), dtype=np.uint8)
    try:
        img = cv2.imdecode(data, flags) if data.size else None
    except cv2.error:
        img = None
    if img is None:
        raise InvalidArgumentError(
            f"{what} file {str(p)!r} could not be decoded as an image "
            "(expected a PNG, PGM/PPM or JPEG file)"
        )
    return img


def _read_image(path, what: str) -> np.ndarray:
    """An 8-bit image as cv2.imread would give it, but grey files stay (H, W)."""
    img = _imread(path, cv2.IMREAD_ANYCOLOR, what)
    if img.ndim == 3 and img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2BGR)
    return np.ascontiguousarray(img)


def _single_channel(img: np.ndarray, path, what: str) -> np.ndarray:
    """Reduce a map stored as identical colour channels to (H, W); refuse real colour."""
    if img.ndim == 3:
        if img.shape[2] == 1 or all(
            np.array_equal(img[:, :, 0], img[:, :, c]) for c in range(1, min(img.shape[2], 3))
        ):
            return img[:, :, 0]
        raise InvalidArgumentError(
            f"{what} file {str(path)!r} must be a single-channel (grey) image, "
            f"got {img.shape[2]} channels with different values"
        )
    return img


def _to_disparity(raw: np.ndarray, scale: float, unknown_value) -> np.ndarray:
    disp = raw.astype(np.float32) / np.float32(scale)
    if unknown_value is not None:
        disp[raw == unknown_value] = np.nan
    disp[~np.isfinite(disp)] = np.nan
    return np.ascontiguousarray(disp, dtype=np.float32)


# --------------------------------------------------------------------------------------
# Disparity readers
# --------------------------------------------------------------------------------------


def read_middlebury_disparity(path, scale, unknown_value=0) -> np.ndarray:
    """Read a Middlebury 2001-2006 disparity map (8- or 16-bit PNG/PGM).

    ``disparity = stored value / scale``; pixels holding ``unknown_value`` become NaN.

    Parameters
    ----------
    path : str or pathlib.Path
        A single-channel PNG or PGM file (a grey map saved as 3 equal channels is
        accepted).
    scale : float
        Stored value per pixel of disparity: 8 for the 2001 scenes (16 for Tsukuba in
        the v2 evaluation form), 1 for full-size 2005/2006 scenes, 2 for half size, ...
    unknown_value : int or None
        Stored value that means "no ground truth" (0 in every Middlebury set); None
        when every pixel is known.

    Returns
    -------
    disparity : (H, W) float32 ndarray
        In pixels, for the left image; NaN = unknown.

    Raises
    ------
    InvalidArgumentError
        The file is missing, cannot be decoded, or holds colour.

    Examples
    --------
    >>> import tempfile, os, cv2, numpy as np
    >>> path = os.path.join(tempfile.mkdtemp(), "disp.png")
    >>> _ = cv2.imwrite(path, np.array([[0, 8], [16, 20]], np.uint8))
    >>> read_middlebury_disparity(path, scale=8)
    array([[nan, 1. ],
           [2. , 2.5]], dtype=float32)
    """
    scale = as_real(scale, "scale", lo=0.0, lo_open=True)
    if unknown_value is not None and (
        isinstance(unknown_value, bool) or not isinstance(unknown_value, numbers.Real)
    ):
        raise InvalidTypeError(f"`unknown_value` must be a number or None, got {unknown_value!r}")
    raw = _imread(path, cv2.IMREAD_UNCHANGED, "Middlebury disparity")
    raw = _single_channel(raw, path, "Middlebury disparity")
    if raw.dtype not in (np.uint8, np.uint16):
        raise InvalidArgumentError(
            f"Middlebury disparity file {str(path)!r} must hold 8- or 16-bit integers, "
            f"got {raw.dtype}"
        )
    return _to_disparity(raw, scale, unknown_value)


_PFM_HEADER = re.compile(rb"\A(P[Ff])\s+(\d+)\s+(\d+)\s+([-+]?[0-9.]+(?:[eE][-+]?\d+)?)\s")


def read_pfm(path) -> np.ndarray:
    """Read a PFM file (Middlebury 2014 / MiddEval3 ``disp0.pfm``, ``disp0GT.pfm``).

    The header is ``Pf`` (grey) or ``PF`` (colour), then ``width height``, then a scale
    whose sign gives the byte order (negative: little-endian, positive: big-endian); its
    magnitude is not applied. Rows are stored bottom to top and are flipped here, so
    row 0 is the top of the image. Infinite values (Middlebury's "unknown") become NaN.

    Parameters
    ----------
    path : str or pathlib.Path
        The PFM file.

    Returns
    -------
    data : (H, W) or (H, W, 3) float32 ndarray
        Native byte order. Colour files keep the file's channel order (R, G, B); use
        ``data[..., ::-1]`` for cv2's BGR.

    Raises
    ------
    InvalidArgumentError
        Missing file, bad header, or fewer data bytes than the header announces.

    Examples
    --------
    >>> import tempfile, os, numpy as np
    >>> path = os.path.join(tempfile.mkdtemp(), "d.pfm")
    >>> rows = np.array([[3, np.inf], [1, 2]], "<f4")  # bottom row first in the file
    >>> with open(path, "wb") as f:
    ...     _ = f.write(b"Pf\\n2 2\\n-1.0\\n" + rows.tobytes())
    >>> read_pfm(path)
    array([[ 1.,  2.],
           [ 3., nan]], dtype=float32)
    """
    p = _existing_file(path, "PFM")
    blob = p.read_bytes()
    m = _PFM_HEADER.match(blob)
    if m is None:
        raise InvalidArgumentError(
            f"PFM file {str(p)!r} has no valid header: expected 'PF' or 'Pf', then "
            f"'width height', then a non-zero scale (got {blob[:32]!r})"
        )
    kind, width, height, scale = m.group(1), int(m.group(2)), int(m.group(3)), float(m.group(4))
    if width <= 0 or height <= 0:
        raise InvalidArgumentError(
            f"PFM file {str(p)!r} announces a size of {width}x{height}; both must be positive"
        )
    if scale == 0 or not math.isfinite(scale):
        raise InvalidArgumentError(
            f"PFM file {str(p)!r} has scale {scale}; expected a non-zero number whose sign "
            "gives the byte order (negative: little-endian)"
        )
    channels = 3 if kind == b"PF" else 1
    dtype = np.dtype("<f4") if scale < 0 else np.dtype(">f4")
    count = width * height * channels
    body = blob[m.end():]
    if len(body) < count * 4:
        raise InvalidArgumentError(
            f"PFM file {str(p)!r} is truncated: the header announces {width}x{height}x"
            f"{channels} float32 values ({count * 4} bytes), the file holds {len(body)}"
        )
    data = np.frombuffer(body, dtype=dtype, count=count).astype(np.float32)
    shape = (height, width, 3) if channels == 3 else (height, width)
    data = np.ascontiguousarray(data.reshape(shape)[::-1])
    data[np.isinf(data)] = np.nan
    return data


def read_kitti_disparity(path) -> np.ndarray:
    """Read a KITTI 2012/2015 disparity map: uint16 PNG, ``value / 256``, 0 = unknown.

    Parameters
    ----------
    path : str or pathlib.Path
        ``disp_noc/*.png`` or ``disp_occ/*.png``.

    Returns
    -------
    disparity : (H, W) float32 ndarray
        In pixels, for the left image; NaN where the file holds 0 (no LiDAR return).

    Raises
    ------
    InvalidArgumentError
        Missing file, undecodable file, or not a single-channel 16-bit image (an 8-bit
        file would silently give disparities 256 times too small).

    Examples
    --------
    >>> import tempfile, os, cv2, numpy as np
    >>> path = os.path.join(tempfile.mkdtemp(), "000000_10.png")
    >>> _ = cv2.imwrite(path, np.array([[0, 256, 640]], np.uint16))
    >>> read_kitti_disparity(path)
    array([[nan, 1. , 2.5]], dtype=float32)
    """
    raw = _imread(path, cv2.IMREAD_UNCHANGED, "KITTI disparity")
    if raw.ndim != 2 or raw.dtype != np.uint16:
        raise InvalidArgumentError(
            f"KITTI disparity file {str(path)!r} must be a single-channel 16-bit PNG "
            f"(value / 256, 0 = unknown), got shape {raw.shape} and dtype {raw.dtype}"
        )
    return _to_disparity(raw, 256.0, 0)


def _read_disparity(path: Path, scale: float, unknown_value, pfm_unknown=None) -> np.ndarray:
    """Any disparity file of a meta.json scene: PFM, or an integer PNG/PGM."""
    if path.suffix.lower() == ".pfm":
        unknown_value = pfm_unknown
        data = read_pfm(path)
        if data.ndim != 2:
            raise InvalidArgumentError(f"disparity file {str(path)!r} must be a grey 'Pf' PFM")
        if unknown_value is not None:
            data[data == unknown_value] = np.nan
        return np.ascontiguousarray(data / np.float32(scale), dtype=np.float32)
    return read_middlebury_disparity(path, scale, unknown_value)


# --------------------------------------------------------------------------------------
# Calibration readers
# --------------------------------------------------------------------------------------


def _parse_matrix(text: str, path, key: str) -> np.ndarray:
    rows = [r.split() for r in text.strip().split(";")]
    if any(len(r) != len(rows[0]) for r in rows):
        raise InvalidArgumentError(
            f"Middlebury calibration file {str(path)!r}: the rows of `{key}` have different "
            f"lengths ({[len(r) for r in rows]})"
        )
    try:
        return np.array([[float(v) for v in r] for r in rows], dtype=np.float64)
    except ValueError:
        raise InvalidArgumentError(
            f"Middlebury calibration file {str(path)!r}: `{key}` must be a matrix like "
            f"'[f 0 cx; 0 f cy; 0 0 1]', got {text!r}"
        ) from None


def read_middlebury_calib(path) -> dict:
    """Read a Middlebury 2014 / MiddEval3 ``calib.txt``.

    Lines are ``key=value``; matrices are written ``[a b c; d e f; g h i]``::

        cam0=[3997.684 0 1176.728; 0 3997.684 1011.728; 0 0 1]
        cam1=[3997.684 0 1307.839; 0 3997.684 1011.728; 0 0 1]
        doffs=131.111
        baseline=193.001
        width=2964
        height=1988
        ndisp=280

    Depth is ``Z = baseline * f / (d + doffs)`` (baseline in mm gives Z in mm).

    Parameters
    ----------
    path : str or pathlib.Path
        The ``calib.txt`` file.

    Returns
    -------
    calib : dict
        Every key of the file: matrices as (3, 3) float64 ndarrays (``cam0``, ``cam1``),
        numbers as floats (``doffs``, ``baseline`` in mm, ``width``, ``height``,
        ``ndisp``, ``vmin``, ...). Added, derived from ``cam0``: ``focal_length``, ``cx``,
        ``cy`` (pixels).

    Raises
    ------
    InvalidArgumentError
        Missing file, a line without ``=``, a value that is neither a number nor a
        matrix, or no 3x3 ``cam0`` / ``cam1``.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "calib.txt")
    >>> with open(path, "w") as f:
    ...     _ = f.write("cam0=[10 0 5; 0 10 4; 0 0 1]\\ncam1=[10 0 7; 0 10 4; 0 0 1]\\n"
    ...                 "doffs=2\\nbaseline=100\\nwidth=12\\nheight=9\\nndisp=16\\n")
    >>> c = read_middlebury_calib(path)
    >>> c["cam1"][0, 2], c["doffs"], c["focal_length"], c["ndisp"]
    (np.float64(7.0), 2.0, 10.0, 16.0)
    """
    p = _existing_file(path, "Middlebury calibration")
    try:
        text = p.read_text()
    except UnicodeDecodeError:
        raise InvalidArgumentError(
            f"Middlebury calibration file {str(p)!r} is not a text file"
        ) from None
    calib: dict = {}
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        if "=" not in line:
            raise InvalidArgumentError(
                f"Middlebury calibration file {str(p)!r}, line {lineno}: expected "
                f"'key=value', got {line!r}"
            )
        key, value = (s.strip() for s in line.split("=", 1))
        if value.startswith("["):
            if not value.endswith("]"):
                raise InvalidArgumentError(
                    f"Middlebury calibration file {str(p)!r}, line {lineno}: matrix "
                    f"`{key}` is not closed with ']'"
                )
            calib[key] = _parse_matrix(value[1:-1], p, key)
        else:
            try:
                calib[key] = float(value)
            except ValueError:
                raise InvalidArgumentError(
                    f"Middlebury calibration file {str(p)!r}, line {lineno}: `{key}` must "
                    f"be a number or a matrix, got {value!r}"
                ) from None
    for key in ("cam0", "cam1"):
        if not isinstance(calib.get(key), np.ndarray) or calib[key].shape != (3, 3):
            raise InvalidArgumentError(
                f"Middlebury calibration file {str(p)!r} must define `{key}` as a 3x3 "
                f"matrix '[f 0 cx; 0 f cy; 0 0 1]'"
                + (f", got shape {calib[key].shape}" if key in calib and
                   isinstance(calib[key], np.ndarray) else "")
            )
    calib["focal_length"] = float(calib["cam0"][0, 0])
    calib["cx"] = float(calib["cam0"][0, 2])
    calib["cy"] = float(calib["cam0"][1, 2])
    return calib


def read_kitti_calib(path) -> dict:
    """Read a KITTI stereo ``calib.txt``: lines ``P0: p11 ... p34`` (3x4, row-major).

    Parameters
    ----------
    path : str or pathlib.Path
        The calibration file (KITTI stereo 2012 ``calib/*.txt``).

    Returns
    -------
    calib : dict
        ``P0`` .. ``P3`` as (3, 4) float64 ndarrays (0, 1: grey left/right; 2, 3: colour
        left/right); any other ``key: numbers`` line as a (3, 4) or (3, 3) array when it
        has 12 or 9 numbers, else a 1-D array. Derived for the grey pair P0/P1:
        ``focal_length`` and ``cx``, ``cy`` (pixels, from P0), and ``baseline`` in
        metres, ``(P0[0, 3] - P1[0, 3]) / P1[0, 0]``. Depth is
        ``Z = focal_length * baseline / d``.

    Raises
    ------
    InvalidArgumentError
        Missing file, a line that is not ``key: numbers``, or P0..P3 missing or not 12
        numbers.

    Examples
    --------
    >>> import tempfile, os
    >>> path = os.path.join(tempfile.mkdtemp(), "calib.txt")
    >>> with open(path, "w") as f:
    ...     for i, tx in enumerate([0.0, -50.0, 4.0, -46.0]):
    ...         _ = f.write(f"P{i}: 100 0 60 {tx} 0 100 40 0 0 0 1 0\\n")
    >>> c = read_kitti_calib(path)
    >>> c["P1"].shape, c["focal_length"], c["baseline"]
    ((3, 4), 100.0, 0.5)
    """
    p = _existing_file(path, "KITTI calibration")
    try:
        text = p.read_text()
    except UnicodeDecodeError:
        raise InvalidArgumentError(f"KITTI calibration file {str(p)!r} is not a text file") from None
    calib: dict = {}
    for lineno, line in enumerate(text.splitlines(), 1):
        line = line.strip()
        if not line:
            continue
        key, sep, value = line.partition(":")
        try:
            if not sep:
                raise ValueError
            nums = np.array([float(v) for v in value.split()], dtype=np.float64)
        except ValueError:
            raise InvalidArgumentError(
                f"KITTI calibration file {str(p)!r}, line {lineno}: expected "
                f"'P0: 12 numbers', got {line[:80]!r}"
            ) from None
        key = key.strip()
        if nums.size == 12:
            nums = nums.reshape(3, 4)
        elif nums.size == 9:
            nums = nums.reshape(3, 3)
        calib[key] = nums
    for key in ("P0", "P1", "P2", "P3"):
        if key not in calib or calib[key].shape != (3, 4):
            got = f"{calib[key].size} numbers" if key in calib else "nothing"
            raise InvalidArgumentError(
                f"KITTI calibration file {str(p)!r} must define `{key}` as a 3x4 projection "
                f"matrix (12 numbers), got {got}"
            )
    p0, p1 = calib["P0"], calib["P1"]
    if p1[0, 0] == 0:
        raise InvalidArgumentError(f"KITTI calibration file {str(p)!r}: P1 has zero focal length")
    calib["focal_length"] = float(p0[0, 0])
    calib["cx"] = float(p0[0, 2])
    calib["cy"] = float(p0[1, 2])
    calib["baseline"] = float((p0[0, 3] - p1[0, 3]) / p1[0, 0])
    return calib


def _read_calibration_file(path: Path) -> dict:
    """Detect the format of a calib.txt (KITTI 'P0:' or Middlebury 'cam0=') and read it."""
    p = _existing_file(path, "calibration")
    try:
        head = p.read_text()[:4096]
    except UnicodeDecodeError:
        raise InvalidArgumentError(f"calibration file {str(p)!r} is not a text file") from None
    if re.search(r"^\s*P0\s*:", head, re.M):
        return read_kitti_calib(p)
    if re.search(r"^\s*cam0\s*=", head, re.M):
        return read_middlebury_calib(p)
    raise InvalidArgumentError(
        f"calibration file {str(p)!r} is neither KITTI ('P0: ...' lines) nor Middlebury "
        "('cam0=[...]' lines)"
    )


# --------------------------------------------------------------------------------------
# Scenes
# --------------------------------------------------------------------------------------


def load_motorcycle() -> StereoScene:
    """The built-in scene: Middlebury 2014 Motorcycle, 741x500, from scikit-image.

    Returns
    -------
    scene : StereoScene
        ``left``/``right`` converted to **BGR** (scikit-image gives RGB) so that they
        look like ``cv2.imread`` output; ``disparity`` float32 with scikit-image's ``inf``
        (unknown) turned into NaN. ``calibration`` holds the values of scikit-image's
        docstring, valid for this down-sampled pair: ``focal_length`` 994.978, ``cx``
        311.193, ``cy`` 254.877, ``doffs`` 31.086 (px), ``baseline`` 193.001 (mm), and
        the Middlebury-style ``cam0``/``cam1`` matrices, ``width``, ``height``.

    Notes
    -----
    The sign convention was checked on the data by warping: the left pixel ``(x, y)``
    matches the right pixel ``(x - d, y)``, as in every Middlebury scene (mean absolute
    grey difference about 7 levels, against about 45 for ``x + d``). scikit-image's
    docstring writes the relation as "``img_left[10, 10 + disp[10, 10]]`` corresponds to
    ``img_right[10, 10]``", which indexes ``disp`` at the right pixel; the map is really
    the left view's and holds ``inf``, not NaN, where unknown.

    Examples
    --------
    >>> scene = load_motorcycle()
    >>> scene.left.shape, scene.disparity.dtype
    ((500, 741, 3), dtype('float32'))
    """
    from skimage.data import stereo_motorcycle

    left, right, disp = stereo_motorcycle()
    disp = np.array(disp, dtype=np.float32)
    disp[~np.isfinite(disp)] = np.nan
    h, w = disp.shape
    f, cx, cy, doffs, baseline = 994.978, 311.193, 254.877, 31.086, 193.001
    calib = {
        "cam0": np.array([[f, 0, cx], [0, f, cy], [0, 0, 1]], dtype=np.float64),
        "cam1": np.array([[f, 0, cx + doffs], [0, f, cy], [0, 0, 1]], dtype=np.float64),
        "doffs": doffs,
        "baseline": baseline,
        "width": float(w),
        "height": float(h),
        "focal_length": f,
        "cx": cx,
        "cy": cy,
    }
    return StereoScene(
        name=MOTORCYCLE,
        left=np.ascontiguousarray(cv2.cvtColor(left, cv2.COLOR_RGB2BGR)),
        right=np.ascontiguousarray(cv2.cvtColor(right, cv2.COLOR_RGB2BGR)),
        disparity=np.ascontiguousarray(disp),
        calibration=calib,
        source=_MOTORCYCLE_CITE,
        dataset=f"Middlebury 2014 Motorcycle, down-sampled 4x to {w}x{h} (scikit-image)",
        meta={"disparity_px": "float, inf = unknown (NaN here)"},
    )


_REQUIRED_META = ("left", "right", "disp", "scale")


def _meta_file(meta: dict, key: str, folder: Path, meta_path: Path) -> Path:
    value = meta[key]
    if not isinstance(value, str) or not value:
        raise InvalidArgumentError(
            f"{str(meta_path)!r}: `{key}` must be a file name (a non-empty string), "
            f"got {value!r}"
        )
    return folder / value


def _calibration_from_meta(value, folder: Path, meta_path: Path) -> dict | None:
    if value is None:
        return None
    if isinstance(value, dict):
        return {k: (np.asarray(v, dtype=np.float64) if isinstance(v, list) else v)
                for k, v in value.items()}
    if isinstance(value, str) and value.strip():
        # "calib.txt" or "calib.txt (free text)": the first word names the file.
        return _read_calibration_file(folder / value.split()[0])
    raise InvalidArgumentError(
        f"{str(meta_path)!r}: `calibration` must be a file name (optionally followed by a "
        f"description) or a dict of parameters, got {value!r}"[:300]
    )


def load_scene(folder, name: str | None = None) -> StereoScene:
    """Load a scene folder described by a ``meta.json``.

    ``meta.json`` keys: ``left``, ``right``, ``disp`` (file names, required), ``scale``
    (required: disparity in pixels = stored value / scale), ``unknown_value`` (stored
    value meaning "no ground truth"; default 0, or none for PFM files, whose ``inf``
    already means unknown), ``dataset``, ``cite``; optional
    ``disp_right``, ``disp_all`` (KITTI ``disp_occ``), ``nonoccluded_mask``,
    ``calibration`` (a file name, optionally followed by a description, of a KITTI or
    Middlebury ``calib.txt``; or a dict). A ``dmin.txt`` beside it is read into
    ``meta["dmin"]``. Disparity files may be PNG/PGM (8 or 16 bit) or PFM.

    Parameters
    ----------
    folder : str or pathlib.Path
        The scene folder.
    name : str, optional
        Name to give the scene; by default its path relative to :func:`shared_data_dir`
        when it lies there (``"middlebury/tsukuba"``), else the folder name.

    Returns
    -------
    scene : StereoScene

    Raises
    ------
    InvalidArgumentError
        ``meta.json`` or a file it names is missing or malformed, a key is missing, or
        the images and disparity maps disagree in size.

    Examples
    --------
    >>> import json, os, tempfile, cv2, numpy as np
    >>> folder = tempfile.mkdtemp()
    >>> img = np.zeros((4, 6), np.uint8)
    >>> _ = cv2.imwrite(os.path.join(folder, "im0.png"), img)
    >>> _ = cv2.imwrite(os.path.join(folder, "im1.png"), img)
    >>> _ = cv2.imwrite(os.path.join(folder, "disp.png"), np.full((4, 6), 16, np.uint8))
    >>> with open(os.path.join(folder, "meta.json"), "w") as f:
    ...     json.dump({"left": "im0.png", "right": "im1.png", "disp": "disp.png",
    ...                "scale": 8, "unknown_value": 0}, f)
    >>> scene = load_scene(folder, name="tiny")
    >>> scene.name, scene.left.shape, float(scene.disparity[0, 0])
    ('tiny', (4, 6), 2.0)
    """
    folder = _as_path(folder, "folder")
    meta_path = folder / "meta.json"
    if not folder.is_dir():
        raise InvalidArgumentError(f"scene folder {str(folder)!r} does not exist")
    _existing_file(meta_path, "scene description (meta.json)")
    try:
        meta = json.loads(meta_path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise InvalidArgumentError(f"{str(meta_path)!r} is not valid JSON: {exc}") from None
    if not isinstance(meta, dict):
        raise InvalidArgumentError(
            f"{str(meta_path)!r} must hold a JSON object, got {type(meta).__name__}"
        )
    missing = [k for k in _REQUIRED_META if k not in meta]
    if missing:
        raise InvalidArgumentError(
            f"{str(meta_path)!r} lacks the key(s) {missing}; a scene needs "
            f"{list(_REQUIRED_META)} (and usually unknown_value, dataset, cite)"
        )
    try:
        scale = as_real(meta["scale"], "scale", lo=0.0, lo_open=True)
    except (InvalidArgumentError, InvalidTypeError) as exc:
        raise InvalidArgumentError(f"{str(meta_path)!r}: {exc}") from None
    unknown = meta.get("unknown_value", 0)
    pfm_unknown = meta.get("unknown_value")  # PFM: inf already means unknown
    if unknown is not None and (isinstance(unknown, bool) or not isinstance(unknown, numbers.Real)):
        raise InvalidArgumentError(
            f"{str(meta_path)!r}: `unknown_value` must be a number or null, got {unknown!r}"
        )

    left = _read_image(_meta_file(meta, "left", folder, meta_path), "left image")
    right = _read_image(_meta_file(meta, "right", folder, meta_path), "right image")
    disp = _read_disparity(
        _meta_file(meta, "disp", folder, meta_path), scale, unknown, pfm_unknown
    )

    def optional_disp(key):
        if meta.get(key) is None:
            return None
        return _read_disparity(
            _meta_file(meta, key, folder, meta_path), scale, unknown, pfm_unknown
        )

    disp_right = optional_disp("disp_right")
    disp_all = optional_disp("disp_all")
    mask = None
    if meta.get("nonoccluded_mask") is not None:
        mpath = _meta_file(meta, "nonoccluded_mask", folder, meta_path)
        mask = _single_channel(
            _imread(mpath, cv2.IMREAD_UNCHANGED, "non-occluded mask"), mpath, "non-occluded mask"
        ) != 0
    calibration = _calibration_from_meta(meta.get("calibration"), folder, meta_path)

    shape = left.shape[:2]
    for what, arr in (("right image", right), ("disparity", disp), ("disp_right", disp_right),
                      ("disp_all", disp_all), ("nonoccluded_mask", mask)):
        if arr is not None and arr.shape[:2] != shape:
            raise InvalidArgumentError(
                f"scene {str(folder)!r}: {what} has size {arr.shape[:2]}, the left image "
                f"{shape}; all files of a scene must have the same height and width"
            )

    meta = dict(meta)
    dmin_path = folder / "dmin.txt"
    if dmin_path.is_file():
        try:
            meta["dmin"] = float(dmin_path.read_text().split()[0])
        except (ValueError, IndexError, UnicodeDecodeError):
            raise InvalidArgumentError(
                f"{str(dmin_path)!r} must hold one number (the disparity offset)"
            ) from None

    if name is None:
        name = folder.name
        root = shared_data_dir(must_exist=False)
        if root is not None:
            try:
                name = folder.resolve().relative_to(root.resolve()).as_posix()
            except ValueError:
                pass
    return StereoScene(
        name=name,
        left=left,
        right=right,
        disparity=disp,
        calibration=calibration,
        source=str(meta.get("cite", "")),
        dataset=str(meta.get("dataset", "")),
        disparity_right=disp_right,
        disparity_all=disp_all,
        nonoccluded_mask=mask,
        folder=folder,
        meta=meta,
    )


def shared_data_dir(must_exist: bool = True) -> Path | None:
    """Where the shared stereo data is: ``$HOPMATCH_SHARED_DATA``, else ``../shared/data``.

    ``../shared/data`` is looked for beside the project root (the folder holding the
    ``hopmatch`` package), then relative to the current directory.

    Parameters
    ----------
    must_exist : bool
        If True (default) raise when no folder is found; if False return None.

    Returns
    -------
    path : pathlib.Path or None

    Raises
    ------
    InvalidArgumentError
        ``must_exist`` and the folder is absent (the message says where it looked).

    Examples
    --------
    >>> path = shared_data_dir(must_exist=False)   # None when the data is absent
    >>> path is None or (path / "middlebury").is_dir()
    True
    """
    env = os.environ.get(SHARED_DATA_ENV)
    if env:
        candidates = [Path(env)]
    else:
        project_root = Path(__file__).resolve().parents[1]
        candidates = [project_root.parent / "shared" / "data", Path.cwd().parent / "shared" / "data"]
    for c in candidates:
        if c.is_dir():
            return c
    if not must_exist:
        return None
    where = " or ".join(repr(str(c)) for c in candidates)
    raise InvalidArgumentError(
        f"the shared stereo data folder is absent (looked in {where}); put it at "
        f"../shared/data beside the project or set {SHARED_DATA_ENV} to its path"
    )


def _scene_root(root) -> Path | None:
    if root is None:
        return shared_data_dir(must_exist=False)
    root = _as_path(root, "root")
    if not root.is_dir():
        raise InvalidArgumentError(f"`root` {str(root)!r} is not a folder")
    return root


def list_scenes(root=None) -> list[str]:
    """Names of the scenes :func:`load` can load.

    Parameters
    ----------
    root : str or pathlib.Path, optional
        The data folder; default :func:`shared_data_dir` (when absent, only the built-in
        scene is listed).

    Returns
    -------
    names : list of str
        ``"motorcycle"`` first, then every folder under ``root`` holding a ``meta.json``,
        as a sorted ``/``-separated relative path (``"aloe"``, ``"kitti2012/000070"``,
        ``"middlebury/tsukuba"``, ...).

    Examples
    --------
    >>> list_scenes()[0]
    'motorcycle'
    """
    names = [MOTORCYCLE]
    base = _scene_root(root)
    if base is not None:
        found = sorted(p.parent.relative_to(base).as_posix() for p in base.rglob("meta.json"))
        names += [n for n in found if n not in (".", MOTORCYCLE)]
    return names


def load(name: str, root=None) -> StereoScene:
    """Load a scene by name: ``"motorcycle"`` or a name from :func:`list_scenes`.

    Parameters
    ----------
    name : str
        ``"motorcycle"`` (built in, always available) or a folder under ``root``, e.g.
        ``"middlebury/tsukuba"``, ``"aloe"``, ``"kitti2012/000070"``.
    root : str or pathlib.Path, optional
        The data folder; default :func:`shared_data_dir`.

    Returns
    -------
    scene : StereoScene

    Raises
    ------
    InvalidArgumentError
        Unknown name (the message lists the available ones) or no shared data.

    Examples
    --------
    >>> load("motorcycle").name
    'motorcycle'
    """
    if not isinstance(name, str):
        raise InvalidTypeError(f"`name` must be a scene name (str), got {type(name).__name__}")
    if name == MOTORCYCLE:
        return load_motorcycle()
    base = _scene_root(root)
    if base is None:
        shared_data_dir(must_exist=True)  # raises, saying where it looked
    folder = base / name
    if ".." in Path(name).parts or not (folder / "meta.json").is_file():
        raise InvalidArgumentError(
            f"unknown scene {name!r} (no {str(folder / 'meta.json')!r}); available: "
            f"{', '.join(list_scenes(base))}"
        )
    return load_scene(folder, name=name)
