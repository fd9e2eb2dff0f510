"""Probe of issue 20: bad inputs, each in its own process with a time limit.

usage: python benchmarks/robustness_probe/mkfiles.py   (the bad files, in /tmp/probe/files)
       python benchmarks/robustness_probe/probe.py PYTHON [KIND ...]
-> one line per case ([ok  ] or [FAIL]), then counts per kind. PYTHON is the interpreter
whose hopmatch is probed (e.g. .venv/bin/python). It needs a few minutes and writes only
below /tmp. The figures of docs/robustness.md, "Probe", come from it.
"""
import json, os, subprocess, sys, time, textwrap

PY = sys.argv[1]
ONLY = set(sys.argv[2:])
F = "/tmp/probe/files"
HOPMATCH = os.path.join(os.path.dirname(PY), "hopmatch")
os.chdir("/tmp")

PRELUDE = '''
import json, os, sys, time, warnings, resource, threading
resource.setrlimit(resource.RLIMIT_AS, (10 << 30, 10 << 30))
import numpy as np, cv2, hopmatch, hopmatch.imageio, hopmatch.datasets, hopmatch.viz, hopmatch.stereo
from hopmatch.errors import HopmatchError
F = "/tmp/probe/files"
hopmatch.warmup()
def crowd(n, spread=0.0, seed=0, same=True):
    rng = np.random.default_rng(seed)
    pts = np.full((n, 2), 100.0, np.float32) + rng.uniform(0, spread, (n, 2)).astype(np.float32)
    desc = rng.normal(size=(n, 25)).astype(np.float32)
    if same:
        desc[:] = desc[0]
    return pts, desc
def noise_pair(h=240, w=320, shift=6, seed=0):
    rng = np.random.default_rng(seed)
    img = cv2.GaussianBlur(rng.uniform(0, 255, (h, w)).astype(np.float32), (0, 0), 1.5)
    img = cv2.normalize(img, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)
    return img, np.roll(img, -shift, axis=1)
def res_summary(r):
    if hasattr(r, "query_idx"):
        return {"matches": int(len(r.query_idx))}
    if isinstance(r, (tuple, list)):
        return {"len": len(r)}
    if isinstance(r, np.ndarray):
        return {"shape": list(r.shape)}
    return {"repr": repr(r)[:200]}
'''

RUN = '''
t0 = time.perf_counter()
out = {}
try:
    with warnings.catch_warnings(record=True) as ws:
        warnings.simplefilter("always")
        r = case()
    out = {"outcome": "returned", **res_summary(r),
           "warnings": [type(w.message).__name__ + ": " + str(w.message)[:150] for w in ws
                        if issubclass(w.category, hopmatch.errors.HopmatchWarning)]}
except BaseException as e:
    out = {"outcome": "raised", "type": type(e).__module__ + "." + type(e).__name__,
           "hopmatch": isinstance(e, HopmatchError),
           "vt": isinstance(e, (ValueError, TypeError)),
           "argument": getattr(e, "argument", None), "msg": " ".join(str(e).split())[:300]}
out["seconds"] = round(time.perf_counter() - t0, 3)
print("@@" + json.dumps(out), flush=True)
'''

CASES = []


def lib(kind, name, code, expect, timeout=25):
    CASES.append(("lib", kind, name, textwrap.dedent(code), expect, timeout))


def cli(kind, name, args, expect="exit2", timeout=40, setup=None, check=None, user=None):
    CASES.append(("cli", kind, name, (args, setup, check, user), expect, timeout))

# ---------------------------------------------------------------------------- hangs
for n in (300, 400, 1500):
    lib("hang", f"hopfield_match {n} identical points", f'''
    def case():
        p, d = crowd({n}); return hopmatch.hopfield_match(p, p - [10, 0], d, d, max_disparity=20)
    ''', "refuse:max_interactions")
lib("hang", "HopfieldMatcher.match 1500 points in a 0.5 px blob", '''
def case():
    p, d = crowd(1500, 0.5); m = hopmatch.HopfieldMatcher(max_disparity=20)
    m.setPairInfo(p, p - [10, 0]); return m.match(d, d)
''', "refuse:max_interactions")
lib("hang", "1000 points on one row, 1 px apart, disparity 0..1000", '''
def case():
    n = 1000; p = np.c_[np.arange(n), np.full(n, 50)].astype(np.float32)
    d = np.ones((n, 25), np.float32)
    return hopmatch.hopfield_match(p, p, d, d, min_disparity=-1000, max_disparity=1000,
                                   neighbour_width=2000, max_vertical=1)
''', "refuse:max_interactions")
lib("hang", "hopfield_match 1500 identical, fundamental matrix", '''
def case():
    p, d = crowd(1500); F = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]], float)
    return hopmatch.hopfield_match(p, p - [10, 0], d, d, max_disparity=20, fundamental_matrix=F)
''', "refuse:max_interactions")
lib("hang", "300,000 left points on a grid, 300,000 identical right points (candidate count)", '''
def case():
    g = np.stack(np.meshgrid(np.arange(600), np.arange(500)), -1).reshape(-1, 2).astype(np.float32)
    q = np.full_like(g, 300.0); d = np.ones((len(g), 9), np.float32)
    return hopmatch.hopfield_match(g, q, d, d, min_disparity=-1000, max_disparity=1000, max_vertical=1000,
                                   neighbour_width=2, neighbour_height=2)
''', "refuse:max_neurons", timeout=40)
lib("hang", "same, epipolar candidates", '''
def case():
    g = np.stack(np.meshgrid(np.arange(600), np.arange(500)), -1).reshape(-1, 2).astype(np.float32)
    q = np.full_like(g, 300.0); d = np.ones((len(g), 9), np.float32)
    F = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]], float)
    return hopmatch.hopfield_match(g, q, d, d, min_disparity=-1000, max_disparity=1000, max_vertical=1000,
                                   neighbour_width=2, neighbour_height=2, fundamental_matrix=F)
''', "refuse:max_neurons", timeout=40)
lib("hang", "match_stereo with 800 identical keypoints via matcher budget 10**7", '''
def case():
    p, d = crowd(800); m = hopmatch.HopfieldMatcher(max_disparity=20, max_interactions=10**7)
    m.setPairInfo(p, p - [10, 0]); return m.match(d, d)
''', "refuse:max_interactions")
lib("hang", "read_image(FIFO)", 'def case(): return hopmatch.imageio.read_image(F + "/fifo.png")',
    "refuse-noloop:path", timeout=10)
