"""The core is a plain numpy package: it imports without Blender or torch, has no import cycle,
and its sub-packages import only downwards (:data:`LAYERS`).

The import graph is read from every module's AST, function-level imports included (a lazy
import is still a dependency: it only hides a cycle until the function runs).
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
CORE = REPO / "cd_spectra_addon" / "core"
PACKAGE = "cd_spectra_addon.core"
FORBIDDEN = ("bpy", "torch")


# The core's sub-packages from the bottom up: a module may import its own package, the core's
# root modules (errors, user_folders) and any package on a lower floor — never one on its own
# floor or above. The same map is drawn in README's "How it works".
LAYERS: tuple[tuple[str, ...], ...] = (
    ("numerics",),
    ("photo", "spectra"),
    ("scene", "rendition"),
    ("readout", "planning"),
    ("pose", "spectrum"),
    ("calibration",),
    ("inverse",),
)
FLOOR = {pkg: i for i, floor in enumerate(LAYERS) for pkg in floor}


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(CORE.rglob("*.py")):
        parts = path.relative_to(CORE).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join((PACKAGE, *parts))] = path
    return out


def _package_of(module: str) -> str | None:
    """The core sub-package a module belongs to (None: the core's root modules)."""
    parts = module[len(PACKAGE) + 1:].split(".") if module.startswith(PACKAGE + ".") else []
    return parts[0] if parts and parts[0] in FLOOR else None


def _upward(graph: dict[str, set[str]]) -> list[str]:
    """Every import that is not downwards: into a package on the same floor or above, or from a
    root module into any package."""
    bad = []
    for src, targets in graph.items():
        a = _package_of(src)
        for dst in sorted(targets):
            b = _package_of(dst)
            if b is None or a == b:
                continue
            if a is None or FLOOR[b] >= FLOOR[a]:
                bad.append(f"{src} → {dst}")
    return bad


def _imports(name: str, path: Path) -> list[tuple[str, int]]:
    """Absolute names of everything ``path`` imports, anywhere in the file, with line numbers.
    ``from . import x`` yields the submodule ``pkg.x`` (and ``pkg`` itself)."""
    package = name if path.stem == "__init__" else name.rpartition(".")[0]
    found = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [(alias.name, node.lineno) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - (node.level - 1)]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            found.append((module, node.lineno))
            found += [(f"{module}.{alias.name}", node.lineno) for alias in node.names]
    return found


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: {target for target, _ in _imports(name, path) if target in modules and target != name}
            for name, path in modules.items()}


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle as [a, b, ..., a], or None (depth-first search with colours)."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for start in sorted(graph):
        if start not in state and (found := visit(start)):
            return found
    return None


def test_cycle_finder_finds_cycles():
    """The check itself: a cycle through a function-level import is one."""
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None
    assert _cycle({"a": {"a"}}) == ["a", "a"]


def test_relative_imports_are_resolved(tmp_path: Path):
    src = tmp_path / "estimate.py"
    src.write_text("from . import colour\nfrom .errors import X\n\ndef f():\n    from ..blender import light\n",
                   encoding="utf-8")
    names = {n for n, _ in _imports(f"{PACKAGE}.estimate", src)}
    assert {f"{PACKAGE}.colour", f"{PACKAGE}.errors", "cd_spectra_addon.blender.light"} <= names


def test_the_core_has_no_import_cycle():
    graph = _graph()
    assert len(graph) >= 20 and graph[f"{PACKAGE}.inverse.estimate"], "the graph was not read"
    cycle = _cycle(graph)
    assert cycle is None, "import cycle: " + " → ".join(cycle or [])


def test_layer_check_finds_upward_imports():
    """The check itself: same floor, upwards and root-into-package imports are caught."""
    graph = {f"{PACKAGE}.scene.capture": {f"{PACKAGE}.readout.readout", f"{PACKAGE}.errors",
                                          f"{PACKAGE}.spectra.grid", f"{PACKAGE}.scene.grating"},
             f"{PACKAGE}.photo.images": {f"{PACKAGE}.spectra.colour"},
             f"{PACKAGE}.errors": {f"{PACKAGE}.numerics.nnls"}}
    assert _upward(graph) == [f"{PACKAGE}.scene.capture → {PACKAGE}.readout.readout",
                              f"{PACKAGE}.photo.images → {PACKAGE}.spectra.colour",
                              f"{PACKAGE}.errors → {PACKAGE}.numerics.nnls"]


def test_every_core_package_has_a_floor():
    packages = {p.name for p in CORE.iterdir() if p.is_dir() and (p / "__init__.py").is_file()}
    assert packages == set(FLOOR), f"packages without a floor in LAYERS: {packages - set(FLOOR)}"


def test_core_packages_import_only_downwards():
    bad = _upward(_graph())
    assert not bad, "upward imports:\n" + "\n".join(bad)


def test_no_module_imports_another_modules_private_names():
    """``from x import _name`` couples two modules through what one of them calls internal."""
    bad = []
    for path in [*sorted((REPO / "cd_spectra_addon").rglob("*.py")), *sorted((REPO / "training").rglob("*.py")),
                 *sorted((REPO / "tools").rglob("*.py"))]:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                bad += [f"{path.relative_to(REPO)}:{node.lineno} {alias.name}" for alias in node.names
                        if alias.name.startswith("_") and not alias.name.startswith("__")]
    assert not bad, "private names imported:\n" + "\n".join(bad)


@pytest.mark.parametrize("name", sorted(_modules()))
def test_no_core_module_mentions_blender_or_torch(name):
    """Not even inside a function: the core runs in Blender's Python and in the CLI alike."""
    bad = [(target, line) for target, line in _imports(name, _modules()[name])
           if target.split(".")[0] in FORBIDDEN or target.startswith("cd_spectra_addon.blender")]
    assert not bad, f"{name} imports {bad}"


def test_every_core_module_imports_without_bpy_or_torch():
    """In a fresh interpreter where importing bpy or torch fails, every core module imports,
    and neither ends up loaded."""
    code = f"""
import importlib, importlib.abc, json, sys
class Refuse(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {FORBIDDEN!r}:
            raise ImportError("blocked by the test: " + name)
        return None
sys.meta_path.insert(0, Refuse())
failed = {{}}
for name in {sorted(_modules())!r}:
    try:
        importlib.import_module(name)
    except Exception as exc:
        failed[name] = repr(exc)
print(json.dumps({{"failed": failed, "loaded": sorted(m for m in sys.modules if m.split(".")[0] in {FORBIDDEN!r})}}))
"""
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120,
                         check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    assert result == {"failed": {}, "loaded": []}
