"""Feature layer: Canny-Deriche gradient, Moravec points (SPEC section 1) and the
cv2 Feature2D-like :class:`DericheMoravecDetector`."""

from .descriptor import gradient_windows
from .detector import DericheMoravecDetector
from .gradient import deriche_gradient
from .moravec import moravec_points, moravec_response

__all__ = [
    "DericheMoravecDetector",
    "deriche_gradient",
    "gradient_windows",
    "moravec_points",
    "moravec_response",
]