lib("hang", "DericheMoravecDetector().read(FIFO .yml)",
    'def case(): return hopmatch.DericheMoravecDetector().read(F + "/fifo.yml")', "refuse-noloop:fs",
    timeout=10)
lib("hang", "HopfieldMatcher().read(FIFO .yml)",
    'def case(): return hopmatch.HopfieldMatcher().read(F + "/fifo.yml")', "refuse-noloop:fs", timeout=10)
lib("hang", "read_pfm(FIFO)", 'def case(): return hopmatch.datasets.readers.read_pfm(F + "/fifo.pfm")',
    "refuse-noloop:", timeout=10)
lib("hang", "read_calibration(FIFO)",
    'def case(): return hopmatch.datasets.calibration.read_calibration(F + "/fifo.txt")', "refuse-noloop:", timeout=10)
lib("hang", "StereoCalibration.from_file(FIFO)", '''
def case():
    from hopmatch.stereo import calibration as c
    return c.StereoCalibration.from_file(F + "/fifo.yml")
''', "refuse-noloop:", timeout=10)
lib("hang", "read_pairs(FIFO)", '''
def case():
    import hopmatch_dask; return hopmatch_dask.read_pairs(F + "/fifo.csv")
''', "refuse-noloop:", timeout=10)
lib("hang", "complete_rows(FIFO result file)", '''
def case():
    from hopmatch_dask.results import complete_rows; return complete_rows(F + "/fifo.csv")
''', "returned-none", timeout=10)
lib("hang", "read_image(/dev/stdin as a terminal-less pipe)",
    'def case(): return hopmatch.imageio.read_image("/dev/stdin")', "refuse-noloop:path", timeout=10)
cli("hang", "hopmatch match FIFO R.png", ["match", f"{F}/fifo.png", f"{F}/R.png", "-o", "{tmp}/o"],
    timeout=15)
cli("hang", "hopmatch detect FIFO", ["detect", f"{F}/fifo.png", "-o", "{tmp}/o"], timeout=15)
cli("hang", "hopmatch batch with a FIFO pair",
    ["batch", "{tmp}/pairs.csv", "-o", "{tmp}/o", "--workers", "1"], expect="summary", timeout=90,
    setup=f"left,right,name\n{F}/L.png,{F}/R.png,good\n{F}/fifo.png,{F}/R.png,bad\n")
cli("hang", "hopmatch batch PAIRS.csv is a FIFO",
    ["batch", f"{F}/fifo.csv", "-o", "{tmp}/o"], timeout=15)

# ------------------------------------------------------------------------ unbounded
cli("unbounded", "hopmatch match /dev/zero R.png", ["match", "/dev/zero", f"{F}/R.png", "-o", "{tmp}/o"])
cli("unbounded", "hopmatch match /dev/urandom R.png",
    ["match", "/dev/urandom", f"{F}/R.png", "-o", "{tmp}/o"])
cli("unbounded", "hopmatch match sparse 40 GB R.png",
    ["match", f"{F}/sparse40g.png", f"{F}/R.png", "-o", "{tmp}/o"])
cli("unbounded", "hopmatch match 30000^2 PNG (0.87 MB)",
    ["match", f"{F}/huge30000.png", f"{F}/huge30000.png", "-o", "{tmp}/o"], expect="exit2-fast-nohint")
cli("unbounded", "hopmatch detect 16-bit RGB 16000^2 PNG",
    ["detect", f"{F}/huge16rgb.png", "-o", "{tmp}/o"], expect="exit2-fast-nohint")
cli("unbounded", "hopmatch detect 8000^2 PNG (64 Mpx > 50M)",
    ["detect", f"{F}/big8000.png", "-o", "{tmp}/o"], expect="exit2-fast-nohint")
for fname in ("huge30000.png", "huge16rgb.png", "liar.pgm", "liar.ppm", "liar.bmp"):
    lib("unbounded", f"read_image({fname})", f'''
    import resource
    def case():
        img = hopmatch.imageio.read_image(F + "/{fname}")
        return img
    ''', "refuse-fast:", timeout=40)
lib("unbounded", "read_image(/dev/zero)", 'def case(): return hopmatch.imageio.read_image("/dev/zero")',
    "refuse-fast:", timeout=40)
lib("unbounded", "read_image(sparse 40 GB)",
    'def case(): return hopmatch.imageio.read_image(F + "/sparse40g.png")', "refuse-fast:", timeout=40)
lib("unbounded", "read_pfm(sparse 40 GB)",
    'def case(): return hopmatch.datasets.readers.read_pfm(F + "/sparse40g.pfm")', "refuse-fast:", timeout=40)
lib("unbounded", "read_calibration(sparse 40 GB)",
    'def case(): return hopmatch.datasets.calibration.read_calibration(F + "/sparse40g.txt")', "refuse-fast:",
    timeout=40)
lib("unbounded", "read_kitti_calib(sparse 40 GB)",
    'def case(): return hopmatch.datasets.calibration.read_kitti_calib(F + "/sparse40g.txt")', "refuse-fast:",
    timeout=40)
