"""HopfieldMatcher and match_stereo: the cv2 DescriptorMatcher-like contract."""

from __future__ import annotations

import pickle

import cv2
import numpy as np
import pytest

import hopmatch
from hopmatch import DericheMoravecDetector, HopfieldMatcher
from hopmatch.errors import (
    BudgetExceededError,
    InvalidArgumentError,
    InvalidTypeError,
    PairInfoError,
)

SHIFT = 7


@pytest.fixture(scope="module")
def pair():
    """A textured image and a copy shifted left by SHIFT px: disparity SHIFT everywhere."""
    rng = np.random.default_rng(11)
    img = cv2.GaussianBlur((rng.random((160, 220)) * 255).astype(np.uint8), (0, 0), 1.2)
    img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX)
    right = np.zeros_like(img)
    right[:, :-SHIFT] = img[:, SHIFT:]
    return img, right


@pytest.fixture(scope="module")
def features(pair):
    det = DericheMoravecDetector()
    kl, dl = det.detectAndCompute(pair[0], None)
    kr, dr = det.detectAndCompute(pair[1], None)
    return kl, dl, kr, dr


def _matcher(features, **params):
    kl, dl, kr, dr = features
    m = HopfieldMatcher.create(max_disparity=20, **params)
    m.setPairInfo(kl, kr, (220, 160), (220, 160))
    return m


def test_match_returns_dmatches_with_the_true_disparity(features):
    kl, dl, kr, dr = features
    m = _matcher(features)
    matches = m.match(dl, dr)
    assert len(matches) > 0.5 * len(kl)
    assert all(isinstance(x, cv2.DMatch) for x in matches)
    q = [x.queryIdx for x in matches]
    t = [x.trainIdx for x in matches]
    assert q == sorted(q) and len(set(q)) == len(q) and len(set(t)) == len(t)
    d = np.array([kl[a].pt[0] - kr[b].pt[0] for a, b in zip(q, t)])
    assert np.mean(np.abs(d - SHIFT) <= 1) > 0.97
    assert all(0.0 <= x.distance <= 1.0 for x in matches)


def test_points_as_arrays_equal_keypoints(features):
    kl, dl, kr, dr = features
    a = _matcher(features).match(dl, dr)
    m = HopfieldMatcher(max_disparity=20)
    m.setPairInfo(cv2.KeyPoint_convert(kl), cv2.KeyPoint_convert(kr))
    b = m.match(dl, dr)
    assert [(x.queryIdx, x.trainIdx) for x in a] == [(x.queryIdx, x.trainIdx) for x in b]


def test_results_work_with_cv2(pair, features):
    kl, dl, kr, dr = features
    m = _matcher(features)
    matches = m.match(dl, dr)
    img = cv2.drawMatches(pair[0], kl, pair[1], kr, matches, None)
    assert img.shape[1] == 440
    knn = m.knnMatch(dl, dr, k=2)
    img2 = cv2.drawMatchesKnn(pair[0], kl, pair[1], kr, knn[:50], None)
    assert img2.shape[0] == 160
    pl = np.float32([kl[x.queryIdx].pt for x in matches])
    pr = np.float32([kr[x.trainIdx].pt for x in matches])
    F, inliers = cv2.findFundamentalMat(pl, pr, cv2.FM_RANSAC, 1.0, 0.999)
    assert F.shape == (3, 3) and inliers.mean() > 0.9


def test_knn_match_and_ratio_test(features):
    kl, dl, kr, dr = features
    m = _matcher(features)
    knn = m.knnMatch(dl, dr, k=2)
    assert len(knn) == len(kl)
    assert all(len(row) == 2 for row in knn)
    for row in knn:
        assert row[0].distance <= row[1].distance
        assert row[0].queryIdx == row[1].queryIdx
    good = [a for a, b in knn if a.distance < 0.75 * b.distance]
    d = np.array([kl[x.queryIdx].pt[0] - kr[x.trainIdx].pt[0] for x in good])
    assert len(good) > 0.5 * len(kl) and np.mean(np.abs(d - SHIFT) <= 1) > 0.95
    compact = m.knnMatch(dl, dr, k=1, compactResult=True)
    assert all(len(row) == 1 for row in compact)


def test_radius_match(features):
    kl, dl, kr, dr = features
    m = _matcher(features)
    rows = m.radiusMatch(dl, dr, 0.2)
    assert len(rows) == len(kl)
    assert all(x.distance <= 0.2 for row in rows for x in row)
    assert sum(len(r) for r in rows) > 0


