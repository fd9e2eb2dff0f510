"""Fingerprint of the default matches on motorcycle and every shared scene.

Prints two lines per scene, ``name mode n_left n_right n_matches sha256``: mode
``defaults`` is ``match_stereo(left, right)`` with no parameters, mode ``range`` is the
same with the scene's disparity range (``hopmatch.compare.disparity_range``). The digest
covers the left and right points, responses, match indices and distances bit for bit.
Run it before and after a change that should not alter behaviour and diff the two
outputs (``python benchmarks/fingerprint.py > before.txt``, change, ``... > after.txt``,
``diff before.txt after.txt``). ``--scenes`` picks scenes; the default is motorcycle and
every scene ``hopmatch.datasets.list_scenes()`` finds; ``--smoke``: motorcycle and, when
present, Middlebury tsukuba (a check that the script works; its lines are those of the
full run for these scenes).
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, smoke_scenes  # noqa: E402

import hopmatch  # noqa: E402
from hopmatch import datasets  # noqa: E402
from hopmatch.compare import disparity_range  # noqa: E402


def fingerprint(res) -> str:
    h = hashlib.sha256()
    for a in (res.points_left, res.points_right, res.responses_left, res.responses_right,
              res.query_idx, res.train_idx, res.distances):
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode() + str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", default=None)
    args = add_smoke_option(ap).parse_args(argv)
    names = args.scenes
    if names is None:
        names = ["motorcycle"] + [s for s in datasets.list_scenes() if s != "motorcycle"]
        if args.smoke:
            names = smoke_scenes(names)
    for name in names:
        scene = datasets.load(name)
        for mode, params in (("defaults", {}),
                             ("range", {"max_disparity": disparity_range(scene)})):
            res = hopmatch.match_stereo(scene.left, scene.right, **params)
            print(f"{name:28s} {mode:8s} {len(res.points_left):6d} {len(res.points_right):6d}"
                  f" {len(res.query_idx):6d}  {fingerprint(res)}", flush=True)


if __name__ == "__main__":
    main()
