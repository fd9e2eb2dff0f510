"""Point clouds as ASCII PLY files, written atomically."""

from __future__ import annotations

import os

import numpy as np

from .._validate import describe
from ..errors import InvalidArgumentError, InvalidTypeError
from ..files import atomic_path
from .checks import as_path, as_real_array

__all__ = ["write_ply"]


def write_ply(path, xyz, colors=None) -> int:
    """Write a point cloud as ASCII PLY, atomically.

    The file is written beside ``path`` under a temporary name and moved onto ``path``
    only when complete: on any error no file (and no half-written file) is left and an
    existing ``path`` is unchanged.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its folder must exist.
    xyz : (N, 3) array_like
        Points. Rows with a NaN or infinite coordinate (no match) are skipped.
    colors : (N, 3) uint8 ndarray, optional
        RGB colour of each point. cv2 images are BGR: pass ``image[rows, cols, ::-1]``.

    Returns
    -------
    count : int
        Number of vertices written.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "cloud.ply")
    >>> write_ply(path, [[0, 0, 1], [0.5, 0, float("nan")]])
    1
    >>> print(open(path).read().splitlines()[-1])
    0 0 1
    """
    path = as_path(path)
    pts = as_real_array(xyz, "xyz")  # rows with NaN or inf are dropped below
    if pts.size == 0:
        pts = pts.reshape(0, 3)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InvalidArgumentError(
            f"`xyz` must have shape (N, 3) holding (X, Y, Z), got shape {pts.shape}"
        )
    cols = None
    if colors is not None:
        if not isinstance(colors, np.ndarray):
            raise InvalidTypeError(
                f"`colors` must be a uint8 numpy array or None, got {describe(colors)}"
            )
        if colors.dtype != np.uint8:
            raise InvalidTypeError(
                f"`colors` must have dtype uint8 (RGB 0-255), got {colors.dtype}; convert "
                "with np.clip(colors, 0, 255).astype(np.uint8)"
            )
        if colors.shape != (len(pts), 3):
            raise InvalidArgumentError(
                f"`colors` must have shape ({len(pts)}, 3), one RGB row per point of `xyz`, "
                f"got shape {colors.shape}"
            )
        cols = colors
    keep = np.isfinite(pts).all(axis=1)
    pts = pts[keep]
    if cols is not None:
        cols = cols[keep]
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="ascii", newline="\n") as fh:
            _write_ply_body(fh, pts.astype(np.float32), cols)
            fh.flush()
            os.fsync(fh.fileno())
    return int(len(pts))


def _write_ply_body(fh, pts: np.ndarray, cols: np.ndarray | None) -> None:
    """Write the PLY header and one ``x y z [r g b]`` line per row of ``pts`` (finite
    float32) and ``cols`` (uint8 RGB, or None) to the text file ``fh``."""
    header = ["ply", "format ascii 1.0", "comment written by hopmatch",
              f"element vertex {len(pts)}",
              "property float x", "property float y", "property float z"]
    if cols is not None:
        header += ["property uchar red", "property uchar green", "property uchar blue"]
    header.append("end_header")
    fh.write("\n".join(header) + "\n")
    if len(pts) == 0:
        return
    if cols is None:
        np.savetxt(fh, pts, fmt="%.9g")
    else:
        rows = (f"{x:.9g} {y:.9g} {z:.9g} {r} {g} {b}\n"
                for (x, y, z), (r, g, b) in zip(pts.tolist(), cols.tolist()))
        fh.writelines(rows)