def test_mask_forbids_pairs(features):
    kl, dl, kr, dr = features
    m = _matcher(features)
    full = m.match(dl, dr)
    mask = np.ones((len(kl), len(kr)), np.uint8)
    banned = full[0]
    mask[banned.queryIdx, banned.trainIdx] = 0
    out = m.match(dl, dr, mask)
    assert (banned.queryIdx, banned.trainIdx) not in {(x.queryIdx, x.trainIdx) for x in out}
    assert m.match(dl, dr, np.zeros((len(kl), len(kr)), bool)) == ()
    assert m.isMaskSupported()


def test_determinism_and_seed(features):
    kl, dl, kr, dr = features
    a = _matcher(features, seed=5).match(dl, dr)
    b = _matcher(features, seed=5).match(dl, dr)
    assert [(x.queryIdx, x.trainIdx, x.distance) for x in a] == \
        [(x.queryIdx, x.trainIdx, x.distance) for x in b]


def test_energy_and_trace(features):
    kl, dl, kr, dr = features
    m = _matcher(features, initial_bias=None)
    res = m.run(dl, dr, record_energy=True)
    assert res.energy_trace[0] == 0.0
    assert np.all(np.diff(res.energy_trace) <= 1e-9)
    assert m.energy() == pytest.approx(res.energy_trace[-1], abs=1e-6)
    assert res.converged


def test_pair_info_errors(features):
    kl, dl, kr, dr = features
    m = HopfieldMatcher()
    with pytest.raises(PairInfoError, match="setPairInfo"):
        m.match(dl, dr)
    m.setPairInfo(kl, kr)
    with pytest.raises(PairInfoError, match="disagree"):
        m.match(dl[:-1], dr)
    m.clearPairInfo()
    assert m.empty()
    with pytest.raises(InvalidArgumentError, match=r"\(N, 2\)"):
        m.setPairInfo(np.zeros((5, 3)), np.zeros((5, 2)))
    with pytest.raises(InvalidArgumentError, match="NaN"):
        m.setPairInfo(np.full((5, 2), np.nan), np.zeros((5, 2)))
    with pytest.raises(InvalidTypeError, match="queryImageSize"):
        m.setPairInfo(kl, kr, "640x480")
    m.setPairInfo(kl, kr)
    with pytest.raises(InvalidArgumentError, match="same type"):
        m.match(dl, dr[:, :10].copy())
    with pytest.raises(InvalidArgumentError, match="mask"):
        m.match(dl, dr, np.ones((3, 3), np.uint8))


@pytest.mark.parametrize(
    "kwargs, exc, words",
    [
        ({"preset": "fast"}, InvalidArgumentError, "'default', 'paper'"),
        ({"theta": -1}, InvalidArgumentError, "theta"),
        ({"slope": 0}, InvalidArgumentError, "slope"),
        ({"seed": -3}, InvalidArgumentError, "seed"),
        ({"max_iterations": 0}, InvalidArgumentError, "max_iterations"),
        ({"max_disparity": "big"}, InvalidTypeError, "max_disparity"),
        ({"neighbour_widht": 3}, InvalidArgumentError, "neighbour_widht"),
        ({"vertical_check": "some"}, InvalidArgumentError, "'multiple', 'all'"),
        ({"vertical_check": True}, InvalidTypeError, "vertical_check"),
    ],
)
def test_invalid_parameters(kwargs, exc, words):
    with pytest.raises(exc, match=words):
        HopfieldMatcher(**kwargs)


def test_budget_refuses_before_allocating(features):
    kl, dl, kr, dr = features
    m = _matcher(features, max_neurons=10)
    with pytest.raises(BudgetExceededError, match="max_neurons"):
        m.match(dl, dr)
    m = _matcher(features, max_interactions=10)
    with pytest.raises(BudgetExceededError, match="max_interactions"):
        m.match(dl, dr)


def test_presets_and_accessors():
    m = HopfieldMatcher(preset="paper")
    assert m.getTheta() == 10.0 and m.getStableIterations() == 200
    m.setPreset("default")
    assert m.getTheta() == HopfieldMatcher().getTheta()
    assert HopfieldMatcher(preset="paper", theta=3).getTheta() == 3.0
    assert HopfieldMatcher(preset="paper").getVerticalCheck() == "multiple"
    assert HopfieldMatcher().getVerticalCheck() == "all"
    m.setMaxDisparity(64)
    assert m.getMaxDisparity() == 64.0