lib("unbounded", "read_scene_image(30000^2 PNG)",
    'def case(): return hopmatch.datasets.readers.read_scene_image(F + "/huge30000.png")', "refuse-fast:",
    timeout=40)
lib("unbounded", "Detector.read(sparse 40 GB yml)",
    'def case(): return hopmatch.DericheMoravecDetector().read(F + "/sparse40g.yml")', "refuse-fast:fs",
    timeout=40)
lib("unbounded", "read_pairs(sparse 40 GB csv)", '''
def case():
    import hopmatch_dask; return hopmatch_dask.read_pairs(F + "/sparse40g.csv")
''', "refuse-fast:", timeout=40)
lib("unbounded", "complete_rows(sparse 40 GB)", '''
def case():
    from hopmatch_dask.results import complete_rows; return complete_rows(F + "/sparse40g.csv")
''', "returned-none-fast", timeout=40)
lib("unbounded", "hopmatch_dask task on 30000^2 PNG", '''
def case():
    import hopmatch_dask
    from hopmatch_dask.tasks import batch_task
    r = batch_task(hopmatch_dask.Pair("x", F + "/huge30000.png", F + "/R.png"), {})
    if r["status"] == "failed" and "internal" not in r["error"]:
        raise hopmatch.errors.InvalidArgumentError(r["error"])
    raise RuntimeError(str(r)[:200])
''', "refuse-fast:", timeout=40)
lib("unbounded", "max_pixels hint text", '''
def case():
    hopmatch.DericheMoravecDetector(max_pixels=100).detect(np.zeros((20, 20), np.uint8))
''', "refuse:max_pixels")

# ------------------------------------------------------------------------ extremes
for pname, val in [("max_iterations", "10**30"), ("stable_iterations", "2**64"), ("seed", "2**64"),
                   ("max_neurons", "10**30"), ("max_interactions", "2**63"),
                   ("max_candidates", "-1"), ("max_iterations", "2**63-1"),
                   ("stable_iterations", "2**63-1"), ("seed", "2**63-1")]:
    expect = "run" if val.endswith("-1") and val != "-1" else f"refuse:{pname}"
    lib("extreme", f"match_stereo({pname}={val})", f'''
    def case():
        L, R = noise_pair(); return hopmatch.match_stereo(L, R, {pname}={val}, max_disparity=16)
    ''', expect)
for pname, val in [("max_features", "2**63-1"), ("max_pixels", "2**63-1"), ("nms_size", "999"),
                   ("window_size", "99"), ("descriptor_size", "99"), ("nms_size", "10**6"),
                   ("max_features", "10**30")]:
    expect = "refuse:" + pname if val in ("10**6", "10**30") else "run"
    lib("extreme", f"detector {pname}={val}", f'''
    def case():
        L, R = noise_pair(); return hopmatch.DericheMoravecDetector({pname}={val}).detect(L)
    ''', expect)
for pname, val in [("alpha", "5e-324"), ("alpha", "1e-300"), ("alpha", "1e300"), ("omega", "5e-324"),
                   ("omega", "1e300"), ("window_sigma", "5e-324"), ("window_sigma", "1e300"),
                   ("threshold", "1e308"), ("threshold", "5e-324")]:
    lib("extreme", f"detector {pname}={val}", f'''
    def case():
        L, R = noise_pair(); return hopmatch.DericheMoravecDetector({pname}={val}).detectAndCompute(L, None)
    ''', "run-or-refuse:" + pname)
for pname, val in [("max_vertical", "1e19"), ("max_vertical", "3.5e38"), ("max_vertical", "1e300"),
                   ("max_disparity", "1e300"), ("min_disparity", "-1e300"),
                   ("neighbour_width", "1e300"), ("neighbour_width", "5e-324"),
                   ("neighbour_height", "1e39"), ("theta", "1e300"), ("slope", "1e300"),
                   ("slope", "5e-324"), ("similarity_weight", "1e308"), ("similarity_gate", "1e308"),
                   ("input_bias", "1e308"), ("input_bias", "-1e308"), ("initial_bias", "1e308"),
                   ("uniqueness_weight", "1e308"), ("vertical_threshold", "5e-324"),
                   ("vertical_threshold", "1e308")]:
    extra = "" if pname in ("max_disparity", "min_disparity") else ", max_disparity=16"
    lib("extreme", f"match_stereo({pname}={val})", f'''
    def case():
        L, R = noise_pair(); return hopmatch.match_stereo(L, R, {pname}={val}{extra})
    ''', "matches-or-refuse:" + pname)
for scale in ("1e-200", "1e200", "1e-320", "1e-30"):
    lib("extreme", f"fundamental matrix scaled by {scale}", f'''
    def case():
        L, R = noise_pair()
        F0 = np.array([[0, 0, 0], [0, 0, -1], [0, 1, 0]], float) * {scale}
        return hopmatch.match_stereo(L, R, fundamental_matrix=F0, max_disparity=16)
    ''', "matches-or-refuse:fundamental_matrix")
