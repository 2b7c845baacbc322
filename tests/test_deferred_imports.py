"""Every ``from <project module> import name`` in the project — at the top of a module or
deferred inside a function — names something the module has.

A deferred import is checked only when its function runs: evaluate.py's paper protocol imported
``CubeJob`` from training.learning.dataset, which had named it ``_CubeJob``, and ``make eval``
died after 45 minutes of rendering. This reads the imports from the source instead."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ROOTS = ("cd_spectra_addon", "training", "tools")
CHECKED = ("cd_spectra_addon.core", "cd_spectra_addon.cli", "training")  # importable without Blender


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports() -> list[tuple[str, int, str, str]]:
    """(file, line, module, name) of every from-import of a project module that CHECKED covers."""
    found = []
    for root in ROOTS:
        for path in sorted((REPO / root).rglob("*.py")):
            here = _module_name(path)
            package = here if path.name == "__init__.py" else here.rpartition(".")[0]
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if not isinstance(node, ast.ImportFrom):
                    continue
                if node.level:
                    base = package.split(".")
                    base = base[: len(base) - (node.level - 1)] if node.level > 1 else base
                    target = ".".join(base + ([node.module] if node.module else []))
                else:
                    target = node.module or ""
                if not target.startswith(CHECKED):
                    continue
                for alias in node.names:
                    if alias.name != "*":
                        found.append((str(path.relative_to(REPO)), node.lineno, target, alias.name))
    return found


def test_the_scan_finds_deferred_imports():
    where = {(f, m, n) for f, _, m, n in _imports()}
    assert ("training/evaluation/evaluate.py", "training.learning.dataset", "CubeJob") in where


@pytest.mark.blender  # training's renderers import bpy
def test_every_imported_name_exists():
    missing = []
    for file, line, target, name in _imports():
        try:
            module = importlib.import_module(target)
        except ModuleNotFoundError as exc:
            if exc.name and exc.name.split(".")[0] in ("bpy", "mathutils", "onnx"):
                continue  # a module that needs Blender or an optional package: not checked here
            missing.append(f"{file}:{line}: {target} does not exist ({exc})")
            continue
        if not hasattr(module, name):
            try:
                importlib.import_module(f"{target}.{name}")  # a submodule
            except ModuleNotFoundError:
                missing.append(f"{file}:{line}: {target} has no {name!r}")
    assert not missing, "\n".join(missing)