def test_housekeeping(features, tmp_path):
    kl, dl, kr, dr = features
    m = _matcher(features, theta=4.0)
    twin = m.clone()
    assert twin.get_params() == m.get_params() and not twin.empty()
    assert m.clone(emptyTrainData=True).empty()
    path = tmp_path / "m.yml"
    m.write(path)
    other = HopfieldMatcher()
    other.read(path)
    assert other.get_params() == m.get_params()
    assert pickle.loads(pickle.dumps(m)).get_params() == m.get_params()
    assert "." not in m.getDefaultName() and "theta=4.0" in repr(m)
    m.clear()
    assert m.empty() and m.getLastResult() is None


def test_read_overwrites_every_parameter_none_included(tmp_path):
    # as cv2's read: the file's values replace the object's, a None (stored as a mark) too
    path = tmp_path / "defaults.yml"
    HopfieldMatcher().write(path)
    m = HopfieldMatcher(max_disparity=50, min_disparity=3, theta=4.0)
    m.read(path)
    assert m.get_params() == HopfieldMatcher().get_params()
    assert m.getMaxDisparity() is None and m.getMinDisparity() is None


def _key(rows):
    return [[(x.queryIdx, x.trainIdx, x.imgIdx, x.distance) for x in row] for row in rows]


def test_the_train_collection_as_cv2s(features):
    # cv2's collection form: add([train]), train(), match(query) - the same matches as
    # match(query, train), with imgIdx 0
    kl, dl, kr, dr = features
    m = _matcher(features)
    two_args = m.match(dl, dr)
    knn_two, radius_two = m.knnMatch(dl, dr, k=2), m.radiusMatch(dl, dr, 0.5)
    assert m.getTrainDescriptors() == []
    m.add([dr])
    m.train()
    assert len(m.getTrainDescriptors()) == 1
    assert np.array_equal(m.getTrainDescriptors()[0], dr)
    assert m.getTrainDescriptors()[0] is not dr  # a copy, as documented
    assert _key([m.match(dl)]) == _key([two_args])
    assert all(x.imgIdx == 0 for x in two_args)  # as BFMatcher, in every form
    assert all(x.imgIdx == 0 for rows in (knn_two, radius_two) for row in rows for x in row)
    assert _key(m.knnMatch(dl, 2)) == _key(knn_two)  # cv2's knnMatch(query, k)
    assert _key(m.knnMatch(dl, k=2)) == _key(knn_two)
    assert _key(m.radiusMatch(dl, 0.5)) == _key(radius_two)  # radiusMatch(query, maxDist)
    # given train descriptors win over the collection
    other = _matcher(features)
    other.add([np.zeros_like(dr)])
    assert _key([other.match(dl, dr)]) == _key([two_args])
    # one stereo pair: a second image is refused, by name
    with pytest.raises(InvalidArgumentError, match="clear"):
        m.add([dr])
    with pytest.raises(InvalidArgumentError, match="list of 2"):
        HopfieldMatcher().add([dr, dr])
    with pytest.raises(InvalidTypeError, match="descriptors"):
        HopfieldMatcher().add(["not an array"])
    twin = m.clone()
    assert len(twin.getTrainDescriptors()) == 1 and not twin.empty()
    assert _key([twin.match(dl)]) == _key([two_args])
    bare = m.clone(emptyTrainData=True)
    assert bare.getTrainDescriptors() == [] and bare.empty()
    m.clear()
    assert m.getTrainDescriptors() == [] and m.empty()


def test_the_collection_alone_makes_a_matcher_non_empty_and_is_needed(features):
    kl, dl, kr, dr = features
    m = HopfieldMatcher()
    assert m.empty()
    m.add(dr)  # the array itself, as well as a list of one
    assert not m.empty()
    with pytest.raises(PairInfoError, match="setPairInfo"):
        m.match(dl)
    with pytest.raises(PairInfoError, match="add"):
        _matcher(features).match(dl)
    with pytest.raises(InvalidTypeError, match="`k`"):
        _matcher(features).knnMatch(dl, dr)
    with pytest.raises(InvalidTypeError, match="maxDistance"):
        _matcher(features).radiusMatch(dl, dr)


def test_save_load_and_clear_as_cv2_algorithm(tmp_path):
    for obj in (HopfieldMatcher(theta=4.0), DericheMoravecDetector(nms_size=5)):
        path = tmp_path / f"{obj.getDefaultName()}.yml"
        obj.save(str(path))
        other = type(obj)()
        other.load(str(path))
        assert other.get_params() == obj.get_params()
        fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
        assert not fs.getNode(obj.getDefaultName()).empty()  # under the default name
        fs.release()
    det = DericheMoravecDetector()
    det.clear()  # cv2.Algorithm.clear: nothing to forget
    assert not det.empty()


