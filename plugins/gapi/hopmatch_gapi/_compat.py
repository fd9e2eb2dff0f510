"""Is this OpenCV able to run Python G-API custom operations?"""

from __future__ import annotations

import cv2

#: What to install when the check fails.
INSTALL_HINT = "pip install 'hopmatch[gapi]' (it caps OpenCV at 4.x: >=4.8,<5)"


def missing_gapi_features() -> list[str]:
    """The names this plugin needs from ``cv2`` that this OpenCV lacks (empty: all present)."""
    needed = {
        "cv2.GComputation": getattr(cv2, "GComputation", None),
        "cv2.GMat": getattr(cv2, "GMat", None),
        "cv2.GArray": getattr(cv2, "GArray", None),
        "cv2.gapi.op": getattr(getattr(cv2, "gapi", None), "op", None),
        "cv2.gapi.kernel": getattr(getattr(cv2, "gapi", None), "kernel", None),
        "cv2.gapi.kernels": getattr(getattr(cv2, "gapi", None), "kernels", None),
        "cv2.empty_array_desc": getattr(cv2, "empty_array_desc", None),
    }
    return [name for name, value in needed.items() if value is None]


def require_gapi() -> None:
    """Raise ``ImportError`` saying what is missing and what to install, if anything is."""
    missing = missing_gapi_features()
    if missing:
        raise ImportError(
            f"hopmatch_gapi needs OpenCV's Python G-API custom operations, which OpenCV "
            f"{cv2.__version__} does not provide (missing: {', '.join(missing)}; the OpenCV 5 "
            f"wheels ship without them). Install the newest OpenCV 4.x: {INSTALL_HINT}",
            name="hopmatch_gapi",
        )
