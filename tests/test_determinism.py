"""Determinism and thread safety: the same input and seed give identical keypoints and
matches across repeated calls, separate processes and concurrent threads; no compiled
kernel sums floats in a loop whose vectorisation depends on where its buffers lie in
memory; and the kernels run once under NUMBA_BOUNDSCHECK=1 (the CI run that catches
out-of-bounds reads)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np

import hopmatch
from hopmatch import DericheMoravecDetector, HopfieldMatcher

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _pair(seed=5, h=180, w=240, shift=7):
    rng = np.random.default_rng(seed)
    left = cv2.GaussianBlur((rng.random((h, w)) * 255).astype(np.uint8), (0, 0), 1.3)
    return left, np.roll(left, -shift, axis=1)


LEFT, RIGHT = _pair()
PARAMS = {"max_disparity": 16, "seed": 11}


def _signature(res):
    """Everything that must not change between runs, as plain lists."""
    return {
        "left": res.points_left.tolist(), "right": res.points_right.tolist(),
        "q": res.query_idx.tolist(), "t": res.train_idx.tolist(),
        "d": res.distances.tolist(), "state": res.network.state.tolist(),
        "iterations": res.network.iterations,
    }


def _stereo(left=LEFT, right=RIGHT, **params):
    return _signature(hopmatch.match_stereo(left, right, **{**PARAMS, **params}))


def test_repeated_calls_are_identical():
    first = _stereo()
    assert len(first["q"]) > 50
    for _ in range(3):
        assert _stereo() == first


def test_the_seed_matters_and_is_reproducible():
    a, b = _stereo(seed=1), _stereo(seed=2)
    assert a["iterations"] > 0
    assert _stereo(seed=1) == a and _stereo(seed=2) == b


def test_separate_processes_agree():
    code = textwrap.dedent("""
        import json, sys
        sys.path.insert(0, %r)
        from tests.test_determinism import _stereo
        print(json.dumps(_stereo()))
    """ % ROOT)
    outs = []
    for hashseed in ("0", "12345"):  # and a different hash seed per process
        env = {**os.environ, "PYTHONHASHSEED": hashseed}
        proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env=env, cwd=ROOT, timeout=600)
        assert proc.returncode == 0, proc.stderr[-2000:]
        outs.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    here = json.loads(json.dumps(_stereo()))  # same float -> JSON round trip
    assert outs[0] == outs[1] == here


def test_threads_sharing_one_detector_and_one_matcher():
    """The documented sharing (docs/robustness.md): parameters and pair info set once, then
    any number of threads call detect/compute/match/knnMatch on the same objects."""
    det = DericheMoravecDetector()
    kp_l, d_l = det.detectAndCompute(LEFT, None)
    kp_r, d_r = det.detectAndCompute(RIGHT, None)
    matcher = HopfieldMatcher(max_disparity=16, seed=3)
    matcher.setPairInfo(kp_l, kp_r, LEFT.shape[::-1], RIGHT.shape[::-1])

    def key(m):
        return [(d.queryIdx, d.trainIdx, d.distance) for d in m]

    ref_match = key(matcher.match(d_l, d_r))
    ref_knn = [key(r) for r in matcher.knnMatch(d_l, d_r, k=2)]
    ref_pts = [kp.pt for kp in det.detect(LEFT)]

    def work(i):
        pts = [kp.pt for kp in det.detect(LEFT)]
        if i % 2:
            return pts, key(matcher.match(d_l, d_r)), None
        return pts, None, [key(r) for r in matcher.knnMatch(d_l, d_r, k=2)]

    with ThreadPoolExecutor(max_workers=4) as pool:
        results = list(pool.map(work, range(12)))
    for pts, match, knn in results:
        assert pts == ref_pts
        assert match is None or match == ref_match
        assert knn is None or knn == ref_knn


def test_threads_with_separate_pairs_use_their_own_matchers():
    pairs = [_pair(seed=s, shift=3 + s) for s in range(4)]
    serial = [_stereo(lft, rgt) for lft, rgt in pairs]
    with ThreadPoolExecutor(max_workers=4) as pool:
        threaded = list(pool.map(lambda p: _stereo(*p), pairs * 2))
    assert threaded == serial * 2


def test_clone_gives_an_independent_matcher_for_a_thread():
    m = HopfieldMatcher(max_disparity=16)
    m.setPairInfo(np.zeros((2, 2), np.float32), np.zeros((2, 2), np.float32))
    c = m.clone()
    c.setPairInfo(np.zeros((5, 2), np.float32), np.zeros((5, 2), np.float32))
    assert len(m.clone()._pair[0]) == 2  # the original is untouched


BOUNDSCHECK_SCRIPT = textwrap.dedent("""
    import numba, numpy as np, cv2, warnings
    import hopmatch
    from hopmatch import DericheMoravecDetector, HopfieldMatcher, hopfield_match
    from hopmatch._config import CACHE
    assert numba.config.BOUNDSCHECK == 1, numba.config.BOUNDSCHECK
    assert not CACHE  # compiled fresh, with the checks in
    warnings.simplefilter("ignore")
    hopmatch.warmup()
    rng = np.random.default_rng(0)
    det = DericheMoravecDetector(nms_size=3)
    # edge shapes for the Moravec kernels: below, at and just above the border margin
    for shape in [(1, 1), (1, 9), (5, 5), (6, 7), (7, 7), (8, 3), (40, 2), (33, 47)]:
        img = (rng.random(shape) * 255).astype(np.uint8)
        for ws in (1, 3, 5):
            hopmatch.moravec_response(img, ws)
        DericheMoravecDetector(window_size=5, nms_size=1).detectAndCompute(img, None)
        det.detectAndCompute(img, None)
    v = hopmatch.moravec_response((rng.random((30, 30)) * 255).astype(np.uint8), 3)
    hopmatch.moravec_points(v, nms_size=999, margin=20)
    hopmatch.moravec_points(v, nms_size=1, margin=0, subpixel=True)
    # windows leaving the image (border replicated), NaN centres (the kernel's, past the
    # public function's checks), 1 x 1 images
    from hopmatch.feature.descriptor import cut_windows
    far = np.float32([[-40.5, 3.2], [0, 0], [29.9, 29.9], [75, -8.25], [np.nan, 4]])
    for size in (1, 3, 9):
        cut_windows(v, far, size)
        cut_windows(v[:1, :1], far, size)
    # candidate output growing past its first allocation, up to the budget and over it
    from hopmatch.matching.network import candidate_pairs
    many = np.c_[rng.uniform(0, 500, 3000), rng.uniform(0, 3, 3000)].astype(np.float32)
    n = len(candidate_pairs(many[:20], many, 0.0, 300.0, 1.0, 10**7)[0])
    candidate_pairs(many[:20], many, 0.0, 300.0, 1.0, n)
    try:
        candidate_pairs(many[:20], many, 0.0, 300.0, 1.0, n - 1)
    except hopmatch.errors.BudgetExceededError:
        pass
    # network kernels: empty sides, single points, duplicates, zero neighbourhoods,
    # epipolar candidates, binary descriptors, energy traces, tiny iteration budgets
    pts = rng.uniform(0, 60, (50, 2)).astype(np.float32)
    desc = rng.normal(size=(50, 9)).astype(np.float32)
    bits = (rng.random((50, 4)) * 255).astype(np.uint8)
    cases = [
        (pts[:0], pts, desc[:0], desc, {}),
        (pts, pts[:0], desc, desc[:0], {}),
        (pts[:1], pts[:1], desc[:1], desc[:1], {}),
        (np.repeat(pts[:3], 5, axis=0), pts[:15], np.repeat(desc[:3], 5, axis=0), desc[:15], {}),
        (pts, pts, desc, desc, {"neighbour_width": 0.0, "neighbour_height": 0.0}),
        (pts, pts, desc, desc, {"max_iterations": 1, "record_energy": True}),
        (pts, pts, desc, desc, {"preset": "paper", "max_candidates": 2}),
        (pts, pts, bits, bits, {"similarity_gate": None}),
        (pts, pts, desc, desc,
         {"fundamental_matrix": np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0.0]])}),
        (np.float32([[0, 0], [2**20, 2**20]]), np.float32([[0, 0], [2**20, 2**20]]),
         desc[:2], desc[:2], {"neighbour_width": 0.0}),
    ]
    for left, right, dl, dr, extra in cases:
        res = hopfield_match(left, right, dl, dr, max_disparity=8.0, **extra)
        assert (res.query_idx < max(len(left), 1)).all()
    m = HopfieldMatcher(max_disparity=8)
    m.setPairInfo(pts, pts)
    m.knnMatch(desc, desc, k=3)
    m.radiusMatch(desc, desc, 0.5)
    img = cv2.GaussianBlur((rng.random((120, 160)) * 255).astype(np.uint8), (0, 0), 1.2)
    hopmatch.match_stereo(img, np.roll(img, -4, axis=1), max_disparity=8)
    print("BOUNDSCHECK OK")
