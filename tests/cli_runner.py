"""The command line's ``main(argv)`` run for a test, with a fake estimator, in this process.

A child Python per call (``python -c FAKE``) cost ~0.15 s of start-up and imports each, ~7 s of
``make test-fast``'s CPU over ~45 calls, for what the same ``main`` does in a few milliseconds
here. What a child gave for free is kept: the fake modules, the working folder and the
environment are restored afterwards; stdout and stderr are captured apart; an escaping exception
or ``SystemExit`` becomes the exit code a child would give; and the run's stderr ends with
``BPY_LOADED`` where ``main`` imported bpy (the line the child runner printed), seen by
conftest's watch of ``__import__`` (:mod:`import_watch`). The entry point itself (``python -m cd_spectra_addon``)
stays tested through real children: every ``fake=False`` run and ``--blend``.
"""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import traceback
from pathlib import Path

from import_watch import ImportWatch


def run_in_process(args: tuple[str, ...], prelude: str, cwd: Path,
                   env_extra: dict[str, str] | None = None, blender_line: bool = True
                   ) -> subprocess.CompletedProcess[str]:
    """``main(args)`` after ``prelude`` (code that puts fake modules into ``sys.modules``);
    ``blender_line``: end stderr with BPY_LOADED / BPY_NOT_LOADED, as test_cli's child runner did."""
    from cd_spectra_addon.__main__ import main  # imported first: nothing binds a fake at its import

    before = dict(sys.modules)
    saved_env, saved_cwd = dict(os.environ), os.getcwd()
    out, err = io.StringIO(), io.StringIO()
    watch = ImportWatch()
    try:
        os.environ.update(env_extra or {})
        os.chdir(cwd)
        exec(compile(prelude, "<fake estimator>", "exec"), {"__name__": "fake_estimator"})
        with watch, contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = main(list(args))
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except BaseException:  # what an uncaught exception does to a child: a traceback, exit 1
                traceback.print_exc()
                code = 1
    finally:
        os.chdir(saved_cwd)
        os.environ.clear()
        os.environ.update(saved_env)
        for name, module in list(sys.modules.items()):
            if getattr(module, "__spec__", None) is None and before.get(name) is not module:
                if name in before:  # a fake the prelude put in place of a real module
                    sys.modules[name] = before[name]
                else:
                    del sys.modules[name]
    if blender_line:
        loaded = any(name == "bpy" or name.startswith("bpy.") for name in watch.seen)
        print("BPY_LOADED" if loaded else "BPY_NOT_LOADED", file=err)
    return subprocess.CompletedProcess(["main", *args], int(code), out.getvalue(), err.getvalue())
