"""Match quality side by side: hopmatch and OpenCV's matchers on scenes with ground truth.

Run: ``python benchmarks/quality.py [SCENE ...] [--method NAME ...]`` (default: motorcycle,
every method). Prints the Markdown table (scene x method: matches, correct@1,
precision@1, recall@1, time ms; single thread). The runner is :mod:`hopmatch.compare`,
the same as ``hopmatch eval``, which also writes the CSV and plots;
``hopmatch eval --docs`` regenerates ``docs/results.md``. ``--smoke``: every method on a
240 x 160 crop of each scene (a check that the script works; figures meaningless).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_smoke_option, machine, smoke_scene  # noqa: E402

from hopmatch import compare, datasets  # noqa: E402


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=["motorcycle"], metavar="SCENE",
                        help="'motorcycle' or a folder of ../shared/data, e.g. middlebury/tsukuba")
    parser.add_argument("--method", action="append", choices=list(compare.METHODS),
                        help="method to run (repeatable; default: all)")
    args = add_smoke_option(parser).parse_args(argv)
    scenes = args.scenes
    if args.smoke:
        scenes = [smoke_scene(datasets.load(name)) for name in scenes]
    rows = compare.compare(scenes, args.method,
                           progress=lambda msg: print(f"  {msg}", file=sys.stderr))
    print(f"Machine: {machine()}\n")
    print(compare.format_markdown(rows))


if __name__ == "__main__":
    main()