""")


def test_kernels_under_numba_boundscheck(tmp_path):
    """The CI run of every kernel with NUMBA_BOUNDSCHECK=1 and a fresh (uncached) compile:
    an out-of-bounds read that the fast build would hide raises IndexError here."""
    env = {**os.environ, "NUMBA_BOUNDSCHECK": "1", "HOPMATCH_NUMBA_CACHE": "0",
           "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    env.pop("NUMBA_DISABLE_JIT", None)
    proc = subprocess.run([sys.executable, "-c", BOUNDSCHECK_SCRIPT], capture_output=True,
                          text=True, env=env, cwd=str(tmp_path), timeout=900)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert "BOUNDSCHECK OK" in proc.stdout


REDUCTIONS_SCRIPT = textwrap.dedent("""
    import importlib, json, pkgutil, sys
    import numba, numpy as np
    sys.path.insert(0, sys.argv[1])
    from vector_reductions import memory_dependent_reductions
    import hopmatch
    import hopmatch._kernels as kernels
    from hopmatch._config import CACHE
    assert not CACHE  # compiled here: Numba inspects no code loaded from its cache

    def stores_and_sums(a, b, out):  # the pattern the scan must find (control)
        total = 0.0
        for i in range(a.shape[0]):
            out[i] = 2.0 * a[i]
            total += out[i] * b[i]
        return total

    x = np.ones(64)
    control = {}
    for fastmath in (True, False):
        k = numba.njit(fastmath=fastmath)(stores_and_sums)
        k(x, x, np.empty(64))
        control[str(fastmath)] = len(memory_dependent_reductions(k.inspect_llvm(k.signatures[0])))
    hopmatch.warmup(1)
    found, scanned, uncompiled = [], [], []
    for info in pkgutil.iter_modules(kernels.__path__):
        module = importlib.import_module("hopmatch._kernels." + info.name)
        for name, f in sorted(vars(module).items()):
            if isinstance(f, numba.core.registry.CPUDispatcher) and f.__module__ == module.__name__:
                if not f.signatures and f.targetoptions.get("inline") != "always":
                    uncompiled.append(info.name + "." + name)  # (inlined ones are in callers)
                for sig in f.signatures:
                    scanned.append(info.name + "." + name)
                    found += [[info.name + "." + name, loop] for _, loop in
                              memory_dependent_reductions(f.inspect_llvm(sig))]
    print(json.dumps({"control": control, "scanned": scanned, "found": found,
                      "uncompiled": uncompiled}))
