"""Build the Blender extension: one zip per platform in dist/, each validated and smoke-tested.

    python tools/build_extension.py [--dist DIR] [--offline] [--skip-smoke-test]

1. Download the pinned wheels for every platform (``pip download --only-binary=:all: --no-deps``)
   into build/wheels/ (git-ignored, reused between builds; --offline uses only what is there).
2. Stage the add-on in build/extension/: the files git knows (tracked or not ignored), the
   wheels, and a copy of blender_manifest.toml with the wheel list written in. The committed
   manifest keeps ``wheels = []`` so the pins live in one place (below).
3. ``blender_ext.py build --split-platforms`` (Blender's own tool from the bpy wheel), then
   ``blender_ext.py validate`` on every zip.
4. Smoke test on this machine: the wheels of this platform's zip are unpacked next to the venv's
   numpy 1.26 (what Blender bundles) in a Python started with ``-S`` (no site-packages), and must
   import; onnxruntime must load every model in models/ and run it.

Why these wheels and versions: see README, "Installing the extension".
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
import zipfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "blender_manifest.toml"
WHEEL_CACHE = ROOT / "build" / "wheels"
STAGE = ROOT / "build" / "extension"
PYTHON_VERSION = "3.11"  # Blender 4.2–5.0


@dataclass(frozen=True)
class Platform:
    blender: str  # Blender's platform name (manifest "platforms")
    pip: str  # the pip --platform tag: the oldest OS this Blender platform supports


# Blender 4.2 needs glibc 2.28 on Linux and macOS 11.2 on both Macs.
PLATFORMS = (
    Platform("linux-x64", "manylinux_2_28_x86_64"),
    Platform("windows-x64", "win_amd64"),
    Platform("macos-arm64", "macosx_11_0_arm64"),
    Platform("macos-x64", "macosx_11_0_x86_64"),
)

# Pins per platform. onnxruntime 1.18.1 everywhere: the last release built with the VS 2019
# toolset (1.19+ fail to load inside Blender on Windows, whose bundled VC++ runtime is older than
# they need), the last with macOS 11 wheels (1.19+ need macOS 13; Blender 4.2 supports 11.2),
# built against numpy 1.x (Blender bundles numpy 1.26). One version on every platform means the
# model is tested against the one runtime every user gets. Its declared dependencies (sympy,
# protobuf, coloredlogs, flatbuffers, packaging) are not needed to load and run a model (the
# smoke test below proves it with none of them installed) and are left out: ~8 MB a zip.
PINS: dict[str, dict[str, str]] = {
    "onnxruntime": {p.blender: "1.18.1" for p in PLATFORMS},
    "pillow": {p.blender: "13.0.0" for p in PLATFORMS},
    "openexr": {p.blender: "3.5.3" for p in PLATFORMS},
}
NEVER_BUNDLE = ("numpy",)  # Blender's own numpy 1.x must stay the only one
SMOKE_IMPORTS = {"onnxruntime": "onnxruntime", "pillow": "PIL.Image", "openexr": "OpenEXR"}


def blender_ext_script() -> Path:
    import importlib.util

    spec = importlib.util.find_spec("bpy")
    if spec is None or spec.origin is None:
        raise SystemExit("error: the bpy wheel is needed for Blender's extension tool (make setup)")
    bpy_dir = Path(spec.origin).parent
    found = sorted(bpy_dir.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        raise SystemExit(f"error: blender_ext.py not found under {bpy_dir}")
    return found[-1]


def wheel_name_ok(name: str) -> bool:
    return not any(name.lower().startswith(f"{bad}-") for bad in NEVER_BUNDLE)


def download_wheels(offline: bool) -> dict[str, list[Path]]:
    """Wheels per Blender platform (a universal2 wheel serves both Macs)."""
    per_platform: dict[str, list[Path]] = {}
    for platform in PLATFORMS:
        dest = WHEEL_CACHE / platform.blender
        dest.mkdir(parents=True, exist_ok=True)
        wheels = []
        for package, versions in PINS.items():
            version = versions[platform.blender]
            pattern = f"{package.replace('-', '_')}-{version}-*.whl"
            have = [p for p in dest.glob(pattern) if p.name.lower().startswith(package.lower())]
            if not have:
                if offline:
                    raise SystemExit(f"error: --offline but {package} {version} for {platform.blender} "
                                     f"is not in {dest}")
                cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--disable-pip-version-check",
                       "--only-binary=:all:", "--no-deps", "--platform", platform.pip,
                       "--python-version", PYTHON_VERSION, "--implementation", "cp",
                       "--dest", str(dest), f"{package}=={version}"]
                result = subprocess.run(cmd, capture_output=True, text=True)
                if result.returncode != 0:
                    raise SystemExit(f"error: pip could not download {package}=={version} for "
                                     f"{platform.blender}:\n{result.stderr.strip()[-2000:]}")
                have = [p for p in dest.glob("*.whl") if p.name.lower().startswith(package.lower() + "-")
                        and f"-{version}-" in p.name]
            if len(have) != 1:
                raise SystemExit(f"error: expected one {package} {version} wheel for {platform.blender}, "
                                 f"found {[p.name for p in have]}")
            wheels.append(have[0])
        bad = [w.name for w in wheels if not wheel_name_ok(w.name)]
        if bad:
            raise SystemExit(f"error: refusing to bundle {bad}: Blender bundles numpy 1.x")
        per_platform[platform.blender] = wheels
    return per_platform


def source_files() -> list[Path]:
    """Files git tracks or would track (respects .gitignore); blender_ext filters them further."""
    result = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                            cwd=ROOT, capture_output=True)
    if result.returncode != 0:
        raise SystemExit("error: the build copies the files git knows; run it inside the git checkout")
    names = [n for n in result.stdout.decode("utf-8").split("\0") if n]
    return [ROOT / n for n in names if (ROOT / n).is_file()]


def manifest_with_wheels(text: str, wheel_names: list[str]) -> str:
    listing = "wheels = [\n" + "".join(f'  "./wheels/{n}",\n' for n in wheel_names) + "]"
    new, count = re.subn(r"^wheels\s*=\s*\[[^\]]*\]", listing, text, count=1, flags=re.MULTILINE)
    if count != 1:
        raise SystemExit("error: blender_manifest.toml needs a `wheels = [...]` line to fill in")
    return new


def stage(per_platform: dict[str, list[Path]], where: Path = STAGE) -> Path:
    if where.exists():
        shutil.rmtree(where)
    where.mkdir(parents=True)
    skip_top = {"build", "dist", "wheels", "data", "out", ".venv", "training", "tests", "bench", "tools"}
    for src in source_files():
        rel = src.relative_to(ROOT)
        if rel.parts[0] in skip_top:
            continue
        dst = where / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dst)
    wheel_dir = where / "wheels"
    wheel_dir.mkdir()
    names = set()
    for wheels in per_platform.values():
        for wheel in wheels:
            shutil.copy2(wheel, wheel_dir / wheel.name)
            names.add(wheel.name)
    text = manifest_with_wheels(MANIFEST.read_text(encoding="utf-8"), sorted(names))
    (where / MANIFEST.name).write_text(text, encoding="utf-8")
    return where


def check_version() -> str:
    manifest = tomllib.loads(MANIFEST.read_text(encoding="utf-8"))
    init = (ROOT / "cd_spectra_addon" / "__init__.py").read_text(encoding="utf-8")
    match = re.search(r'^__version__\s*=\s*"([^"]+)"', init, flags=re.MULTILINE)
    if match is None or match.group(1) != manifest["version"]:
        raise SystemExit(f"error: manifest version {manifest['version']} differs from "
                         f"cd_spectra_addon.__version__ {match.group(1) if match else '?'}")
    return manifest["version"]


def run_tool(script: Path, *args: str) -> str:
    result = subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True)
    if result.returncode != 0:
        raise SystemExit(f"error: blender_ext {args[0]} failed:\n{result.stdout}{result.stderr}")
    return result.stdout


def this_platform() -> str | None:
    import platform

    machine = {"x86_64": "x64", "amd64": "x64", "arm64": "arm64", "aarch64": "arm64"}.get(
        platform.machine().lower())
    system = {"linux": "linux", "windows": "windows", "darwin": "macos"}.get(platform.system().lower())
    return f"{system}-{machine}" if machine and system else None


SMOKE = r"""
import json, sys, time
sys.path[:0] = json.loads(sys.argv[1])
import numpy
assert numpy.__version__.startswith("1."), numpy.__version__
for name in json.loads(sys.argv[2]):
    __import__(name)
