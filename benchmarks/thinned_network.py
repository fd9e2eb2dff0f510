"""What a network on thinned left points costs in matches, scene by scene (issue 18).

Run: ``python benchmarks/thinned_network.py [--factor F] [--scenes NAME ...] [--smoke]``

When a pair's candidate pairs exceed ``max_neurons`` even on the range the coarse pass
found, the network runs on as many left points as fit, one per cell of a grid
(:func:`hopmatch.matching.disparity_range.run_thinned`), and the guided pass searches the
rest. The shared scenes fit their budgets; here each is matched with the defaults, then
again with ``max_neurons`` set to its band's candidate pairs divided by ``F`` and
without the narrower ranges tried first (``BUDGET_WIDENING`` emptied), so that the network
runs thinned. It prints correct matches and precision at 1 px of both (passes.py's
scoring), the left points the thinned network ran on, and the pooled counts. A scene whose
budget is then below the coarse pass's own candidates (or run_thinned's sample's) is
refused as before and printed so.

``--smoke``: motorcycle's centre crop only (figures mean nothing).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _common import add_smoke_option, single_thread, smoke_scene  # noqa: E402
from passes import score  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.errors import BudgetExceededError  # noqa: E402
from hopmatch.matching import disparity_range  # noqa: E402
from hopmatch.matching.candidates import candidate_pairs  # noqa: E402

#: One run (``both_features=False``): the network's thinning is what this measures (with
#: both feature images, a second run over the budget is left out instead).
ONE_RUN = {"both_features": False}

def band_pairs(result) -> int:
    """The candidate pairs of ``result``'s band (its range, every left point, the right
    points it detected)."""
    c = result.network.config
    n_right = result.n_detected_right or len(result.points_right)
    ni, _ = candidate_pairs(result.points_left, np.ascontiguousarray(result.points_right[:n_right]),
                            c.min_disparity, c.max_disparity, c.max_vertical, 10**10, sort=False)
    return len(ni)


def main(argv=None) -> int:
    ap = add_smoke_option(argparse.ArgumentParser(description=__doc__.splitlines()[0]))
    ap.add_argument("--factor", type=float, default=4.0,
                    help="max_neurons = the band's candidate pairs / FACTOR")
    ap.add_argument("--scenes", nargs="*", default=None)
    args = ap.parse_args(argv)
    single_thread()
    names = ["motorcycle"] if args.smoke else (args.scenes or datasets.list_scenes())
    print(f"scene | defaults correct / precision | max_neurons = pairs / {args.factor:g}: "
          "left points of the network | correct / precision")
    totals = np.zeros(4, dtype=np.int64)
    for name in names:
        scene = smoke_scene(datasets.load(name)) if args.smoke else datasets.load(name)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            full = hopmatch.match_stereo(scene.left, scene.right, **ONE_RUN)
            budget = int(band_pairs(full) / args.factor)
            widening = disparity_range.BUDGET_WIDENING
            disparity_range.BUDGET_WIDENING = ()
            try:
                thin = hopmatch.match_stereo(scene.left, scene.right, max_neurons=budget,
                                             **ONE_RUN)
            except BudgetExceededError:
                thin = None
            finally:
                disparity_range.BUDGET_WIDENING = widening
        _, c0, p0, _ = score(full.matched_left, full.matched_right, scene.disparity)
        if thin is None:
            print(f"{name} | {c0} / {p0:.3f} | refused (max_neurons={budget}) | -", flush=True)
            continue
        _, c1, p1, _ = score(thin.matched_left, thin.matched_right, scene.disparity)
        kept = thin.network.thinned
        ran = f"all {len(thin.points_left)}" if kept is None else \
            f"{len(kept)} of {len(thin.points_left)}"
        print(f"{name} | {c0} / {p0:.3f} | {ran} | {c1} / {p1:.3f}", flush=True)
        totals += [c0, 1, c1, 1]
    print(f"pooled over the {totals[1]} scenes run both ways: defaults {totals[0]} correct, "
          f"thinned {totals[2]} ({totals[2] / max(totals[0], 1):.3f}x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