lib("extreme", "setFundamentalMatrix scaled by 1e-200", '''
def case():
    p, d = crowd(200, 60); m = hopmatch.HopfieldMatcher(max_disparity=20)
    m.setPairInfo(p, p - [10, 0]); m.setFundamentalMatrix(np.array([[0,0,0],[0,0,-1],[0,1,0]]) * 1e-200)
    return m.match(d, d)
''', "len-or-refuse:F")
for cls, pname, val in [("DericheMoravecDetector", "max_pixels", "10**10"),
                        ("DericheMoravecDetector", "max_pixels", "2**63-1"),
                        ("DericheMoravecDetector", "max_features", "2**31"),
                        ("HopfieldMatcher", "seed", "2**40+7"), ("HopfieldMatcher", "seed", "2**63-1"),
                        ("HopfieldMatcher", "max_neurons", "3_000_000_000"),
                        ("HopfieldMatcher", "max_iterations", "2**53+1"),
                        ("HopfieldMatcher", "stable_iterations", "2**62"),
                        ("HopfieldMatcher", "max_vertical", "5e-324"),
                        ("HopfieldMatcher", "input_bias", "-1.7976931348623157e308")]:
    for ext in ("yml", "json", "xml"):
        lib("extreme", f"FileStorage .{ext} round trip {cls}({pname}={val})", f'''
        import tempfile
        def case():
            a = hopmatch.{cls}({pname}={val}); path = tempfile.mktemp(suffix=".{ext}")
            a.write(path); b = hopmatch.{cls}(); b.read(path)
            if b.get_params() != a.get_params():
                raise RuntimeError(f"silently changed: {{b.get{pname.title().replace('_', '')}()!r}}")
            return True
        ''', "true")

# ------------------------------------------------------------------- silent empty
for label, make in [
    ("uint8 left, uint16 x257 right", "L, R.astype(np.uint16) * 257"),
    ("uint8 left, float32 [0,1] right", "L, R.astype(np.float32) / 255"),
    ("right at half gain (uint8)", "L, (R // 2).astype(np.uint8)"),
    ("right at 0.75 gain (uint8)", "L, (R * 0.75).astype(np.uint8)"),
    ("both float32 in [0, 1]", "L.astype(np.float32) / 255, R.astype(np.float32) / 255"),
    ("both dark (gain 0.1)", "(L * 0.1).astype(np.uint8), (R * 0.1).astype(np.uint8)"),
    ("uint16 x257 both", "L.astype(np.uint16) * 257, R.astype(np.uint16) * 257"),
    ("right at gain 2 (float32)", "L.astype(np.float32), R.astype(np.float32) * 2"),
]:
    lib("silent", f"match_stereo: {label}", f'''
    def case():
        from hopmatch.datasets import load_motorcycle
        s = load_motorcycle(); L = cv2.cvtColor(s.left, cv2.COLOR_BGR2GRAY); R = cv2.cvtColor(s.right, cv2.COLOR_BGR2GRAY)
        a, b = {make}
        return hopmatch.match_stereo(a, b)
    ''', "matches-or-warning:300", timeout=60)
lib("silent", "unrelated pair (noise vs other noise)", '''
def case():
    L, _ = noise_pair(seed=1); R, _ = noise_pair(seed=2); return hopmatch.match_stereo(L, R, max_disparity=16)
''', "warning")
lib("silent", "right image flipped upside down", '''
def case():
    L, R = noise_pair(); return hopmatch.match_stereo(L, R[::-1].copy(), max_disparity=16)
''', "warning")
lib("silent", "disparity range excludes the true shift (6 px, range 20..40)", '''
def case():
    L, R = noise_pair(); return hopmatch.match_stereo(L, R, min_disparity=20, max_disparity=40)
''', "warning")
for label, call in [
    ("a flat left frame", "hopmatch.match_stereo(np.full_like(L, 9), R, max_disparity=16)"),
    ("a 3-row pair", "hopmatch.match_stereo(L[:3].copy(), R[:3].copy(), max_disparity=16)"),
    ("an all-zero left mask",
     "hopmatch.match_stereo(L, R, max_disparity=16, mask_left=np.zeros(L.shape, np.uint8))"),
]:
    lib("silent", f"match_stereo: {label}", f'''
    def case():
        L, R = noise_pair(); return {call}
    ''', "warning")

# ------------------------------------------------------------------------ foreign
for label, text in [
    ("node is a sequence", "%YAML:1.0\n---\nhopmatch_DericheMoravecDetector: [1, 2, 3]\n"),
    ("node is a scalar", "%YAML:1.0\n---\nhopmatch_DericheMoravecDetector: 5\n"),
    ("node is a string", "%YAML:1.0\n---\nhopmatch_DericheMoravecDetector: abc\n"),
    ("root is a sequence", "%YAML:1.0\n--- [1, 2]\n"),
    ("parameter is a map", "%YAML:1.0\n---\nhopmatch_DericheMoravecDetector:\n  window_size: {a: 1}\n"),
    ("parameter is 1e400", "%YAML:1.0\n---\nhopmatch_DericheMoravecDetector:\n  threshold: 1e400\n"),
    ("parameter is huge int", "%YAML:1.0\n---\nhopmatch_DericheMoravecDetector:\n  max_pixels: 99999999999999999999999\n"),
    ("binary garbage", None),
]:
    body = (f"open(path, 'w').write({text!r})" if text is not None
            else "open(path, 'wb').write(bytes(range(256)) * 4)")
    lib("foreign", f"Detector.read(): {label}", f'''
    import tempfile
    def case():
        path = tempfile.mktemp(suffix=".yml"); {body}
        return hopmatch.DericheMoravecDetector().read(path)
    ''', "refuse:" + ("threshold" if "1e400" in label else "max_pixels" if "huge" in label else "fs"))
