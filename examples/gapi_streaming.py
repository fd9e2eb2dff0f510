"""Stereo matching as a G-API stream: a sequence of stereo pairs through one compiled graph.

Usage::

    python examples/gapi_streaming.py [--frames N] [--size WxH] [--max-disparity D]
                                      [--mode streaming|apply] [--verify]

The Middlebury scenes of the shared data (found with :func:`hopmatch.datasets.list_scenes`;
the built-in motorcycle pair when the shared data is absent) play the frames of a stereo
video: each is resized to a common size (a horizontal scale keeps a pair rectified) and
written as two lossless PNG sequences, which OpenCV reads as two video streams
(``cv.gapi.wip.make_capture_src``). ``hopmatch_gapi.stereo_graph()`` is compiled once for
streaming with ``hopmatch_gapi.kernels()`` and pulls one result per frame: the matched left
points, right points and disparities. The frame rate is printed at the end.

``--mode apply`` feeds the same frames one by one with ``GComputation.apply`` instead (the
graph is still compiled once). ``--verify`` checks every frame against a direct
``hopmatch.match_stereo`` call on the same images (exit status 1 if any differs).

Needs OpenCV 4.x (Python G-API custom operations; see docs/gapi.md).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import cv2 as cv
import numpy as np

import hopmatch
from hopmatch import datasets


def stereo_frames(n: int | None, size: tuple[int, int]):
    """``(name, left, right)`` frames: the shared Middlebury scenes (else motorcycle),
    resized to ``size`` (width, height), repeated to make ``n`` frames when asked."""
    names = [s for s in datasets.list_scenes() if s.startswith("middlebury/")] or ["motorcycle"]
    n = n or len(names)
    frames = []
    for i in range(n):
        scene = datasets.load(names[i % len(names)])
        frames.append((scene.name, cv.resize(scene.left, size, interpolation=cv.INTER_AREA),
                       cv.resize(scene.right, size, interpolation=cv.INTER_AREA)))
    return frames


def write_sequences(frames, folder: Path) -> tuple[str, str]:
    """Write the frames as ``left_0000.png``... / ``right_0000.png``...; return the
    ``cv.VideoCapture`` patterns of the two sequences."""
    for i, (_, left, right) in enumerate(frames):
        for side, image in (("left", left), ("right", right)):
            if not cv.imwrite(str(folder / f"{side}_{i:04d}.png"), image):
                raise OSError(f"cannot write frame {i} in {folder}")
    return str(folder / "left_%04d.png"), str(folder / "right_%04d.png")


def run_streaming(pattern_left: str, pattern_right: str, kernels):
    """Yield ``(matched_left, matched_right, disparities)`` per frame, pulled from a
    streaming graph fed by two image-sequence sources."""
    import hopmatch_gapi

    graph = hopmatch_gapi.stereo_graph()
    stream = graph.compileStreaming(args=cv.gapi.compile_args(kernels))
    stream.setSource(cv.gin(cv.gapi.wip.make_capture_src(pattern_left),
                            cv.gapi.wip.make_capture_src(pattern_right)))
    stream.start()
    try:
        while True:
            ok, out = stream.pull()
            if not ok:
                break
            yield hopmatch_gapi.as_arrays(*out)
    finally:
        stream.stop()


def run_apply(frames, kernels):
    """Yield the same as :func:`run_streaming`, one ``GComputation.apply`` per frame."""
    import hopmatch_gapi

    graph = hopmatch_gapi.stereo_graph()
    args = cv.gapi.compile_args(kernels)
    for _, left, right in frames:
        yield hopmatch_gapi.as_arrays(*graph.apply(cv.gin(left, right), args=args))


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WxH such as 384x288, got {text!r}") from None
    if w < 32 or h < 32:
        raise argparse.ArgumentTypeError(f"the frame size must be at least 32x32, got {text!r}")
    return w, h


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=None,
                        help="number of frames (default: one per scene found)")
    parser.add_argument("--size", type=_size, default=(384, 288), help="frame size WxH")
    parser.add_argument("--max-disparity", type=float, default=None,
                        help="matcher max_disparity (default: a quarter of the width)")
    parser.add_argument("--mode", choices=("streaming", "apply"), default="streaming")
    parser.add_argument("--verify", action="store_true",
                        help="compare every frame with hopmatch.match_stereo")
    args = parser.parse_args(argv)
    if args.frames is not None and args.frames < 1:
        parser.error("--frames must be at least 1")

    try:
        import hopmatch_gapi
    except ImportError as exc:
        print(f"gapi_streaming: {exc}", file=sys.stderr)
        return 2

    params = {} if args.max_disparity is None else {"max_disparity": args.max_disparity}
    kernels = hopmatch_gapi.kernels(**params)
    frames = stereo_frames(args.frames, args.size)
    w, h = args.size
    print(f"{len(frames)} frames of {w}x{h} ({args.mode} mode)")
    hopmatch.warmup()  # Numba kernels loaded before timing

    differ = 0
    with tempfile.TemporaryDirectory(prefix="hopmatch-gapi-") as tmp:
        if args.mode == "streaming":
            results = run_streaming(*write_sequences(frames, Path(tmp)), kernels)
        else:
            results = run_apply(frames, kernels)
        t0 = time.perf_counter()
        t_first = None
        n = 0
        for (name, left, right), (ml, mr, disp) in zip(frames, results):
            n += 1
            if t_first is None:
                t_first = time.perf_counter() - t0
            line = f"frame {n - 1}: {name}: {len(disp)} matches"
            if len(disp):
                line += f", median disparity {float(np.median(disp)):g} px"
            if args.verify:
                if args.mode == "streaming":  # what the capture source decoded
                    left = cv.imread(str(Path(tmp) / f"left_{n - 1:04d}.png"))
                    right = cv.imread(str(Path(tmp) / f"right_{n - 1:04d}.png"))
                ref = hopmatch.match_stereo(left, right, **params)
                same = all(np.array_equal(a, b) for a, b in zip(
                    (ml, mr, disp), (ref.matched_left, ref.matched_right, ref.disparities)))
                differ += not same
                line += ", identical to match_stereo" if same else ", DIFFERS from match_stereo"
            print(line, flush=True)
        elapsed = time.perf_counter() - t0

    fps = n / elapsed if elapsed > 0 else float("inf")
    print(f"{n} frames in {elapsed:.2f} s: {fps:.1f} frames per second"
          + (" (including --verify)" if args.verify else ""))
    if n > 1 and t_first is not None and not args.verify:
        print(f"after the first frame (graph compilation: {t_first * 1000:.0f} ms): "
              f"{(n - 1) / max(elapsed - t_first, 1e-9):.1f} frames per second")
    if n != len(frames):
        print(f"error: the graph gave {n} results for {len(frames)} frames", file=sys.stderr)
        return 1
    if differ:
        print(f"error: {differ} frame(s) differ from hopmatch.match_stereo", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
