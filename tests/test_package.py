"""The package as users meet it: ``import hopmatch`` reaches every submodule without
importing them (issue 19, point 2), and the install extras bring what each plugin needs
(point 1)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


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
    assert "-c .ci/constraints.txt" not in line and "opencv-contrib-python-headless<5" in constraints


def test_installed_metadata_has_the_extras():
    """The installed distribution (this venv) declares the same extras."""
    from importlib.metadata import metadata

    extras = set(metadata("hopmatch").get_all("Provides-Extra") or ())
    assert {"gapi", "dask", "plots", "all", "test", "docs"} <= extras