def test_sift_descriptors_are_accepted(pair):
    sift = cv2.SIFT_create(500)
    kl, dl = sift.detectAndCompute(pair[0], None)
    kr, dr = sift.detectAndCompute(pair[1], None)
    m = HopfieldMatcher(max_disparity=20)
    m.setPairInfo(kl, kr)
    matches = m.match(dl, dr)
    d = np.array([kl[x.queryIdx].pt[0] - kr[x.trainIdx].pt[0] for x in matches])
    assert len(matches) > 50 and np.mean(np.abs(d - SHIFT) <= 1) > 0.95


def test_orb_binary_descriptors_are_accepted(pair):
    orb = cv2.ORB_create(800)
    kl, dl = orb.detectAndCompute(pair[0], None)
    kr, dr = orb.detectAndCompute(pair[1], None)
    m = HopfieldMatcher(max_disparity=20)
    m.setPairInfo(kl, kr)
    matches = m.match(dl, dr)
    d = np.array([kl[x.queryIdx].pt[0] - kr[x.trainIdx].pt[0] for x in matches])
    assert len(matches) > 20 and np.mean(np.abs(d - SHIFT) <= 1) > 0.9


def test_match_stereo(pair):
    res = hopmatch.match_stereo(pair[0], pair[1], max_disparity=20)
    assert len(res.matches) > 50
    assert np.mean(np.abs(res.disparities - SHIFT) <= 1) > 0.97
    assert res.matched_left.dtype == np.float32 and res.disparities.dtype == np.float32
    assert all(isinstance(k, cv2.KeyPoint) for k in res.keypoints_left[:5])
    assert set(res.timings) == {"detect_left", "detect_right", "match"}
    # rows of two heights: no rows to search with a range (the defaults match such a pair
    # as an unrectified one: test_matching_unrectified.py)
    with pytest.raises(InvalidArgumentError, match="same height"):
        hopmatch.match_stereo(pair[0], pair[1][:-4], max_disparity=20)
    with pytest.raises(InvalidArgumentError, match="unknown parameter"):
        hopmatch.match_stereo(pair[0], pair[1], tehta=3)


def test_empty_inputs_give_empty_results():
    m = HopfieldMatcher()
    m.setPairInfo(np.zeros((0, 2)), np.zeros((0, 2)))
    assert m.match(np.zeros((0, 49), np.float32), np.zeros((0, 49), np.float32)) == ()
    blank = np.zeros((60, 80), np.uint8)
    res = hopmatch.match_stereo(blank, blank)
    assert res.matches == () and res.disparities.shape == (0,)


def test_fundamental_matrix_matches_along_epipolar_lines(pair, features):
    """A rectified pair seen through F = [e1]x (horizontal epipolar lines) gives the same
    candidates as the horizontal band, and a rotated right image is matched with its F."""
    kl, dl, kr, dr = features
    f_rect = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]], np.float64)
    a = _matcher(features).match(dl, dr)
    m = _matcher(features)
    m.setFundamentalMatrix(f_rect)
    b = m.match(dl, dr)
    assert [(x.queryIdx, x.trainIdx) for x in a] == [(x.queryIdx, x.trainIdx) for x in b]
    assert np.array_equal(m.getFundamentalMatrix(), f_rect)
    m.clearPairInfo()
    assert m.getFundamentalMatrix() is None

    # rotate the right image by 3 degrees: rows are no longer epipolar lines
    rot = cv2.getRotationMatrix2D((110, 80), 3.0, 1.0)
    right_rot = cv2.warpAffine(pair[1], rot, (220, 160))
    res_band = hopmatch.match_stereo(pair[0], right_rot, max_disparity=20)
    h = np.vstack([rot, [0, 0, 1]])
    f_rot = np.linalg.inv(h).T @ f_rect  # x_r = H x_r0 with x_r0^T F x_l = 0
    res_f = hopmatch.match_stereo(pair[0], right_rot, max_disparity=20, max_vertical=1.5,
                                  fundamental_matrix=f_rot)
    back = cv2.transform(res_f.matched_right[None], cv2.invertAffineTransform(rot))[0]
    d = res_f.matched_left[:, 0] - back[:, 0]
    assert len(res_f.matches) > 2 * len(res_band.matches)
    assert np.mean(np.abs(d - SHIFT) <= 1) > 0.9