import onnxruntime as ort
import numpy as np
out = {"numpy": numpy.__version__, "onnxruntime": ort.__version__, "models": {}}
for path in json.loads(sys.argv[3]):
    t = time.perf_counter()
    s = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    feeds = {}
    for i in s.get_inputs():
        shape = [d if isinstance(d, int) and d > 0 else 1 for d in i.shape]
        feeds[i.name] = np.zeros(shape, dtype=np.float32)
    s.run(None, feeds)
    out["models"][path] = round(1e3 * (time.perf_counter() - t), 1)
print(json.dumps(out))
"""


def smoke_test(zip_path: Path) -> dict[str, object]:
    """Import the zip's wheels with numpy 1.26 only, and run every shipped model."""
    import numpy

    with tempfile.TemporaryDirectory() as tmp:
        site = Path(tmp) / "site"
        with zipfile.ZipFile(zip_path) as zf:
            for name in zf.namelist():
                if name.startswith("wheels/") and name.endswith(".whl"):
                    zf.extract(name, tmp)
        for wheel in sorted((Path(tmp) / "wheels").glob("*.whl")):
            with zipfile.ZipFile(wheel) as wf:
                wf.extractall(site)
        numpy_dir = Path(tmp) / "numpy_only"
        numpy_dir.mkdir()
        (numpy_dir / "numpy").symlink_to(Path(numpy.__file__).parent, target_is_directory=True)
        models = sorted(str(p) for p in (ROOT / "models").glob("*.onnx")) if (ROOT / "models").is_dir() else []
        result = subprocess.run(
            [sys.executable, "-S", "-c", SMOKE, json.dumps([str(site), str(numpy_dir)]),
             json.dumps(list(SMOKE_IMPORTS.values())), json.dumps(models)],
            capture_output=True, text=True)
        if result.returncode != 0:
            raise SystemExit(f"error: smoke test of {zip_path.name} failed:\n{result.stderr[-3000:]}")
        return json.loads(result.stdout.strip().splitlines()[-1])


