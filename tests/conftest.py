"""Shared fixtures, and the rule that keeps ``make test-fast`` honest.

``make test-fast`` runs ``-m "not slow and not blender"``; ``make test`` (CI) runs everything.
A test that uses Blender but lacks the ``blender`` marker would slip into the inner loop, so the
marker is enforced, not trusted:

- at collection, a test whose code (or a fixture it uses, or its module at import) names bpy,
  Blender's own modules or a project module that needs them is an error unless marked;
- at run time, an unmarked test that imports bpy fails. The check wraps ``__import__``, which
  also sees ``import bpy`` of a module that is already loaded, so test order does not hide it.

bpy is pinned (requirements.txt): tests import it plainly and never skip without it.
"""

from __future__ import annotations

import types
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest
from hypothesis import settings
from import_watch import ImportWatch, is_blender

# Hypothesis fails an example that runs longer than its deadline (200 ms by default): a wall-clock
# assertion that a busy shared machine can break. No test here has one (most already said so).
settings.register_profile("cd-spectra", deadline=None)
settings.load_profile("cd-spectra")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)


def _code_names(code: types.CodeType) -> Iterator[str]:
    yield from code.co_names
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            yield from _code_names(const)


def _names_blender(func: Any, depth: int = 2) -> str | None:
    """The first name in ``func``'s code (or, ``depth`` calls down, in a plain function it names)
    that is Blender or refers to it, else None."""
    func = getattr(func, "__wrapped__", func)
    code = getattr(func, "__code__", None)
    if code is None:
        return None
    scope = getattr(func, "__globals__", {})
    for name in _code_names(code):
        if is_blender(name):
            return name
        value = scope.get(name)
        owner = value.__name__ if isinstance(value, types.ModuleType) else getattr(value, "__module__", None)
        if isinstance(owner, str) and is_blender(owner):
            return f"{name} ({owner})"
        if depth > 0 and isinstance(value, types.FunctionType) and value is not func:
            if (why := _names_blender(value, depth - 1)) is not None:
                return f"{name} → {why}"
    return None


def _blender_use(item: pytest.Function) -> str | None:
    """Why ``item`` needs Blender, judged from its code, its fixtures and its module."""
    module = item.module
    for name, value in vars(module).items():
        if isinstance(value, types.ModuleType) and is_blender(value.__name__):
            return f"its module imports {value.__name__} at the top"
    if (why := _names_blender(item.function)) is not None:
        return f"it uses {why}"
    for fixture_name in item.fixturenames:
        for fixturedef in item._fixtureinfo.name2fixturedefs.get(fixture_name, ()):
            if (why := _names_blender(fixturedef.func)) is not None:
                return f"its fixture {fixture_name!r} uses {why}"
    return None


# The files whose tests take minutes, longest first (CI's --durations, 9a82b99): run first, so
# that under xdist's --dist loadfile (a file stays on one worker) the longest file does not start
# last and leave the other core idle at the end. Order only; nothing else depends on it.
LONG_FILES = ("test_training.py", "test_calibration_shots.py", "test_properties.py", "test_hostile_inputs.py",
              "test_cycles_render.py", "test_censoring.py", "test_soak.py")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    rank = {name: k for k, name in enumerate(LONG_FILES)}
    items.sort(key=lambda item: rank.get(item.path.name, len(LONG_FILES)))  # stable: the rest keep their order
    unmarked = []
    for item in items:
        if isinstance(item, pytest.Function) and item.get_closest_marker("blender") is None:
            if (why := _blender_use(item)) is not None:
                unmarked.append(f"  {item.nodeid}: {why}")
    if unmarked:
        raise pytest.UsageError("tests that use Blender must be marked @pytest.mark.blender "
                                "(make test-fast deselects them):\n" + "\n".join(unmarked))


def _watched(item: pytest.Item) -> Iterator[None]:
    if item.get_closest_marker("blender") is not None:
        return (yield)
    with ImportWatch() as watch:
        result = yield
    if watch.seen:
        raise pytest.fail.Exception(f"{item.nodeid} imported {', '.join(watch.seen)} without "
                                    "@pytest.mark.blender (make test-fast would run it)", pytrace=False)
    return result


@pytest.hookimpl(wrapper=True)
def pytest_runtest_setup(item: pytest.Item) -> Iterator[None]:
    return (yield from _watched(item))


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item: pytest.Item) -> Iterator[None]:
    return (yield from _watched(item))
