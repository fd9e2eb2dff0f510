"""Pictures of keypoints, matches and sparse disparities; plots; the paper's figures.

- :mod:`hopmatch.viz.draw`: OpenCV drawing (:func:`draw_matches`, :func:`draw_disparity`,
  :func:`draw_keypoints`).
- :mod:`hopmatch.viz.plots`: matplotlib plots (:func:`plot_energy`,
  :func:`plot_precision_vs_correct`, :func:`plot_precision_curves`,
  :func:`plot_error_histogram` and their ``render_*``
  forms returning bytes). matplotlib is imported when a plot is drawn (``pip install
  hopmatch[all]``), and pyplot's global state is never touched.
- :mod:`hopmatch.viz.figures`: the paper's Figure 5 (:func:`draw_keypoints_on_gradient`)
  and Figure 7 (:func:`draw_labelled_matches`).
- :mod:`hopmatch.viz.overview`: pictures of thousands of matches that read at 100 %
  (:func:`draw_match_overview`: a spread-out subset of matches as lines, every match as a
  dot, coloured by disparity, with a caption; :func:`draw_keypoint_disparities`: the left
  image's keypoints coloured by disparity with a colour bar in pixels). The command line
  writes these.

Every drawing function returns a new uint8 BGR image, as ``cv2.imwrite`` expects; inputs
may be grey or BGR(A), 8-bit, 16-bit or float (other depths are stretched to 0..255 for
display).

:func:`write_image_atomic` and :func:`write_text_atomic` (their home is
``hopmatch.files``, with every other writer of the package) write a file all or nothing:
the data goes to a temporary name in the destination folder and is renamed
(``os.replace``) when complete, so a failed write never leaves a partial file.

Examples
--------
>>> import numpy as np
>>> from hopmatch import viz
>>> img = np.zeros((40, 50), np.uint8)
>>> pts = np.float32([[10, 10], [30, 20]])
>>> viz.draw_matches(img, img, pts, pts, [[0, 0], [1, 1]]).shape
(40, 100, 3)
>>> viz.draw_labelled_matches(img, img, pts, pts, [[0, 0], [1, 1]], gap=4).shape
(40, 104, 3)
"""

from __future__ import annotations

from ..files import (  # noqa: F401 (kept importable from here: hopmatch.viz.write_temp...)
    encode_image,
    write_bytes_atomic,
    write_image_atomic,
    write_temp,
    write_text_atomic,
)
from .draw import (  # noqa: F401
    GREEN,
    GREY,
    RED,
    disparity_colours,
    draw_disparity,
    draw_keypoints,
    draw_matches,
)
from .figures import (  # noqa: F401
    FIGURE_LABEL,
    FIGURE_OUTLINE,
    FIGURE_POINT,
    draw_keypoints_on_gradient,
    draw_labelled_matches,
)
from .overview import (  # noqa: F401
    WRONG,
    disparity_scale,
    draw_colour_bar,
    draw_keypoint_disparities,
    draw_match_overview,
    nice_ticks,
    spread_subset,
)
from .plots import (  # noqa: F401
    ERROR_BINS,
    plot_energy,
    plot_error_histogram,
    plot_precision_curves,
    plot_precision_vs_correct,
    render_energy,
    render_error_histogram,
    render_precision_curves,
    render_precision_vs_correct,
)

__all__ = [
    "draw_disparity",
    "draw_keypoint_disparities",
    "draw_keypoints",
    "draw_keypoints_on_gradient",
    "draw_labelled_matches",
    "draw_match_overview",
    "draw_matches",
    "plot_energy",
    "plot_error_histogram",
    "plot_precision_curves",
    "plot_precision_vs_correct",
    "render_energy",
    "render_error_histogram",
    "render_precision_curves",
    "render_precision_vs_correct",
    "write_image_atomic",
    "write_text_atomic",
]