lib("foreign", "Matcher.read(): node is a sequence (json)", '''
import tempfile
def case():
    path = tempfile.mktemp(suffix=".json"); open(path, "w").write('{"hopmatch_HopfieldMatcher": [1, 2]}')
    return hopmatch.HopfieldMatcher().read(path)
''', "refuse:fs")
lib("foreign", "write() onto a folder", '''
import tempfile
def case():
    path = tempfile.mkdtemp(suffix=".yml"); return hopmatch.DericheMoravecDetector().write(path)
''', "refuse-clean:fs")
lib("foreign", "write() name over 255 characters", '''
import tempfile
def case():
    path = tempfile.mkdtemp() + "/" + "a" * 300 + ".yml"; return hopmatch.DericheMoravecDetector().write(path)
''', "refuse-clean:fs")
lib("foreign", "write() into an unwritable folder (as nobody)", '''
import tempfile
def case():
    d = tempfile.mkdtemp(); os.chmod(d, 0o555); os.setuid(65534)
    return hopmatch.DericheMoravecDetector().write(d + "/p.yml")
''', "refuse-clean:fs")
lib("foreign", "write() into a path whose parent is a file", '''
import tempfile
def case():
    f = tempfile.mktemp(); open(f, "w").close(); return hopmatch.DericheMoravecDetector().write(f + "/p.yml")
''', "refuse-clean:fs")
lib("foreign", "Detector.read(symlink loop)",
    'def case(): return hopmatch.DericheMoravecDetector().read(F + "/loop.yml")', "refuse-noloop:fs")
lib("foreign", "read_image(symlink loop)",
    'def case(): return hopmatch.imageio.read_image(F + "/loop.png")', "refuse-noloop:path")
lib("foreign", "read_image(name over 255 characters)",
    'def case(): return hopmatch.imageio.read_image("/tmp/" + "a" * 300 + ".png")', "refuse:path")
lib("foreign", "read_image(socket)", 'def case(): return hopmatch.imageio.read_image(F + "/socket.png")',
    "refuse:path")
lib("foreign", "StereoCalibration.to_file onto a folder", '''
import tempfile
def case():
    from hopmatch.stereo import calibration as c
    K = np.array([[500., 0, 160], [0, 500, 120], [0, 0, 1]])
    cal = c.StereoCalibration(K, np.zeros(5), K, np.zeros(5), np.eye(3), np.array([-0.1, 0, 0]), (320, 240))
    return cal.to_file(tempfile.mkdtemp(suffix=".yml"))
''', "refuse-clean:")
lib("foreign", "write_ply onto a folder", '''
import tempfile
def case():
    return hopmatch.stereo.write_ply(tempfile.mkdtemp(suffix=".ply"), np.zeros((3, 3), np.float32))
''', "refuse-clean:")
lib("foreign", "viz.write_text_atomic name over 255", '''
import tempfile
def case():
    return hopmatch.viz.write_text_atomic(tempfile.mkdtemp() + "/" + "b" * 300, "x")
''', "refuse-clean:")
cli("foreign", "hopmatch match with a 300-character file name",
    ["match", "/tmp/" + "a" * 300 + ".png", f"{F}/R.png", "-o", "{tmp}/o"])
cli("foreign", "hopmatch match symlink loop", ["match", f"{F}/loop.png", f"{F}/R.png", "-o", "{tmp}/o"],
    expect="exit2-noloop")
cli("foreign", "hopmatch match socket file", ["match", f"{F}/socket.png", f"{F}/R.png", "-o", "{tmp}/o"])
cli("foreign", "hopmatch match -o with a 300-character name",
    ["match", f"{F}/L.png", f"{F}/R.png", "-o", "{tmp}/" + "o" * 300])
cli("foreign", "hopmatch match -o inside a file", ["match", f"{F}/L.png", f"{F}/R.png", "-o", f"{F}/L.png/o"])
cli("foreign", "hopmatch match -o unwritable (nobody)",
    ["match", f"{F}/L.png", f"{F}/R.png", "-o", "/var/o"], user=65534)
cli("foreign", "hopmatch batch --scheduler nonsense://::x",
    ["batch", "{tmp}/pairs.csv", "-o", "{tmp}/o", "--scheduler", "nonsense://::x"],
    setup=f"left,right\n{F}/L.png,{F}/R.png\n", timeout=60)
cli("foreign", "hopmatch batch --scheduler tcp://127.0.0.1:1 (nothing listens)",
    ["batch", "{tmp}/pairs.csv", "-o", "{tmp}/o", "--scheduler", "tcp://127.0.0.1:1"],
    setup=f"left,right\n{F}/L.png,{F}/R.png\n", timeout=60)
cli("foreign", "hopmatch batch --scheduler tcp://",
    ["batch", "{tmp}/pairs.csv", "-o", "{tmp}/o", "--scheduler", "tcp://"],
    setup=f"left,right\n{F}/L.png,{F}/R.png\n", timeout=60)
cli("foreign", "hopmatch match --max-iterations 10**30",
    ["match", f"{F}/L.png", f"{F}/R.png", "-o", "{tmp}/o", "--max-iterations", str(10**30)])
cli("foreign", "hopmatch match --seed 2**64",
    ["match", f"{F}/L.png", f"{F}/R.png", "-o", "{tmp}/o", "--seed", str(2**64)])
cli("foreign", "hopmatch match --max-vertical 1e400",
    ["match", f"{F}/L.png", f"{F}/R.png", "-o", "{tmp}/o", "--max-vertical", "1e400"])
cli("foreign", "hopmatch match --alpha 5e-324",
    ["match", f"{F}/L.png", f"{F}/R.png", "-o", "{tmp}/o", "--alpha", "5e-324"])
for label, content in [("cut at a line boundary", "cut"), ("holding a nan row", "nan"),
                       ("holding an inf row", "inf")]:
    lib("foreign", f"resume: result file {label}", f'''
    import tempfile
    def case():
        from hopmatch_dask.results import complete_rows, matches_table
        import hopmatch_dask
        rng = np.random.default_rng(0)
        text = matches_table(rng.uniform(0, 99, (10, 2)), rng.uniform(0, 99, (10, 2)), rng.uniform(0, 9, 10), rng.uniform(0, 1, 10))
        if "{content}" == "cut":
            text = "".join(text.splitlines(True)[:5])
        else:
            lines = text.splitlines(True); lines[3] = ",".join(["{content}"] * 6) + "\\n"; text = "".join(lines)
        d = tempfile.mkdtemp(); open(d + "/p.csv", "w").write(text)
        return complete_rows(d + "/p.csv")
    ''', "returned-none")

