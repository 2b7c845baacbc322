"""Install this platform's built zips, wheels and all, into headless Blender of each Python.

    python tools/install_check.py [--dist dist] [--python PATH ...] [--out bench/extension_install.md]

For every interpreter given (default: .venv, bpy 4.5 / Python 3.11, and .venv313, bpy 5.2 /
Python 3.13) and every zip of this platform in dist/ (``make extension`` first), a fresh
Blender user folder (``BLENDER_USER_RESOURCES`` in a temporary directory) gets a user
repository and ``bpy.ops.extensions.package_install_files`` is asked to install and enable the
zip. The table says whether Blender accepted it (the two builds' ranges must not overlap: each
Blender takes exactly one), and for an accepted zip which of its wheels Blender unpacked into its
``extensions/.local`` site-packages and whether they import there next to Blender's numpy (a
child process with that folder first on ``sys.path``, so the venv's copies cannot stand in).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from tools.build_extension import SMOKE_IMPORTS, this_platform  # noqa: E402

INSTALL = r"""
import bpy, glob, json, os, sys
repo_dir = os.path.join(os.environ["BLENDER_USER_RESOURCES"], "repo")
os.makedirs(repo_dir, exist_ok=True)
bpy.context.preferences.extensions.repos.new(name="check", module="check_repo", custom_directory=repo_dir,
                                             source="USER")
try:
    result = sorted(bpy.ops.extensions.package_install_files(filepath=sys.argv[1], repo="check_repo",
                                                             enable_on_install=True))
except RuntimeError as exc:
    result = ["RuntimeError: " + " ".join(str(exc).split())[:200]]
sites = glob.glob(os.path.join(os.environ["BLENDER_USER_RESOURCES"], "extensions", ".local", "lib", "*",
                               "site-packages"))
print(json.dumps({"blender": bpy.app.version_string, "python": sys.version.split()[0], "result": result,
                  "enabled": "bl_ext.check_repo.cd_spectra" in bpy.context.preferences.addons,
                  "site": sites[0] if sites else None}))
"""

IMPORTS = r"""
import json, sys
site = sys.argv[1]
sys.path.insert(0, site)
import numpy
out = {"numpy": numpy.__version__}
for name in json.loads(sys.argv[2]):
    module = __import__(name, fromlist=["_"])
    origin = getattr(module, "__file__", "") or ""
    out[name] = (getattr(module, "__version__", "?") if origin.startswith(site) else "NOT FROM THE ZIP")
print(json.dumps(out))
"""


def last_json(text: str) -> dict:
    for line in reversed(text.strip().splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    raise SystemExit(f"error: no result from Blender:\n{text[-2000:]}")


def check(python: Path, zip_path: Path) -> dict:
    with tempfile.TemporaryDirectory() as user:
        env = {**os.environ, "BLENDER_USER_RESOURCES": user}
        proc = subprocess.run([str(python), "-c", INSTALL, str(zip_path)], capture_output=True, text=True, env=env,
                              timeout=600, cwd=user)
        report = last_json(proc.stdout)
        report["imports"] = None
        if report["enabled"] and report["site"]:
            proc = subprocess.run([str(python), "-c", IMPORTS, report["site"], json.dumps(list(SMOKE_IMPORTS.values()))],
                                  capture_output=True, text=True, cwd=user, timeout=300)
            report["imports"] = last_json(proc.stdout) if proc.returncode == 0 else {"error": proc.stderr[-300:]}
        return report


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dist", type=Path, default=ROOT / "dist")
    p.add_argument("--python", type=Path, action="append",
                   help="an interpreter with the bpy wheel (repeatable; default .venv and .venv313)")
    p.add_argument("--out", type=Path, help="also write the table here (Markdown)")
    args = p.parse_args(argv)
    pythons = args.python or [p for p in (ROOT / ".venv" / "bin" / "python", ROOT / ".venv313" / "bin" / "python")
                              if p.exists()]
    here = (this_platform() or "?").replace("-", "_")
    zips = sorted(args.dist.glob(f"cd_spectra-*-{here}.zip"))
    if not zips:
        raise SystemExit(f"error: no {here} zips in {args.dist} (make extension)")
    lines = ["# Installing the built zips into headless Blender", "",
             f"`python tools/install_check.py` on {here}: each zip, wheels included, installed with "
             "`bpy.ops.extensions.package_install_files` into a fresh Blender user folder; the wheels "
             "imported from Blender's `extensions/.local` site-packages next to Blender's numpy.", "",
             "| Blender (bpy) | Python | zip | installed and enabled (the zip's range) | wheels imported from the zip |",
             "|---|---|---|---|---|"]
    for python in pythons:
        for zip_path in zips:
            r = check(python, zip_path)
            with zipfile.ZipFile(zip_path) as zf:
                manifest = tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))
            span = f"{manifest['blender_version_min']} ≤ Blender < {manifest.get('blender_version_max', '∞')}"
            imports = r["imports"]
            shown = ", ".join(f"{k} {v}" for k, v in imports.items()) if imports else "—"
            lines.append(f"| {r['blender']} | {r['python']} | `{zip_path.name}` | "
                         f"{'yes' if r['enabled'] else 'no, declined'} ({span}) | {shown} |")
            print(lines[-1], flush=True)
    if args.out:
        args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
