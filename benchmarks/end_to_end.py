"""End-to-end speed on motorcycle: detect left, detect right, match.

Run: ``python benchmarks/end_to_end.py`` (single thread; prints a Markdown table).

Peers, timed in the same run on the same images: ORB (3000 features) + BFMatcher (Hamming)
knnMatch k=2 + ratio test 0.75, and SIFT + BFMatcher (L2) knnMatch k=2 + ratio test 0.75.
Goals: hopmatch <= 1.0x ORB, <= 0.10x SIFT, under 33 ms.
"""

from __future__ import annotations

import sys
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import best_time, machine, motorcycle_bgr, single_thread  # noqa: E402

import hopmatch  # noqa: E402


def ratio_pipeline(feature, norm):
    matcher = cv2.BFMatcher(norm)

    def run(left, right):
        kl, dl = feature.detectAndCompute(left, None)
        kr, dr = feature.detectAndCompute(right, None)
        return [m for m, n in (p for p in matcher.knnMatch(dl, dr, k=2) if len(p) == 2)
                if m.distance < 0.75 * n.distance]

    return run


def main() -> None:
    single_thread()
    hopmatch.warmup()
    left, right, _ = motorcycle_bgr()
    gl = cv2.cvtColor(left, cv2.COLOR_BGR2GRAY)
    gr = cv2.cvtColor(right, cv2.COLOR_BGR2GRAY)
    orb = ratio_pipeline(cv2.ORB_create(3000), cv2.NORM_HAMMING)
    sift = ratio_pipeline(cv2.SIFT_create(), cv2.NORM_L2)

    t_hop = best_time(lambda: hopmatch.match_stereo(gl, gr), repeat=15)
    t_hop_kp = best_time(lambda: hopmatch.match_stereo(gl, gr).matches, repeat=15)
    t_orb = best_time(lambda: orb(gl, gr), repeat=15)
    t_sift = best_time(lambda: sift(gl, gr), repeat=5)
    res = hopmatch.match_stereo(gl, gr)
    print(f"Machine: {machine()}\n")
    print(f"## End to end on motorcycle ({gl.shape[1]}x{gl.shape[0]}, grey), single thread\n")
    print(f"hopmatch: {len(res.points_left)}/{len(res.points_right)} keypoints, "
          f"{len(res.query_idx)} matches; stage times (last run): "
          + ", ".join(f"{k} {v * 1e3:.1f} ms" for k, v in res.timings.items()) + "\n")
    print("| pipeline | ms | pairs/s | hopmatch / pipeline |")
    print("|---|---:|---:|---:|")
    for name, t in [("hopmatch.match_stereo (arrays)", t_hop),
                    ("hopmatch.match_stereo + cv2.DMatch objects", t_hop_kp),
                    ("ORB(3000) + BFMatcher ratio 0.75", t_orb),
                    ("SIFT + BFMatcher ratio 0.75", t_sift)]:
        print(f"| {name} | {t * 1e3:.1f} | {1 / t:.1f} | {t_hop / t:.2f} |")


if __name__ == "__main__":
    main()