# ------------------------------------------------------------------- shared matcher
lib("shared", "setPairInfo+match from 32 threads on one matcher", '''
def case():
    from concurrent.futures import ThreadPoolExecutor
    m = hopmatch.HopfieldMatcher(max_disparity=20)
    rng = np.random.default_rng(0)
    jobs = []
    for t in range(32):
        p = rng.uniform(20, 200, (150, 2)).astype(np.float32); d = rng.normal(size=(150, 25)).astype(np.float32)
        shift = np.float32([3 + t % 10, 0]); jobs.append((p, p - shift, d, int(3 + t % 10)))
    def one(job):
        p, q, d, s = job
        try:
            m.setPairInfo(p, q); time.sleep(0.001); r = m.match(d, d)
        except HopmatchError as e:
            return "error"
        ok = all(x.queryIdx == x.trainIdx for x in r)
        return "ok" if ok and len(r) > 50 else "wrong"
    with ThreadPoolExecutor(8) as ex:
        out = list(ex.map(one, jobs))
    wrong = out.count("wrong"); errors = out.count("error")
    if wrong:
        raise RuntimeError(f"{wrong} of 32 calls silently gave wrong matches ({errors} raised)")
    return out
''', "no-wrong")

# ---------------------------------------------------------------- interrupted writes
for k in range(1, 8):
    lib("interrupt", f"KeyboardInterrupt at os.replace call {k} of hopmatch match (old run present)", f'''
    import tempfile, hashlib
    def snap(d):
        return {{n: hashlib.md5(open(os.path.join(d, n), "rb").read()).hexdigest() for n in os.listdir(d)}}
    def case():
        from hopmatch.cli import main
        d = tempfile.mkdtemp() + "/o"
        assert main(["-q", "match", F + "/L.png", F + "/R.png", "-o", d, "--plot-energy", "--figures"]) == 0
        before = snap(d)
        # a second run with other parameters, interrupted at the k-th os.replace
        real = os.replace; real_rename = os.rename; calls = [0]
        def wrap(fn):
            def fake(a, b):
                calls[0] += 1
                if calls[0] == {k}:
                    raise KeyboardInterrupt
                return fn(a, b)
            return fake
        os.replace = wrap(real); os.rename = wrap(real_rename)
        try:
            rc = main(["-q", "match", F + "/L.png", F + "/R.png", "-o", d, "--plot-energy", "--figures", "--max-disparity", "12"])
        except BaseException as e:
            rc = type(e).__name__
        finally:
            os.replace = real; os.rename = real_rename
        after = snap(d)
        if calls[0] < {k}:
            return "not reached"
        if after != before:
            changed = sorted(n for n in set(after) | set(before) if after.get(n) != before.get(n))
            raise RuntimeError(f"rc={{rc}}: folder changed although interrupted: {{changed}}")
        return "unchanged"
    ''', "unchanged")
lib("interrupt", "KeyboardInterrupt at os.replace of a fresh folder", '''
import tempfile
def case():
    from hopmatch.cli import main
    d = tempfile.mkdtemp() + "/new/o"
    real = os.replace; real_rename = os.rename; calls = [0]
    def wrap(fn):
        def fake(a, b):
            calls[0] += 1
            if calls[0] in (1, 2):
                raise KeyboardInterrupt
            return fn(a, b)
        return fake
    os.replace = wrap(real); os.rename = wrap(real_rename)
    try:
        main(["-q", "match", F + "/L.png", F + "/R.png", "-o", d])
    except BaseException:
        pass
    finally:
        os.replace = real; os.rename = real_rename
    left = os.listdir(d) if os.path.exists(d) else None
    if left:
        raise RuntimeError(f"fresh folder left with {left}")
    return "clean"
''', "clean")
for sig in ("SIGINT", "SIGTERM", "SIGHUP"):
    lib("interrupt", f"{sig} while hopmatch match renames (real signal)", f'''
    import tempfile, hashlib, signal, subprocess
    def snap(d):
        return {{n: hashlib.md5(open(os.path.join(d, n), "rb").read()).hexdigest() for n in os.listdir(d)}}
    def case():
        d = tempfile.mkdtemp() + "/o"
        exe = os.path.join(os.path.dirname(sys.executable), "hopmatch")
        subprocess.run([exe, "-q", "match", F + "/L.png", F + "/R.png", "-o", d], check=True)
        before = snap(d)
        # slow down each rename so that the signal lands among them
        code = ("import os, time, sys; real = os.replace\\n"
                "real_rename = os.rename\\n"
                "def slow(a, b):\\n    open('/tmp/probe/renaming', 'w').close(); time.sleep(0.3); real(a, b)\\n"
                "def slow_rename(a, b):\\n    open('/tmp/probe/renaming', 'w').close(); time.sleep(0.3); real_rename(a, b)\\n"
                "os.replace = slow; os.rename = slow_rename\\n"
                "from hopmatch.cli import main; sys.exit(main(sys.argv[1:]))")
        try: os.unlink("/tmp/probe/renaming")
        except OSError: pass
        p = subprocess.Popen([sys.executable, "-c", code, "-q", "match", F + "/L.png", F + "/R.png", "-o", d,
                              "--nms-size", "5"], stderr=subprocess.PIPE)
        t = time.time()
        while not os.path.exists("/tmp/probe/renaming") and time.time() - t < 60:
            time.sleep(0.005)
        time.sleep(0.35)
        p.send_signal(signal.{sig}); p.wait(30)
        after = snap(d)
        visible = {{n: h for n, h in after.items() if not n.startswith(".")}}
        if visible != before and set(visible) == set(before) and all(visible[n] != before[n] for n in before):
            return "new"
        if visible != before:
            changed = sorted(n for n in set(visible) | set(before) if visible.get(n) != before.get(n))
            raise RuntimeError(f"rc={{p.returncode}}: mixed folder, changed {{changed}} of {{sorted(before)}}")
        return "unchanged"
    ''', "unchanged-or-new", timeout=90)