def test_fundamental_matrix_validation():
    m = HopfieldMatcher()
    with pytest.raises(InvalidArgumentError, match=r"\(3, 3\)"):
        m.setFundamentalMatrix(np.eye(3)[:2])
    # one check for every function that takes F (issue 16): array-likes are accepted
    m.setFundamentalMatrix([[0, 0, 0], [0, 0, -1], [0, 1, 0]])
    assert m.getFundamentalMatrix().dtype == np.float64
    with pytest.raises(InvalidTypeError, match="F"):
        m.setFundamentalMatrix("F")
    with pytest.raises(InvalidArgumentError, match="finite"):
        m.setFundamentalMatrix(np.full((3, 3), np.nan))


# -- issue 20: shared-instance misuse raises instead of matching another thread's pair -------


def test_concurrent_set_pair_info_raises_rather_than_mixing_pairs():
    """32 threads each setting their own pair on one matcher: 12 of 32 calls silently
    matched another thread's keypoints before issue 20. Now every call either matches
    its own pair or raises ConcurrentPairInfoError."""
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    from hopmatch.errors import ConcurrentPairInfoError

    m = HopfieldMatcher(max_disparity=20)
    rng = np.random.default_rng(0)
    jobs = []
    for t in range(32):
        p = rng.uniform(20, 200, (150, 2)).astype(np.float32)
        jobs.append((p, p - np.float32([3 + t % 10, 0]), rng.normal(size=(150, 25)).astype(
            np.float32)))
    def alone(job):
        p, q, d = job
        solo = HopfieldMatcher(max_disparity=20)
        solo.setPairInfo(p, q)
        return [(x.queryIdx, x.trainIdx) for x in solo.match(d, d)]

    # what each pair gives on a matcher of its own (some pairs keep only about 50)
    expected = [alone(job) for job in jobs]
    assert all(len(e) > 20 for e in expected)
    barrier = threading.Barrier(8)

    def one(job):
        p, q, d = jobs[job]
        try:
            barrier.wait(timeout=10)
        except threading.BrokenBarrierError:
            pass
        try:
            m.setPairInfo(p, q)
            time.sleep(0.002)
            res = m.match(d, d)
        except ConcurrentPairInfoError:
            return "refused"
        own = [(x.queryIdx, x.trainIdx) for x in res] == expected[job]
        return "own" if own else "wrong"

    with ThreadPoolExecutor(8) as ex:
        out = list(ex.map(one, range(len(jobs))))
    assert out.count("wrong") == 0, out
    assert out.count("refused") > 0  # the misuse was seen


def test_pair_changed_during_a_match_is_detected(monkeypatch):
    """A setPairInfo from another thread while a match runs (the generation read at the
    start and at the end differ) raises; a match in a thread that never set the pair
    (the documented sharing) works."""
    from hopmatch.errors import ConcurrentPairInfoError
    from hopmatch.matching import matcher as matcher_module

    rng = np.random.default_rng(1)
    p = rng.uniform(20, 120, (150, 2)).astype(np.float32)
    d = rng.normal(size=(150, 25)).astype(np.float32)
    m = HopfieldMatcher(max_disparity=20)
    m.setPairInfo(p, p - [5, 0])
    real = matcher_module.match_pair

    def meanwhile(*args, **kwargs):
        import threading

        t = threading.Thread(target=m.setPairInfo, args=(p, p - [6, 0]))
        t.start()
        t.join()
        return real(*args, **kwargs)

    monkeypatch.setattr(matcher_module, "match_pair", meanwhile)
    with pytest.raises(ConcurrentPairInfoError, match="changed while this match ran"):
        m.match(d, d)
    monkeypatch.setattr(matcher_module, "match_pair", real)
    # this thread set a pair, another replaced it: refused up front
    with pytest.raises(ConcurrentPairInfoError, match="another thread replaced"):
        m.match(d, d)
    m.setPairInfo(p, p - [5, 0])  # its own again: fine
    assert len(m.match(d, d)) > 50
    import threading

    got = []
    t = threading.Thread(target=lambda: got.append(len(m.match(d, d))))
    t.start()
    t.join()
    assert got and got[0] > 50  # a thread that only matches shares the pair
    # pickling and cloning give a fresh state
    import pickle

    other = pickle.loads(pickle.dumps(m))
    other.setPairInfo(p, p - [5, 0])
    assert len(other.match(d, d)) > 50 and len(m.clone().match(d, d)) > 50


