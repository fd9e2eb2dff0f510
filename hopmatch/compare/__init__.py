"""hopmatch side by side with OpenCV's matchers, on scenes with ground truth.

Every method is a small function with one signature, ``method(scene) -> MethodResult``:
it takes a :class:`~hopmatch.datasets.StereoScene` and returns the matched points
``left_pts``/``right_pts`` ((M, 2) float32, (x, y), row ``k`` of each forming match ``k``),
the ``seconds`` it took (detection on both images + matching, single thread), and the
keypoint sets the method chose from (for recall). A :class:`MethodResult` unpacks as
``left_pts, right_pts, seconds, keypoints_left, keypoints_right``. :data:`METHODS` maps the
names used by ``hopmatch eval --method`` to these functions.

Every method works on the grey pair (``cv2.COLOR_BGR2GRAY``, converted before the clock
starts) and gets the same disparity range, ``0 .. ceil(1.1 * max finite ground truth)``
(:func:`disparity_range`): what a user with a calibrated rig would set.

:func:`compare` runs methods on scenes and scores them with
:func:`hopmatch.evaluate.score_matches` at 0.5, 1 and 2 px (vertical tolerance = the
threshold); :func:`format_markdown` / :func:`format_csv` (and the atomic ``write_*``) turn
its rows into tables. ``hopmatch eval`` and ``benchmarks/quality.py`` are thin layers on
top; ``hopmatch eval --docs`` regenerates ``docs/results.md``.

Modules: :mod:`~hopmatch.compare.methods` (the methods), :mod:`~hopmatch.compare.runner`
(running and scoring), :mod:`~hopmatch.compare.tables` (tables and pictures of the rows),
:mod:`~hopmatch.compare.results_doc` (``docs/results.md``),
:mod:`~hopmatch.compare.curves` (precision against correct matches as each method's own
threshold moves); every name is importable from
``hopmatch.compare``.

Examples
--------
>>> from hopmatch import compare, datasets
>>> rows = compare.compare([datasets.load("motorcycle")], ["hopmatch", "sift-ratio"])
>>> [r["method"] for r in rows]
['hopmatch', 'sift-ratio']
>>> print(compare.format_markdown(rows))              # doctest: +SKIP
"""

from __future__ import annotations

# the public names of hopmatch.compare, from the submodules that define them
from .curves import (  # noqa: F401
    CURVE_METHODS,
    format_curves_markdown,
    precision_curves,
)
from .methods import (  # noqa: F401
    DESCRIPTIONS,
    METHODS,
    NCC_HALF,
    RATIO,
    MethodResult,
    disparity_range,
    hopfield_on_sift,
    ncc_wta,
    orb_gms,
    sgbm,
    sift_cross_check,
)
from .results_doc import (  # noqa: F401
    DOC_DRAWINGS,
    DOCS_COMMAND,
    docs_scenes,
    format_results_doc,
    machine_description,
    summary_rows,
)
from .runner import THRESHOLDS, compare, run_method  # noqa: F401
from .tables import (  # noqa: F401
    COLUMNS,
    MARKDOWN_COLUMNS,
    correct_flags,
    draw_row,
    errors_by_method,
    format_csv,
    format_markdown,
    write_csv,
    write_markdown,
)

__all__ = [
    "COLUMNS",
    "METHODS",
    "MethodResult",
    "THRESHOLDS",
    "compare",
    "disparity_range",
    "draw_row",
    "format_csv",
    "format_markdown",
    "precision_curves",
    "run_method",
    "write_csv",
    "write_markdown",
]