# ------------------------------------------------------- fuzzing the API (2026-12-07)
# Found by fuzzing the public API table by table (each FAILed before the fixes named in the
# 2026-12-07 commits): a segmentation fault, an internal error on the command line, foreign
# exceptions, budgets refused mid-run.
lib("fuzz", "HopfieldMatcher.load(a YAML file nested 50,000 deep) (a segfault)", '''
def case():
    return hopmatch.HopfieldMatcher.create().load(F + "/deep.yml")
''', "refuse:fs")
lib("fuzz", "StereoCalibration.from_file(an XML file nested 50,000 deep) (a segfault)", '''
def case():
    open("/tmp/probe/deep.xml", "w").write('<?xml version="1.0"?>\\n<opencv_storage>\\n'
                                           + "<a>" * 50000 + "1" + "</a>" * 50000
                                           + "\\n</opencv_storage>\\n")
    return hopmatch.stereo.StereoCalibration.from_file("/tmp/probe/deep.xml")
''', "refuse:")
cli("fuzz", "match --fundamental-matrix (a YAML file nested 50,000 deep) (a segfault)",
    ["match", F + "/L.png", F + "/R.png", "-o", "{tmp}/o", "--fundamental-matrix",
     F + "/deep.yml"])
cli("fuzz", "match of a 20 x 20 pair, pictures drawn (an internal error)",
    ["match", F + "/tiny20.png", F + "/tiny20.png", "-o", "{tmp}/o"], expect="exit0")
lib("fuzz", "load_scene(meta.json nested 200,000 deep) (RecursionError)", '''
def case():
    d = "/tmp/probe/deepscene"; os.makedirs(d, exist_ok=True)
    for f in ("im0.png", "im1.png", "disp.png"):
        cv2.imwrite(d + "/" + f, np.zeros((4, 6), np.uint8))
    open(d + "/meta.json", "w").write('{"left": "im0.png", "right": "im1.png", "disp": '
                                      '"disp.png", "scale": 8, "x": ' + "[" * 200000
                                      + "]" * 200000 + "}")
    return hopmatch.datasets.load_scene(d)
''', "refuse:")
lib("fuzz", "gradient_windows(g, float32 points holding NaN) (NaN rows)", '''
def case():
    g = np.random.default_rng(0).random((50, 50)).astype(np.float32)
    return hopmatch.gradient_windows(g, np.array([[np.nan, 5]], np.float32), 3)
''', "refuse:points")
lib("fuzz", "HopfieldMatcher on points at negative x, no image sizes (a range refused)", '''
def case():
    rng = np.random.default_rng(0); p = rng.uniform(0, 300, (400, 2)).astype(np.float32) - 400
    d = rng.normal(size=(400, 25)).astype(np.float32)
    m = hopmatch.HopfieldMatcher.create(); m.setPairInfo(p, p); return m.match(d, d)
''', "run")
lib("fuzz", "match_stereo(record_energy='x') (read as True)", '''
def case():
    l, r = noise_pair(); return hopmatch.match_stereo(l, r, record_energy="x")
''', "refuse:record_energy")
lib("fuzz", "matches_table of 2 left and 1 right points (cut silently)", '''
def case():
    from hopmatch import tables
    lp = np.float32([[10, 10], [20, 20]])
    return tables.matches_table(lp, lp[:1], np.ones(2), np.ones(2))
''', "refuse:")
lib("fuzz", "viz.draw_labelled_matches(gap=10**9) (MemoryError)", '''
def case():
    img = np.zeros((50, 60), np.uint8); kp = [cv2.KeyPoint(10, 10, 5)]
    return hopmatch.viz.draw_labelled_matches(img, img, kp, kp, [cv2.DMatch(0, 0, .1)],
                                              gap=10**9)
''', "refuse:gap")
lib("fuzz", "viz.draw_keypoints(color='red') (cv2.error)", '''
def case():
    return hopmatch.viz.draw_keypoints(np.zeros((50, 60), np.uint8), [cv2.KeyPoint(10, 10, 5)],
                                       color="red")
''', "refuse:color")
lib("fuzz", "files.write_text_atomic(path, bytes) (AttributeError)", '''
def case():
    import hopmatch.files
    return hopmatch.files.write_text_atomic("/tmp/probe/x.txt", b"abc")
''', "refuse:text")
lib("fuzz", "match_stereo(rectified=False) on a 2964 x 2000 pair (BudgetExceededError)", '''
def case():
    import skimage.data
    l, r, _ = skimage.data.stereo_motorcycle()
    l, r = (cv2.resize(v, (2964, 2000)) for v in (l, r))  # colour, bilinear
    return hopmatch.match_stereo(l, r, rectified=False)
''', "matches-or-refuse:", timeout=120)
lib("fuzz", "knnMatch(k=2000) of 2000 points (28 s in the padding)", '''
def case():
    rng = np.random.default_rng(0); n = 2000
    p = rng.uniform(0, 400, (n, 2)).astype(np.float32); d = rng.normal(size=(n, 25)).astype(np.float32)
    m = hopmatch.HopfieldMatcher.create(max_disparity=8); m.setPairInfo(p, p, (400, 400), (400, 400))
    return m.knnMatch(d, d, k=n)
''', "len-or-refuse:", timeout=12)