def build(dist: Path, stage_dir: Path = STAGE, *, wheels: bool = True, offline: bool = False,
          smoke: bool = True) -> dict[str, object]:
    """Build, validate and (with wheels, on a known platform) smoke-test; return a report."""
    start = time.perf_counter()
    version = check_version()
    script = blender_ext_script()
    per_platform = download_wheels(offline) if wheels else {p.blender: [] for p in PLATFORMS}
    t_download = time.perf_counter() - start
    source = stage(per_platform, stage_dir)
    run_tool(script, "validate", str(source))
    dist.mkdir(parents=True, exist_ok=True)
    for old in dist.glob(f"cd_spectra-{version}-*.zip"):
        old.unlink()
    run_tool(script, "build", "--split-platforms", "--source-dir", str(source), "--output-dir", str(dist))
    zips = sorted(dist.glob(f"cd_spectra-{version}-*.zip"))
    expected = {f"cd_spectra-{version}-{p.blender.replace('-', '_')}.zip" for p in PLATFORMS}
    if {z.name for z in zips} != expected:
        raise SystemExit(f"error: expected {sorted(expected)}, built {[z.name for z in zips]}")
    for z in zips:
        run_tool(script, "validate", str(z))
        with zipfile.ZipFile(z) as zf:
            bad = [n for n in zf.namelist() if n.startswith("wheels/") and not wheel_name_ok(n[7:])]
            if bad:
                raise SystemExit(f"error: {z.name} bundles {bad}")
    report: dict[str, object] = {
        "version": version,
        "download_s": round(t_download, 1),
        "zips": {z.name: {"path": str(z), "mb": round(z.stat().st_size / 1e6, 2)} for z in zips},
    }
    here = this_platform()
    if here:
        report["this_platform_zip"] = str(dist / f"cd_spectra-{version}-{here.replace('-', '_')}.zip")
        if smoke and wheels:
            report["smoke_test"] = smoke_test(Path(str(report["this_platform_zip"])))
    report["build_s"] = round(time.perf_counter() - start, 1)
    return report


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dist", type=Path, default=ROOT / "dist", help="where the zips go")
    p.add_argument("--offline", action="store_true", help="use only wheels already in build/wheels/")
    p.add_argument("--skip-smoke-test", action="store_true")
    p.add_argument("--no-wheels", action="store_true",
                   help="leave the wheels out (tests: the dependencies come from the venv)")
    p.add_argument("--stage", type=Path, default=STAGE, help="where the build copy is made")
    args = p.parse_args(argv)
    report = build(args.dist, args.stage, wheels=not args.no_wheels, offline=args.offline,
                   smoke=not args.skip_smoke_test)
    print(json.dumps(report, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
