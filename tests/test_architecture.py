"""The house rules of hopmatch/ (issue 16): no module imports another module's underscore
names, and no module is a grab-bag of more than about 600 lines."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "hopmatch"
MODULES = sorted(PACKAGE.rglob("*.py"))
MAX_LINES = 650


def _private_imports(source: str, label: str) -> list[str]:
    tree = ast.parse(source)
    bad = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.level or (node.module or "").startswith(
                "hopmatch")):
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    bad.append(f"{label}:{node.lineno} imports "
                               f"{alias.name} from {'.' * node.level}{node.module or ''}")
    return bad


def test_the_checks_see_the_package():
    assert len(MODULES) > 20


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_module_imports_another_modules_private_names(path):
    assert _private_imports(path.read_text(encoding="utf-8"), path.name) == []


def test_the_private_import_check_can_fail():
    source = ("from .other import _hidden\nfrom hopmatch.x import visible, _also\n"
              "from numpy import _private_but_not_ours\nfrom . import __version__\n")
    assert len(_private_imports(source, "probe.py")) == 2


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_module_is_a_grab_bag(path):
    n = len(path.read_text(encoding="utf-8").splitlines())
    assert n <= MAX_LINES, f"{path.name} has {n} lines"


PLUGINS = Path(__file__).resolve().parents[1] / "plugins"
PLUGIN_MODULES = sorted(PLUGINS.rglob("*.py"))


def _private_hopmatch_imports(source: str, label: str) -> list[str]:
    """Imports of hopmatch's underscore modules (``hopmatch._files``) or names, from code
    outside the package: what the plugins may not do."""
    bad = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            names = [f"{node.module}.{alias.name}" for alias in node.names]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "hopmatch" and any(p.startswith("_") and not p.startswith("__")
                                              for p in parts[1:]):
                bad.append(f"{label}:{node.lineno} imports {name}")
    return bad


def test_the_plugin_checks_see_the_plugins():
    assert {p.parent.name for p in PLUGIN_MODULES} >= {"hopmatch_dask", "hopmatch_gapi"}


@pytest.mark.parametrize("path", PLUGIN_MODULES, ids=lambda p: str(p.relative_to(PLUGINS)))
def test_no_plugin_imports_hopmatchs_underscore_modules_or_names(path):
    assert _private_hopmatch_imports(path.read_text(encoding="utf-8"), path.name) == []


def test_the_plugin_import_check_can_fail():
    source = ("import hopmatch._files\nfrom hopmatch._tables import x\n"
              "from hopmatch.files import _hidden\nfrom hopmatch import _threads\n"
              "from hopmatch.files import read_input_bytes\nimport hopmatch\n"
              "from . import _local\nimport numpy._core\n")
    assert len(_private_hopmatch_imports(source, "probe.py")) == 4
