"""Input and output of the commands: images read with errors naming the file, the output
folder staged so that a failed run leaves nothing behind, and run.json."""

from __future__ import annotations

import json
import os
import platform
from datetime import datetime, timezone
from pathlib import Path

import cv2
import numpy as np

import hopmatch

from .. import imageio
from .._files import encode_image, write_temp
from .reporting import CLIError

__all__ = ["Outputs", "image_info", "ms", "read_image", "run_json", "versions"]


def read_image(path: str) -> np.ndarray:
    """:func:`hopmatch.imageio.read_image`, its error as a :class:`CLIError`."""
    try:
        return imageio.read_image(path)
    except imageio.ImageReadError as exc:
        raise CLIError(exc.path, exc.problem) from None


class Outputs:
    """The output folder of one run: files are staged under temporary names, then renamed.

    ``open()`` creates the folder (and missing parents) and checks it is writable;
    ``add()`` writes a file under a hidden temporary name; ``commit()`` renames them all;
    ``abort()`` removes the temporary files and the folders ``open()`` created (if empty).
    """

    def __init__(self, folder: str):
        self.label = folder
        self.path = Path(folder)
        self.created: list[Path] = []
        self.staged: list[tuple[Path, Path]] = []
        self.names: list[str] = []

    def open(self) -> None:
        if self.path.exists() and not self.path.is_dir():
            raise CLIError(self.label, "exists and is not a folder")
        missing, q = [], self.path.absolute()
        while not q.exists() and q.parent != q:
            missing.append(q)
            q = q.parent
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            self._remove_created(missing)
            raise CLIError(self.label,
                           f"cannot create the folder: {imageio.os_reason(exc)}") from None
        self.created = missing
        try:
            os.unlink(write_temp(self.path, "write-test", b""))
        except OSError as exc:
            self.abort()
            raise CLIError(self.label,
                           f"cannot write in the folder: {imageio.os_reason(exc)}") from None

    def add(self, name: str, data: bytes) -> None:
        try:
            tmp = write_temp(self.path, name, data)
        except OSError as exc:
            raise CLIError(str(self.path / name),
                           f"cannot write: {imageio.os_reason(exc)}") from None
        self.staged.append((tmp, self.path / name))
        self.names.append(name)

    def add_text(self, name: str, text: str) -> None:
        self.add(name, text.encode("utf-8"))

    def add_image(self, name: str, image: np.ndarray) -> None:
        self.add(name, encode_image(image, Path(name).suffix))

    def commit(self) -> None:
        done = []
        try:
            for tmp, final in self.staged:
                os.replace(tmp, final)
                done.append(final)
        except OSError as exc:
            for final in done:
                _unlink(final)
            self.abort()
            raise CLIError(self.label, "cannot rename the finished files: "
                                       f"{imageio.os_reason(exc)}") from None
        self.staged = []

    def abort(self) -> None:
        for tmp, _ in self.staged:
            _unlink(tmp)
        self.staged = []
        self._remove_created(self.created)
        self.created = []

    @staticmethod
    def _remove_created(folders) -> None:
        for folder in folders:  # deepest first
            try:
                folder.rmdir()
            except OSError:
                break


def _unlink(path: Path) -> None:
    try:
        os.unlink(path)
    except OSError:
        pass


# --------------------------------------------------------------------------------------
# run.json
# --------------------------------------------------------------------------------------


def versions() -> dict:
    """Versions of hopmatch, OpenCV, NumPy, Numba and Python."""
    import numba

    return {
        "hopmatch": hopmatch.__version__,
        "opencv": cv2.__version__,
        "numpy": np.__version__,
        "numba": numba.__version__,
        "python": platform.python_version(),
    }


def image_info(path: str, image: np.ndarray) -> dict:
    """Absolute path, shape and dtype of an input image."""
    return {"path": str(Path(path).absolute()), "shape": list(image.shape),
            "dtype": str(image.dtype)}


def ms(seconds: float) -> float:
    """Seconds as milliseconds, rounded to the microsecond."""
    return round(seconds * 1000.0, 3)


def run_json(command: str, **sections) -> str:
    """The text of run.json: the command, when, the versions, then ``sections``."""
    doc = {"command": command, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
           "versions": versions(), **sections}
    return json.dumps(doc, indent=2, default=str) + "\n"
