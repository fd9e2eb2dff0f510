"""Stereo calibrations: :class:`StereoCalibration` and its OpenCV FileStorage files.

A calibration holds what ``cv2.stereoCalibrate`` (K1, D1, K2, D2, R, T) and, optionally,
``cv2.stereoRectify`` (R1, R2, P1, P2, Q) give. It is written with ``cv2.FileStorage``
(YAML, XML or JSON) and read back from the many key spellings found in the wild
(:data:`CALIBRATION_KEYS`), OpenCV's ``stereo_calib`` sample's pair of files included.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from .._validate import as_array, as_image_size, as_matrix, as_points, cv2_call, describe
from ..errors import FileReadError, InvalidArgumentError, InvalidTypeError
from ..files import MAX_TEXT_BYTES, atomic_path, check_input_file, check_storage_nesting
from .checks import (
    as_alpha,
    as_camera_matrix,
    as_distortion,
    as_path,
    as_rotation,
    as_translation,
)

__all__ = ["CALIBRATION_KEYS", "MAX_CALIBRATION_CORNERS", "StereoCalibration", "as_calibration",
           "calibrate_from_corners"]


#: Key spellings read by StereoCalibration.from_file, canonical name first.
CALIBRATION_KEYS = {
    "K1": ("K1", "M1", "cameraMatrix1", "camera_matrix1", "camera_matrix_1", "cameraMatrixL",
           "camera_matrix_left", "mtx1", "mtxL"),
    "D1": ("D1", "distCoeffs1", "dist_coeffs1", "distortion_coefficients1",
           "distortion_coefficients_1", "distCoeffsL", "dist_coeffs_left", "dist1", "distL"),
    "K2": ("K2", "M2", "cameraMatrix2", "camera_matrix2", "camera_matrix_2", "cameraMatrixR",
           "camera_matrix_right", "mtx2", "mtxR"),
    "D2": ("D2", "distCoeffs2", "dist_coeffs2", "distortion_coefficients2",
           "distortion_coefficients_2", "distCoeffsR", "dist_coeffs_right", "dist2", "distR"),
    "R": ("R", "rotation", "rotation_matrix"),
    "T": ("T", "translation", "translation_vector"),
    "R1": ("R1",), "R2": ("R2",), "P1": ("P1",), "P2": ("P2",), "Q": ("Q",),
}
#: Fields every calibration has; the others are optional (None).
_REQUIRED = ("K1", "D1", "K2", "D2", "R", "T")
#: Spellings of an image size stored as one [width, height] node.
_SIZE_KEYS = ("image_size", "imageSize", "img_size")

#: The check of each field, for the constructor and for from_file (which names the file
#: and key of a malformed value).
_FIELD_CHECKS = {
    "K1": as_camera_matrix,
    "D1": as_distortion,
    "K2": as_camera_matrix,
    "D2": as_distortion,
    "R": as_rotation,
    "T": as_translation,
    "image_size": as_image_size,
    "R1": lambda v, n: as_matrix(v, n, (3, 3)),
    "R2": lambda v, n: as_matrix(v, n, (3, 3)),
    "P1": lambda v, n: as_matrix(v, n, (3, 4)),
    "P2": lambda v, n: as_matrix(v, n, (3, 4)),
    "Q": lambda v, n: as_matrix(v, n, (4, 4)),
}


def _check_calibration_fields(values: dict) -> dict:
    """Coerce calibration fields (None stays None for the optional ones)."""
    out = {}
    for key, value in values.items():
        if value is None and key not in _REQUIRED:
            out[key] = None
        else:
            out[key] = _FIELD_CHECKS[key](value, key)
    return out


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class StereoCalibration:
    """A calibrated stereo pair, as ``cv2.stereoCalibrate`` and ``cv2.stereoRectify`` give it.

    All matrices are stored as float64 arrays; the constructor checks their shapes.
    ``R``, ``T`` take points from the left camera's frame to the right's
    (``X_right = R @ X_left + T``), as ``cv2.stereoCalibrate`` returns them.

    Parameters
    ----------
    K1, K2 : (3, 3) array_like
        Camera matrices of the left and right cameras.
    D1, D2 : array_like of 4, 5, 8, 12 or 14 values
        Distortion coefficients (stored as ``(1, n)``).
    R : (3, 3) array_like, or rotation vector of 3 values
        Rotation from the left to the right camera.
    T : array_like of 3 values
        Translation from the left to the right camera (stored as ``(3, 1)``), in the unit
        all 3-D results come out in.
    image_size : (width, height), optional
        Size of the calibration images (cv2's order). Taken from the images by
        :func:`rectify` when None.
    R1, R2 : (3, 3) array_like, optional
        Rectification rotations of ``cv2.stereoRectify``.
    P1, P2 : (3, 4) array_like, optional
        Projection matrices in the rectified frames.
    Q : (4, 4) array_like, optional
        Disparity-to-depth matrix.

    Examples
    --------
    >>> import numpy as np
    >>> K = [[500, 0, 320], [0, 500, 240], [0, 0, 1]]
    >>> cal = StereoCalibration(K, np.zeros(5), K, np.zeros(5), np.eye(3), [-0.1, 0, 0],
    ...                         image_size=(640, 480))
    >>> cal
    StereoCalibration(image_size=(640, 480), baseline=0.1, rectified=False)
    >>> cal.with_rectification().P2[0, 3].round(3)
    np.float64(-50.0)
    """

    K1: np.ndarray
    D1: np.ndarray
    K2: np.ndarray
    D2: np.ndarray
    R: np.ndarray
    T: np.ndarray
    image_size: tuple[int, int] | None = None
    R1: np.ndarray | None = None
    R2: np.ndarray | None = None
    P1: np.ndarray | None = None
    P2: np.ndarray | None = None
    Q: np.ndarray | None = None

    def __post_init__(self):
        checked = _check_calibration_fields(
            {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        )
        for key, value in checked.items():
            object.__setattr__(self, key, value)

    # -- derived quantities -------------------------------------------------------------
    @property
    def rectified(self) -> bool:
        """True when R1, R2, P1, P2 and Q are all present."""
        return all(getattr(self, k) is not None for k in ("R1", "R2", "P1", "P2", "Q"))

    @property
    def baseline(self) -> float:
        """Distance between the optical centres, ``||T||``, in the unit of ``T``."""
        return float(np.linalg.norm(self.T))

    def fundamental_matrix(self) -> np.ndarray:
        """The (3, 3) fundamental matrix ``F = K2^-T [T]x R K1^-1`` of the pair.

        For *undistorted* pixel coordinates: ``[xr, yr, 1] @ F @ [xl, yl, 1] == 0``.
        Normalised so that ``||F|| = 1``.
        """
        t = self.T.ravel()
        tx = np.array([[0, -t[2], t[1]], [t[2], 0, -t[0]], [-t[1], t[0], 0]])
        f = np.linalg.inv(self.K2).T @ tx @ self.R @ np.linalg.inv(self.K1)
        return f / np.linalg.norm(f)

    def with_rectification(self, alpha: float = 0.0, *, zero_disparity: bool = True,
                           image_size=None) -> StereoCalibration:
        """A copy with R1, R2, P1, P2, Q computed by ``cv2.stereoRectify``.

        Parameters
        ----------
        alpha : float
            Free scaling of ``cv2.stereoRectify``: 0 keeps only valid pixels, 1 keeps all
            source pixels, -1 lets OpenCV choose.
        zero_disparity : bool
            ``cv2.CALIB_ZERO_DISPARITY``: same principal point in both rectified views, so
            points at infinity have disparity 0.
        image_size : (width, height), optional
            Needed when the calibration has none.
        """
        size = as_image_size(image_size, "image_size") or self.image_size
        if size is None:
            raise InvalidArgumentError(
                "this calibration has no image_size; pass image_size=(width, height)"
            )
        alpha = as_alpha(alpha)
        if not isinstance(zero_disparity, (bool, np.bool_)):
            raise InvalidTypeError(
                f"`zero_disparity` must be a bool, got {describe(zero_disparity)}"
            )
        flags = cv2.CALIB_ZERO_DISPARITY if zero_disparity else 0
        r1, r2, p1, p2, q, _, _ = cv2_call(
            "cv2.stereoRectify with this calibration", cv2.stereoRectify,
            self.K1, self.D1, self.K2, self.D2, size, self.R, self.T,
            flags=flags, alpha=alpha,
        )
        return dataclasses.replace(self, image_size=size, R1=r1, R2=r2, P1=p1, P2=p2, Q=q)

    def __repr__(self) -> str:
        return (f"StereoCalibration(image_size={self.image_size}, "
                f"baseline={self.baseline:.6g}, rectified={self.rectified})")

    # -- files ----------------------------------------------------------------------------
    @classmethod
    def from_file(cls, path, extrinsics=None) -> StereoCalibration:
        """Read a calibration from an OpenCV FileStorage file (YAML, XML or JSON).

        Reads the key spellings of :data:`CALIBRATION_KEYS`: ``K1``/``M1``/
        ``cameraMatrix1``..., ``D1``/``distCoeffs1``..., ``R``, ``T`` and optionally ``R1``,
        ``R2``, ``P1``, ``P2``, ``Q``; the image size from ``image_size`` (or ``imageSize``)
        = [width, height], or ``image_width`` and ``image_height``.

        OpenCV's ``stereo_calib.cpp`` sample writes ``intrinsics.yml`` (M1, D1, M2, D2) and
        ``extrinsics.yml`` (R, T, R1, R2, P1, P2, Q): pass the first as ``path`` and the
        second as ``extrinsics``, which is also found on its own beside an
        ``intrinsics.*`` file.

        Parameters
        ----------
        path : str or os.PathLike
            The file.
        extrinsics : str or os.PathLike, optional
            A second file whose keys fill those missing from the first.

        Raises
        ------
        InvalidArgumentError
            When a file cannot be read, or lacks a required key (the message names the
            file, the missing keys and the keys it holds), or holds a malformed matrix.
        """
        path = as_path(path)
        values, spelled, found = _read_storage(path, "path")
        sources = {k: path for k in values}
        missing_rt = [k for k in ("R", "T") if k not in values]
        if extrinsics is None and missing_rt and "intrinsics" in path.name:
            guess = path.with_name(path.name.replace("intrinsics", "extrinsics"))
            if guess.is_file():
                extrinsics = guess
        if extrinsics is not None:
            epath = as_path(extrinsics, "extrinsics")
            evalues, espelled, efound = _read_storage(epath, "extrinsics")
            for k, v in evalues.items():
                if k not in values:
                    values[k] = v
                    sources[k] = epath
                    spelled[k] = espelled[k]
            found = found + [f"{k} ({epath.name})" for k in efound]
        missing = [k for k in _REQUIRED if k not in values]
        if missing:
            spellings = "; ".join(f"{k}: {', '.join(CALIBRATION_KEYS[k])}" for k in missing)
            hint = ""
            if found == ["imagelist"]:
                hint = (" It looks like an image list (the input of OpenCV's stereo_calib "
                        "sample), not a calibration.")
            elif missing == ["R", "T"] or set(missing) <= {"R", "T"}:
                hint = (" OpenCV's stereo_calib sample writes R and T to extrinsics.yml: "
                        "pass it as extrinsics=...")
            files = str(path) + (f" and {extrinsics}" if extrinsics is not None else "")
            raise InvalidArgumentError(
                f"{files} holds no complete stereo calibration: missing {', '.join(missing)} "
                f"(accepted keys: {spellings}); it holds: {', '.join(found) or 'nothing'}.{hint}"
            )
        for field, value in values.items():
            try:
                _FIELD_CHECKS[field](value, field)
            except (InvalidArgumentError, InvalidTypeError) as exc:
                raise InvalidArgumentError(
                    f"{sources[field]}: key {spelled[field]!r} (read as {field}) is malformed: "
                    f"{exc}"
                ) from None
        return cls(**values)

    def to_file(self, path) -> None:
        """Write the calibration to an OpenCV FileStorage file, atomically.

        The format follows the extension (``.yml``/``.yaml``, ``.xml``, ``.json``, optionally
        followed by ``.gz``). Keys: K1, D1, K2, D2, R, T, image_width, image_height and,
        when present, R1, R2, P1, P2, Q; :meth:`from_file` reads them back. The file is
        written under a temporary name beside ``path`` and moved onto it when complete.
        """
        path = as_path(path)
        ext = path.suffixes[-2] if path.suffix == ".gz" and len(path.suffixes) > 1 else path.suffix
        if ext.lower() not in (".yml", ".yaml", ".xml", ".json"):
            raise InvalidArgumentError(
                f"`path` must end in .yml, .yaml, .xml or .json (optionally + .gz), as "
                f"cv2.FileStorage chooses the format from it; got {str(path)!r}"
            )
        with atomic_path(path) as tmp:
            try:
                fs = cv2.FileStorage(str(tmp), cv2.FILE_STORAGE_WRITE)
            except (cv2.error, SystemError) as exc:
                raise InvalidArgumentError(f"cannot write {path}: {exc}") from None
            if not fs.isOpened():
                raise InvalidArgumentError(f"cannot write {path}: cv2.FileStorage did not open it")
            try:
                for key in ("K1", "D1", "K2", "D2", "R", "T"):
                    fs.write(key, getattr(self, key))
                if self.image_size is not None:
                    fs.write("image_width", int(self.image_size[0]))
                    fs.write("image_height", int(self.image_size[1]))
                for key in ("R1", "R2", "P1", "P2", "Q"):
                    if getattr(self, key) is not None:
                        fs.write(key, getattr(self, key))
            except cv2.error as exc:
                raise InvalidArgumentError(f"cannot write {path}: {exc.err}") from exc
            finally:
                fs.release()


def as_calibration(calibration, name: str = "calibration") -> StereoCalibration:
    """``calibration`` itself when it is a :class:`StereoCalibration`; anything else is
    refused with a hint on how to make one."""
    if not isinstance(calibration, StereoCalibration):
        raise InvalidTypeError(
            f"`{name}` must be a StereoCalibration (e.g. StereoCalibration.from_file(path)), "
            f"got {describe(calibration)}"
        )
    return calibration


#: Most target corners :func:`calibrate_from_corners` takes, over all views (each corner
#: seen by both cameras).
MAX_CALIBRATION_CORNERS = 1 << 22


def calibrate_from_corners(object_points, left_points, right_points,
                           image_size) -> tuple[StereoCalibration, float]:
    """A stereo calibration from a calibration target's corners seen by both cameras.

    Each camera's intrinsics come from ``cv2.calibrateCamera`` of its own corners; then
    ``cv2.stereoCalibrate`` with those intrinsics fixed (``cv2.CALIB_FIX_INTRINSIC``)
    gives R and T, as OpenCV's ``stereo_calib`` sample does. The calls run with one
    OpenCV thread (``cv2.setNumThreads(1)``, restored after; other threads' cv2 calls
    meanwhile run single-threaded too): in parallel their results differ in the last
    digits from process to process, and that once in a while moves a pixel of a rectified
    image (docs/pipelines.md). So the same corners give the same calibration in any
    process.

    Parameters
    ----------
    object_points : sequence of (N_v, 3) array_like
        The target's corners in its own frame, one array per view (in the unit T is to
        come out in; planar targets have z = 0).
    left_points, right_points : sequence of (N_v, 2) array_like
        The same corners in the left and right images (``cv2.findChessboardCorners``'
        ``(N_v, 1, 2)`` arrays are accepted), one array per view.
    image_size : (width, height)
        Size of the calibration images.

    Returns
    -------
    (StereoCalibration, float)
        The calibration (with ``image_size``; no rectification yet:
        :meth:`StereoCalibration.with_rectification`) and ``cv2.stereoCalibrate``'s RMS
        reprojection error in pixels.

    Raises
    ------
    InvalidTypeError, InvalidArgumentError
        Malformed corners (the three sequences of unequal lengths, a view with fewer than
        4 corners or unequal counts across the three, more than
        :data:`MAX_CALIBRATION_CORNERS` in all), or corners OpenCV cannot calibrate from.
    """
    size = as_image_size(image_size, "image_size")
    if size is None:
        raise InvalidTypeError("`image_size` must be (width, height) as two integers, got None")
    views = {}
    for name, value in (("object_points", object_points), ("left_points", left_points),
                        ("right_points", right_points)):
        if isinstance(value, (str, bytes, np.ndarray)) or not isinstance(value, Sequence):
            raise InvalidTypeError(f"`{name}` must be a sequence of arrays, one per view, "
                                   f"got {describe(value)}")
        views[name] = value
    n_views = {len(v) for v in views.values()}
    if len(n_views) != 1 or 0 in n_views:
        raise InvalidArgumentError(
            "`object_points`, `left_points` and `right_points` must hold one array per view, "
            "as many views in each and at least one, got "
            + ", ".join(f"{len(v)}" for v in views.values()) + " views")
    total = 0
    obj, left, right = [], [], []
    for v, (o, lp, rp) in enumerate(zip(*views.values())):
        o = as_array(o, f"object_points[{v}]", "an (N, 3) array of corner positions")
        if o.ndim == 3 and o.shape[1] == 1:
            o = o.reshape(-1, o.shape[2])
        if o.ndim != 2 or o.shape[1] != 3:
            raise InvalidArgumentError(
                f"`object_points[{v}]` must have shape (N, 3), got shape {o.shape}")
        total += len(o)
        if total > MAX_CALIBRATION_CORNERS:
            raise InvalidArgumentError(
                f"the views hold more than {MAX_CALIBRATION_CORNERS} corners in all; "
                "calibrate from fewer views or corners")
        lp, rp = as_points(lp, f"left_points[{v}]"), as_points(rp, f"right_points[{v}]")
        if not (len(o) == len(lp) == len(rp)) or len(o) < 4:
            raise InvalidArgumentError(
                f"view {v} must have the same number of corners, at least 4, in "
                f"`object_points`, `left_points` and `right_points`, got {len(o)}, "
                f"{len(lp)} and {len(rp)}")
        obj.append(np.ascontiguousarray(o, dtype=np.float32))
        left.append(lp.reshape(-1, 1, 2))
        right.append(rp.reshape(-1, 1, 2))
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        _, k1, d1, _, _ = cv2_call("calibrateCamera of the left corners", cv2.calibrateCamera,
                                   obj, left, size, None, None)
        _, k2, d2, _, _ = cv2_call("calibrateCamera of the right corners",
                                   cv2.calibrateCamera, obj, right, size, None, None)
        rms, k1, d1, k2, d2, r, t, _, _ = cv2_call(
            "stereoCalibrate", cv2.stereoCalibrate, obj, left, right, k1, d1, k2, d2, size,
            flags=cv2.CALIB_FIX_INTRINSIC)
    finally:
        cv2.setNumThreads(threads)
    if not all(np.isfinite(m).all() for m in (k1, d1, k2, d2, r, t)) or not np.isfinite(rms):
        raise InvalidArgumentError("the corners give no finite calibration (degenerate views: "
                                   "see that the target is seen at several poses)")
    return StereoCalibration(k1, d1, k2, d2, r, t, image_size=size), float(rms)


# -- reading FileStorage files ------------------------------------------------------------


def _read_node(node, what: str):
    """A FileNode as a float64 array (matrix, sequence or number)."""
    try:
        if node.isMap():
            mat = node.mat()
            if mat is None:
                raise InvalidArgumentError(f"{what} is a map, not an OpenCV matrix")
            return np.asarray(mat, dtype=np.float64)
        if node.isSeq():
            vals = []
            for i in range(node.size()):
                item = node.at(i)
                if item.isSeq():
                    vals.append([item.at(j).real() for j in range(item.size())])
                elif item.isInt() or item.isReal():
                    vals.append(item.real())
                else:
                    raise InvalidArgumentError(f"{what} holds a non-numeric item")
            try:
                return np.asarray(vals, dtype=np.float64)
            except ValueError:
                raise InvalidArgumentError(f"{what} is a ragged sequence") from None
        if node.isInt() or node.isReal():
            return np.asarray(node.real(), dtype=np.float64)
    except cv2.error as exc:
        raise InvalidArgumentError(f"{what} is malformed: {exc.err}") from exc
    raise InvalidArgumentError(f"{what} is not a matrix or a number")


def _read_storage(path: Path, name: str) -> tuple[dict, dict, list[str]]:
    """The calibration values found in one FileStorage file, their spellings, its keys."""
    try:
        check_input_file(path, MAX_TEXT_BYTES, argument=name)
        if path.stat().st_size == 0:
            raise InvalidArgumentError(f"`{name}`: {str(path)!r} is empty")
        check_storage_nesting(path, argument=name)
    except FileReadError as exc:
        if exc.problem == "no such file":
            raise InvalidArgumentError(f"`{name}`: no such file {str(path)!r}",
                                       argument=name) from None
        raise InvalidArgumentError(f"`{name}`: {str(path)!r} {exc.problem}",
                                   argument=name) from None
    try:
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError) as exc:  # cv2 raises SystemError for some non-text files
        detail = getattr(exc, "err", None) or str(exc)
        raise InvalidArgumentError(
            f"`{name}`: {str(path)!r} is not an OpenCV FileStorage file (YAML/XML/JSON): {detail}"
        ) from None
    try:
        if not fs.isOpened():
            raise InvalidArgumentError(
                f"`{name}`: cv2.FileStorage cannot parse {str(path)!r}; is it an OpenCV "
                "YAML (starting with %YAML:1.0), XML or JSON file?"
            )
        root = fs.root()
        found = list(root.keys()) if root.isMap() else []
        values, spelled = {}, {}
        for field, spellings in CALIBRATION_KEYS.items():
            for key in spellings:
                if key in found:
                    values[field] = _read_node(fs.getNode(key), f"key {key!r} of {path}")
                    spelled[field] = key
                    break
        for key in _SIZE_KEYS:
            if key in found:
                size = _read_node(fs.getNode(key), f"key {key!r} of {path}").ravel()
                values["image_size"] = _size_from_values(size, f"key {key!r} of {path}")
                spelled["image_size"] = key
                break
        else:
            if "image_width" in found and "image_height" in found:
                w = _read_node(fs.getNode("image_width"), f"key 'image_width' of {path}")
                h = _read_node(fs.getNode("image_height"), f"key 'image_height' of {path}")
                values["image_size"] = _size_from_values(
                    np.array([w.ravel()[0], h.ravel()[0]]), f"image_width/image_height of {path}"
                )
                spelled["image_size"] = "image_width/image_height"
        return values, spelled, found
    finally:
        fs.release()


def _size_from_values(size: np.ndarray, what: str) -> tuple[int, int]:
    if size.size != 2 or not np.all(size == np.round(size)) or np.any(size <= 0):
        raise InvalidArgumentError(
            f"{what} must be [width, height] as positive integers, got {size.tolist()}"
        )
    return int(size[0]), int(size[1])