def test_match_is_the_same_for_own_keypoints_arrays_and_copies(motorcycle):
    """The drop-in path (the detector's keypoint tuples) and the slow paths (arrays, lists
    of new keypoints) give the same matches; a keypoint moved after detection is seen."""
    import cv2

    left, right, _ = motorcycle
    det = hopmatch.DericheMoravecDetector()
    kl, dl = det.detectAndCompute(left, None)
    kr, dr = det.detectAndCompute(right, None)
    size = left.shape[1::-1]

    def matches(q, t):
        m = hopmatch.HopfieldMatcher()
        m.setPairInfo(q, t, size, size)
        return [(d.queryIdx, d.trainIdx, d.distance, d.imgIdx) for d in m.match(dl, dr)]

    own = matches(kl, kr)
    assert len(own) > 1000
    assert own == matches(cv2.KeyPoint_convert(kl), cv2.KeyPoint_convert(kr))
    assert own == matches([cv2.KeyPoint(*k.pt, k.size) for k in kl], list(kr))
    naive = hopmatch.HopfieldMatcher()
    naive.setPairInfo(kl, kr, size, size)
    res = naive.run(dl, dr)
    assert own == [(int(q), int(t), float(d), 0) for q, t, d in
                   zip(res.query_idx, res.train_idx, res.distances)]
    q0 = own[0][0]
    kl[q0].pt = (kl[q0].pt[0], kl[q0].pt[1] + 40.0)  # off its row: its match must change
    assert matches(kl, kr) == matches(cv2.KeyPoint_convert(kl), cv2.KeyPoint_convert(kr))
    assert (q0, own[0][1]) not in {(q, t) for q, t, _, _ in matches(kl, kr)}


def _knn_reference(res, n_query, n_train, k, mask=None, compact=False):
    """knn_rows spelled out: each query's candidates by increasing distance (ties by train
    index), the first k; then, unless compact, the lowest allowed train indices not among
    its candidates at distance 1.0 until k."""
    from hopmatch.matching.similarity import match_distance

    dist = match_distance(res.fields)
    rows = []
    for q in range(n_query):
        mine = sorted((float(dist[i]), int(res.neuron_right[i]))
                      for i in np.flatnonzero(res.neuron_left == q))[:k]
        row = [(q, t, d) for d, t in mine]
        if compact:
            if row:
                rows.append(row)
            continue
        taken = {t for _, t in mine}
        for t in range(n_train):
            if len(row) >= k:
                break
            if t not in taken and (mask is None or mask[q, t]):
                row.append((q, t, 1.0))
        rows.append(row)
    return rows


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("with_mask", [False, True])
def test_knn_rows_pad_as_the_reference_does(seed, with_mask):
    """knn_rows's padding with the lowest train indices not among a query's candidates,
    against the plain loops of _knn_reference (the padding's old loop over the k columns
    cost k**2 per short row: 28 s for 3000 queries and k = 3000)."""
    from hopmatch.matching.matcher import knn_rows
    from hopmatch.matching.network import NetworkResult

    rng = np.random.default_rng(seed)
    n_query, n_train, n = 30, 25, 120
    left = rng.integers(0, n_query, n).astype(np.int32)
    right = rng.integers(0, n_train, n).astype(np.int32)
    pairs = np.unique(np.stack([left, right], 1), axis=0)  # one neuron per pair
    left, right = pairs[:, 0].copy(), pairs[:, 1].copy()
    fields = rng.normal(size=len(left))
    res = NetworkResult(query_idx=left[:0], train_idx=right[:0],
                        distances=np.zeros(0, np.float32), neuron_left=left,
                        neuron_right=right, state=np.zeros(len(left), bool), fields=fields,
                        similarity=np.zeros(len(left)), n_interactions=0, iterations=0,
                        sweeps=0, converged=True, energy=0.0)
    mask = (rng.random((n_query, n_train)) < 0.7) if with_mask else None
    for k in (1, 3, 10, n_train, n_train + 5):
        for compact in (False, True):
            got = [[(m.queryIdx, m.trainIdx, m.distance) for m in row]
                   for row in knn_rows(res, n_query, n_train, k, mask, compact)]
            want = _knn_reference(res, n_query, n_train, k, mask, compact)
            assert [[(q, t) for q, t, _ in r] for r in got] == \
                [[(q, t) for q, t, _ in r] for r in want], (k, compact)
            assert np.allclose([d for r in got for *_, d in r],
                               [d for r in want for *_, d in r], rtol=0, atol=1e-6)