# ========================================================================== runner
def classify(expect, res, seconds, rc=None, stderr=""):
    if res is None:
        return "FAIL"
    o = res
    if expect.startswith(("refuse", "run-or-refuse", "matches-or-refuse", "len-or-refuse")):
        want = expect.split(":", 1)[1]
        if o["outcome"] == "raised":
            if not (o["hopmatch"] and o["vt"]):
                return "FAIL"
            if "fast" in expect and o["seconds"] > 1.0:
                return "FAIL"
            if o["seconds"] > 1.0:
                return "FAIL"
            if "noloop" in expect and "no such file" in o["msg"]:
                return "FAIL"
            if "clean" in expect and ".tmp" in o["msg"]:
                return "FAIL"
            if want and want not in (o.get("argument") or "") and f"`{want}`" not in o["msg"] \
                    and want not in o["msg"]:
                return "FAIL"
            return "ok"
        if expect.startswith("run-or-refuse"):
            return "ok"
        if expect.startswith("matches-or-refuse"):
            return "ok" if o.get("matches", 0) > 0 or o.get("warnings") else "FAIL"
        if expect.startswith("len-or-refuse"):
            return "ok" if o.get("len", 0) > 0 else "FAIL"
        return "FAIL"
    if expect == "run":
        return "ok" if o["outcome"] == "returned" else "FAIL"
    if expect.startswith("returned-none"):
        return "ok" if o["outcome"] == "returned" and o.get("repr") == "None" and \
            ("fast" not in expect or o["seconds"] < 1) else "FAIL"
    if expect == "true":
        return "ok" if o["outcome"] == "returned" and o.get("repr") == "True" else "FAIL"
    if expect.startswith("matches-or-warning"):
        n = int(expect.split(":")[1])
        return "ok" if o["outcome"] == "returned" and (o.get("matches", 0) >= n or o.get("warnings")) else "FAIL"
    if expect == "warning":
        return "ok" if o["outcome"] == "returned" and (o.get("warnings") or o.get("matches", 0) > 100) else "FAIL"
    if expect == "no-wrong":
        return "ok" if o["outcome"] == "returned" else "FAIL"
    if expect in ("unchanged", "clean"):
        return "ok" if o["outcome"] == "returned" and o.get("repr") in (repr(expect), repr("not reached")) else "FAIL"
    if expect == "unchanged-or-new":
        return "ok" if o["outcome"] == "returned" else "FAIL"
    return "FAIL"


def run_lib(code, timeout):
    src = PRELUDE + code + RUN
    t = time.time()
    try:
        p = subprocess.run([PY, "-c", src], capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, f"HANG (> {timeout} s)"
    line = next((l for l in p.stdout.splitlines() if l.startswith("@@")), None)
    if line is None:
        return None, f"rc={p.returncode}: {' '.join(p.stderr.split()[-30:])[:300]}"
    res = json.loads(line[2:])
    if res["outcome"] == "raised":
        desc = f"{res['type']} ({'hopmatch' if res['hopmatch'] else 'FOREIGN'}) in {res['seconds']} s: {res['msg'][:160]}"
    else:
        desc = f"returned {({k: v for k, v in res.items() if k not in ('outcome',)})}"[:300]
    return res, desc


def run_cli(spec, expect, timeout):
    import tempfile
    args, setup, check, user = spec
    tmp = tempfile.mkdtemp(prefix="probe")
    os.chmod(tmp, 0o777)
    if setup:
        open(f"{tmp}/pairs.csv", "w").write(setup)
    args = [a.replace("{tmp}", tmp) for a in args]
    env = dict(os.environ, NUMBA_CACHE_DIR="/tmp/probe/numba-cache")
    cmd = [HOPMATCH, "-q", *args]
    if user:
        cmd = [PY, "-c", "import os, sys; from hopmatch.cli import main; os.setuid(%d); "
               "sys.exit(main(sys.argv[1:]))" % user, "-q", *args]
    t = time.time()
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout,
                           env=env, cwd=tmp)
    except subprocess.TimeoutExpired:
        return "FAIL", f"HANG (> {timeout} s)"
    dt = time.time() - t
    err = " ".join(p.stderr.split())[:220]
    desc = f"exit {p.returncode} in {dt:.1f} s: {err}"
    if expect == "summary":
        ok = os.path.exists(f"{tmp}/o/summary.csv")
        return ("ok" if ok else "FAIL"), desc + ("" if ok else " (no summary.csv)")
    if expect == "exit0":
        return ("ok" if p.returncode == 0 else "FAIL"), desc
    ok = p.returncode == 2 and "internal error" not in p.stderr and "Traceback" not in p.stderr
    if "nohint" in expect and "create(--" in p.stderr:
        ok = False
    if "fast" in expect and dt > 4:
        ok = False
    if "noloop" in expect and "no such file" in p.stderr:
        ok = False
    return ("ok" if ok else "FAIL"), desc


counts = {}
for how, kind, name, spec, expect, timeout in CASES:
    if ONLY and kind not in ONLY:
        continue
    if how == "lib":
        res, desc = run_lib(spec, timeout)
        verdict = classify(expect, res, None)
    else:
        verdict, desc = run_cli(spec, expect, timeout)
    c = counts.setdefault(kind, [0, 0])
    c[0] += 1
    c[1] += verdict == "ok"
    print(f"[{verdict:4}] {kind:9} | {name} | {desc}", flush=True)
print()
for kind, (n, ok) in counts.items():
    print(f"{kind:10} {n:3} cases, {ok:3} ok, {n - ok:3} failing")
print(f"{'total':10} {sum(c[0] for c in counts.values()):3} cases, {sum(c[1] for c in counts.values()):3} ok")