""")


def test_no_kernel_sums_in_a_loop_vectorised_behind_a_memory_check(tmp_path):
    """Every kernel compiled fresh (as a first run does), its LLVM IR scanned for a float
    reduction in a vector loop entered only when a runtime check finds its buffers apart
    (tests/vector_reductions.py): there the sum's order, and its last bits, would depend
    on the heap's layout from one call to the next (as the guided pass's row search did
    before it was compiled exact: fields 1 ulp apart between runs, with two threads). The
    scan finds the pattern in a fastmath control kernel and not in its exact twin, and
    every kernel not inlined into others has been compiled, so none escapes it."""
    env = {**os.environ, "HOPMATCH_NUMBA_CACHE": "0", "HOPMATCH_COMPILE_HELPER": "0",
           "HOPMATCH_COMPILE_NOTICE": "0", "NUMBA_CACHE_DIR": str(tmp_path / "numba-cache")}
    for name in ("NUMBA_DISABLE_JIT", "NUMBA_BOUNDSCHECK"):
        env.pop(name, None)
    proc = subprocess.run([sys.executable, "-c", REDUCTIONS_SCRIPT,
                           os.path.join(ROOT, "tests")], capture_output=True, text=True,
                          env=env, cwd=str(tmp_path), timeout=900)
    assert proc.returncode == 0, proc.stderr[-4000:]
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    assert report["control"] == {"True": 1, "False": 0}
    assert {"guided.row_search", "refine.refine_rows", "similarity.normalised_difference",
            "network.run_network", "deriche.deriche_pass"} <= set(report["scanned"])
    assert report["uncompiled"] == []  # warmup compiles every kernel: all are scanned
    assert report["found"] == []
