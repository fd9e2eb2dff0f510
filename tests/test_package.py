"""The package as users meet it: ``import hopmatch`` reaches every submodule without
importing them (issue 19, point 2), and the install extras bring what each plugin needs
(point 1)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAZY = ("stereo", "datasets", "evaluate", "viz", "compare", "cli", "imageio")


def _python(code: str) -> str:
    res = subprocess.run([sys.executable, "-c", code], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    return res.stdout


# --------------------------------------------------------------------------------------
# Submodules reachable from `import hopmatch`, imported on first use
# --------------------------------------------------------------------------------------


def test_submodules_are_reachable_from_the_package():
    """What the warnings and the docs write (``hopmatch.stereo.rectify``) works after a
    bare ``import hopmatch``, in a fresh interpreter."""
    out = _python(
        "import hopmatch\n"
        "print(hopmatch.stereo.rectify.__name__, hopmatch.datasets.load.__name__,\n"
        "      hopmatch.evaluate.score_matches.__name__, hopmatch.viz.draw_matches.__name__,\n"
        "      hopmatch.compare.METHODS is not None, hopmatch.cli.main.__name__,\n"
        "      hopmatch.imageio.read_image.__name__)\n")
    assert out.split() == ["rectify", "load", "score_matches", "draw_matches", "True", "main",
                           "read_image"]


def test_import_does_not_load_the_lazy_submodules():
    out = _python("import sys, hopmatch\n"
                  f"print([m for m in {LAZY!r} if 'hopmatch.' + m in sys.modules])\n")
    assert out.strip() == "[]"


def test_lazy_submodules_are_listed_and_unknown_names_still_fail():
    import hopmatch

    assert set(LAZY) <= set(dir(hopmatch))
    assert set(LAZY) == set(hopmatch.LAZY_SUBMODULES)
    with pytest.raises(AttributeError, match="has no attribute 'stereoo'"):
        hopmatch.stereoo  # noqa: B018
    # the names of today still import from where they import today
    from hopmatch.stereo import rectify
    from hopmatch.viz import write_text_atomic

    assert hopmatch.stereo.rectify is rectify and callable(write_text_atomic)


# --------------------------------------------------------------------------------------
# Install extras
# --------------------------------------------------------------------------------------


def _requirement_map(requirements) -> dict[str, str]:
    """``{distribution name: specifier text}`` of PEP 508 requirement strings."""
    out = {}
    for req in requirements:
        m = re.match(r"^\s*([A-Za-z0-9_.-]+)(\[[^\]]*\])?\s*(.*)$", req)
        out[m.group(1).lower()] = m.group(3).replace(" ", "")
    return out


@pytest.fixture(scope="module")
def project():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]


def test_core_install_allows_opencv_5(project):
    core = _requirement_map(project["dependencies"])
    assert "<5" not in core["opencv-contrib-python-headless"]


def test_gapi_extra_brings_an_opencv_with_python_gapi_ops(project):
    """OpenCV 5.0's wheels lack the Python G-API custom operations the plugin needs: its
    extra caps OpenCV below 5, from 4.8 on."""
    gapi = _requirement_map(project["optional-dependencies"]["gapi"])
    spec = gapi["opencv-contrib-python-headless"]
    assert "<5" in spec and ">=4.8" in spec


def test_all_extra_is_every_plugin_working(project):
    extras = project["optional-dependencies"]
    everything = _requirement_map(extras["all"])
    for plugin in ("gapi", "dask", "plots"):
        for name, spec in _requirement_map(extras[plugin]).items():
            assert everything.get(name) == spec, (plugin, name)


def test_ci_keeps_a_second_environment_on_opencv_5(project):
    """The second environment of .ci/run installs the test extra beside OpenCV 5: the test
    extra must not cap OpenCV (pip would refuse the pair), and nothing there asks for
    ``gapi`` or ``all``."""
    run = (ROOT / ".ci" / "run").read_text()
    line = next(ln for ln in run.splitlines() if ".venv-cv5/bin/pip install" in ln)
    assert '"opencv-contrib-python-headless>=5,<6"' in line
    assert "[test]" in line and "gapi" not in line and "all]" not in line
    test = _requirement_map(project["optional-dependencies"]["test"])
    assert "opencv-contrib-python-headless" not in test
    constraints = (ROOT / ".ci" / "constraints.txt").read_text()
    assert "-c .ci/constraints.txt" not in line
    assert "opencv-contrib-python-headless<5" in constraints


def test_installed_metadata_has_the_extras():
    """The installed distribution (this venv) declares the same extras."""
    from importlib.metadata import metadata

    extras = set(metadata("hopmatch").get_all("Provides-Extra") or ())
    assert {"gapi", "dask", "plots", "all", "test", "docs"} <= extras
