"""The scene catalogue: :class:`StereoScene`, the built-in scene, and the scenes of the
shared data folder.

:func:`load` gives a scene by name: ``"motorcycle"`` is built in (from scikit-image) and
always available; the others are folders with a ``meta.json`` under the shared data folder
(:func:`shared_data_dir`), read by :func:`load_scene`. :func:`list_scenes` lists them. The
files of a scene are read with :mod:`hopmatch.datasets.readers`.
"""

from __future__ import annotations

import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from .._validate import as_array, as_real, describe
from ..errors import FileReadError, InvalidArgumentError, InvalidTypeError
from .calibration import read_calibration
from .readers import (
    as_disparity_scale,
    as_path,
    as_pfm_value,
    as_unknown_value,
    existing_file,
    read_mask,
    read_scene_disparity,
    read_scene_image,
    read_text_file,
)

__all__ = [
    "MOTORCYCLE",
    "SHARED_DATA_ENV",
    "StereoScene",
    "list_scenes",
    "load",
    "load_motorcycle",
    "load_scene",
    "shared_data_candidates",
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

#: The project root: the folder holding the ``hopmatch`` package.
_PROJECT_ROOT = Path(__file__).resolve().parents[2]


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
    The left pixel ``(x, y)`` matches the right pixel ``(x - d, y)``, as in every
    Middlebury scene (``tests/datasets/test_datasets_catalogue.py`` checks it by warping
    the right image into the left view). scikit-image's docstring writes the relation as
    "``img_left[10, 10 + disp[10, 10]]`` corresponds to ``img_right[10, 10]``", which
    indexes ``disp`` at the right pixel; the map is really the left view's and holds
    ``inf``, not NaN, where unknown.

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
#: The keys of a ``meta.json`` naming disparity files.
_DISPARITY_KEYS = ("disp", "disp_right", "disp_all")


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
        return _calibration_dict(value, meta_path)
    if isinstance(value, str) and value.strip():
        # "calib.txt" or "calib.txt (free text)": the first word names the file.
        return read_calibration(folder / value.split()[0])
    raise InvalidArgumentError(
        f"{str(meta_path)!r}: `calibration` must be a file name (optionally followed by a "
        f"description) or a dict of parameters, got {value!r}"[:300]
    )


def load_scene(folder, name: str | None = None) -> StereoScene:
    """Load a scene folder described by a ``meta.json``.

    ``meta.json`` keys: ``left``, ``right``, ``disp`` (file names, required), ``scale``
    (required: disparity in pixels = stored value / scale, in [2**-16, 2**16]),
    ``unknown_value`` (stored value meaning "no ground truth"; default 0, or none for PFM
    files, whose ``inf`` already means unknown), ``dataset``, ``cite``; optional
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
    FileReadError
        (an ``InvalidArgumentError``) ``meta.json`` nests arrays or objects more than
        :data:`MAX_META_DEPTH` levels deep; a number of it (``scale``, ``unknown_value``,
        a value of the ``calibration`` dict) is not a finite number in its range, or a
        matrix of that dict not a rectangular list of finite numbers (the message names
        the file and the key); ``dmin.txt`` holds no finite number; or as the readers of
        the files it names do.
    InvalidTypeError
        ``folder`` is not a str or path.

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
    folder = as_path(folder, "folder")
    meta_path, meta = _read_meta(folder)
    scale = _meta_check(meta_path, as_disparity_scale, meta["scale"])
    unknown = meta.get("unknown_value", 0)
    pfm_unknown = meta.get("unknown_value")  # PFM: inf already means unknown
    pfm = [meta[k].lower().endswith(".pfm") for k in _DISPARITY_KEYS
           if isinstance(meta.get(k), str)]
    if not all(pfm):  # an integer map: a value its pixels can hold, used as stored
        _meta_check(meta_path, as_unknown_value, unknown)
    if any(pfm):  # a PFM: a float32 value
        _meta_check(meta_path, as_pfm_value, pfm_unknown, "unknown_value")

    def file(key):
        return _meta_file(meta, key, folder, meta_path)

    def optional_disp(key):
        if meta.get(key) is None:
            return None
        return read_scene_disparity(file(key), scale, unknown, pfm_unknown)

    left = read_scene_image(file("left"), "left image")
    right = read_scene_image(file("right"), "right image")
    disp = read_scene_disparity(file("disp"), scale, unknown, pfm_unknown)
    disp_right = optional_disp("disp_right")
    disp_all = optional_disp("disp_all")
    mask = None
    if meta.get("nonoccluded_mask") is not None:
        mask = read_mask(file("nonoccluded_mask"), "non-occluded mask")
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
    dmin = _read_dmin(folder / "dmin.txt")
    if dmin is not None:
        meta["dmin"] = dmin
    return StereoScene(
        name=_default_name(folder) if name is None else name,
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


def _calibration_dict(value: dict, meta_path: Path) -> dict:
    """The ``calibration`` dict of a ``meta.json``: its lists as float64 arrays (finite
    numbers, rows of equal length), its numbers finite, anything else kept as it is."""
    out = {}
    for key, v in value.items():
        name = f"calibration.{key}"
        if isinstance(v, list):
            v = _meta_check(meta_path, as_array, v, name,
                            "a matrix: a list of numbers, or of rows of equally many numbers")
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            _meta_check(meta_path, as_real, v, name)
        out[key] = v
    return out


#: Deepest nesting of arrays and objects a ``meta.json`` may have. A matrix of the
#: ``calibration`` dict is 4 levels deep; Python's JSON parser fails near 1000 (with a
#: RecursionError), and printing a value nested that deep may fail as well.
MAX_META_DEPTH = 32

#: The JSON tokens that nesting depends on: strings (skipped whole), brackets and colons.
_JSON_TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\]{}:]')


def _nested_too_deep(text: str, limit: int = MAX_META_DEPTH) -> tuple[bool, str | None]:
    """Whether the JSON ``text`` nests arrays and objects more than ``limit`` levels deep,
    and then the top-level key under which it first does (None when not under a key).
    Scans the text, so it also answers for a text too deep for :func:`json.loads`."""
    if text.count("[") + text.count("{") <= limit:  # every scene description: no scan
        return False, None
    depth, key, previous = 0, None, ""
    for m in _JSON_TOKEN.finditer(text):
        token = m.group()
        if token in ("[", "{"):
            depth += 1
            if depth > limit:
                return True, key
        elif token in ("]", "}"):
            depth -= 1
        elif token == ":" and depth == 1 and previous.startswith('"'):
            key = previous[1:-1]
        previous = token
    return False, None


def _json_int(digits: str) -> int | float:
    """A JSON integer as :func:`json.loads` reads it, except that one of more digits than
    Python converts (4300 by default) becomes the float it rounds to, ``inf``, for the
    checks of its key to refuse, instead of a bare ``ValueError`` naming no key."""
    try:
        return int(digits)
    except ValueError:
        return float(digits)


def _parse_meta(text: str, meta_path: Path):
    """The JSON value of the ``meta.json`` text; errors name ``meta_path``."""
    try:
        meta = json.loads(text, parse_int=_json_int)
    except json.JSONDecodeError as exc:
        raise InvalidArgumentError(f"{str(meta_path)!r} is not valid JSON: {exc}") from None
    except RecursionError:
        meta = None  # nested too deeply for the parser: _nested_too_deep says where
    too_deep, key = _nested_too_deep(text)
    if too_deep or meta is None:
        where = "its JSON" if key is None else f"`{key}`"
        raise FileReadError(
            meta_path, f"not a valid scene description: {where} nests arrays or objects "
                       f"more than {MAX_META_DEPTH} levels deep (a scene description holds "
                       "file names, numbers, and a calibration dict of matrices)",
            kind="too_deep")
    return meta


def _read_meta(folder: Path) -> tuple[Path, dict]:
    """``(path, content)`` of the ``meta.json`` of ``folder``: a JSON object holding at
    least the keys of ``_REQUIRED_META``."""
    meta_path = folder / "meta.json"
    if not folder.is_dir():
        raise InvalidArgumentError(f"scene folder {str(folder)!r} does not exist")
    existing_file(meta_path, "scene description (meta.json)")
    text = read_text_file(meta_path, "scene description (meta.json)")
    meta = _parse_meta(text, meta_path)
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
    return meta_path, meta


def _meta_check(meta_path: Path, check, value, *args, **kwargs):
    """``check(value, *args, **kwargs)`` (a checker of :mod:`hopmatch._validate` or
    :mod:`~hopmatch.datasets.readers` naming the key it is given), its error re-raised as
    a :class:`FileReadError` naming ``meta_path``: ``"<meta_path>: `<key>` must be..."``."""
    try:
        return check(value, *args, **kwargs)
    except (InvalidArgumentError, InvalidTypeError) as exc:
        raise FileReadError(meta_path, str(exc)) from None


def _read_dmin(path: Path) -> float | None:
    """The number a Middlebury 2005 ``dmin.txt`` holds, or None when there is none; one
    that is not a finite number raises :class:`FileReadError` naming the file."""
    if not path.is_file():
        return None
    text = read_text_file(path, "disparity offset (dmin.txt)")
    try:
        dmin = float(text.split()[0])
    except (ValueError, IndexError):
        dmin = None
    if dmin is None or not math.isfinite(dmin):
        raise FileReadError(
            path, "must hold one finite number (the disparity offset), got "
                  f"{text.strip()[:40]!r}")
    return dmin


def _default_name(folder: Path) -> str:
    """``folder``'s path relative to :func:`shared_data_dir` when it lies there, else its
    name."""
    root = shared_data_dir(must_exist=False)
    if root is not None:
        try:
            return folder.resolve().relative_to(root.resolve()).as_posix()
        except ValueError:
            pass
    return folder.name


def shared_data_candidates() -> list[tuple[Path, str]]:
    """The folders :func:`shared_data_dir` tries, in order, each with how it was found.

    ``$HOPMATCH_SHARED_DATA`` alone when it is set (an explicit setting wins, and is not
    second-guessed by a folder that happens to lie nearby); else ``shared/data`` in the
    current directory, ``../shared/data`` beside it, and, when hopmatch runs from a source
    checkout (a ``pyproject.toml`` beside the package), ``../shared/data`` beside the
    checkout. An installed hopmatch never looks inside its virtual environment.
    """
    env = os.environ.get(SHARED_DATA_ENV)
    if env:
        return [(Path(env), f"${SHARED_DATA_ENV}")]
    cwd = Path.cwd()
    out = [(cwd / "shared" / "data", "./shared/data"),
           (cwd.parent / "shared" / "data", "../shared/data")]
    if (_PROJECT_ROOT / "pyproject.toml").is_file():
        beside = _PROJECT_ROOT.parent / "shared" / "data"
        if all(beside.resolve() != c.resolve() for c, _ in out):
            out.append((beside, "beside the source checkout"))
    return out


def shared_data_dir(must_exist: bool = True) -> Path | None:
    """Where the shared stereo data is, looked for where a user keeps it.

    ``$HOPMATCH_SHARED_DATA`` when set; otherwise ``shared/data`` in the current directory,
    then ``../shared/data``, then ``../shared/data`` beside the source checkout when
    hopmatch runs from one (:func:`shared_data_candidates`). The first folder that exists
    is the answer.

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
        ``must_exist`` and the folder is absent: the message lists every place looked in
        (absolute paths) and how to point hopmatch at the data.

    Examples
    --------
    >>> path = shared_data_dir(must_exist=False)   # None when the data is absent
    >>> path is None or path.is_dir()
    True
    """
    candidates = shared_data_candidates()
    for c, _ in candidates:
        if c.is_dir():
            return c
    if not must_exist:
        return None
    where = "; ".join(f"{how}: {str(c)!r}" for c, how in candidates)
    if os.environ.get(SHARED_DATA_ENV):
        hint = (f"{SHARED_DATA_ENV} is set but names no folder; point it at the folder "
                "holding the scenes (middlebury/, aloe/, ...) or unset it to look in "
                "./shared/data and ../shared/data")
    else:
        hint = (f"put the data in shared/data under the current directory or beside it "
                f"(../shared/data), or set {SHARED_DATA_ENV} to its folder")
    raise InvalidArgumentError(
        f"the shared stereo data folder is absent (looked in {where}); {hint}")


def _scene_root(root) -> Path | None:
    if root is None:
        return shared_data_dir(must_exist=False)
    root = as_path(root, "root")
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

    Raises
    ------
    InvalidArgumentError
        ``root`` is given and is not a folder.

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
        Unknown name (the message lists the available ones), no shared data, or as
        :func:`load_scene` does.
    InvalidTypeError
        ``name`` is not a str.

    Examples
    --------
    >>> load("motorcycle").name
    'motorcycle'
    """
    if not isinstance(name, str):
        raise InvalidTypeError(f"`name` must be a scene name (str), got {describe(name)}")
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
