"""Build the Blender extension: two builds, one zip per platform each, validated and smoke-tested.

    python tools/build_extension.py [--dist DIR] [--offline] [--skip-smoke-test] [--build NAME]
                                    [--python313 PATH]

Two builds with non-overlapping Blender ranges, because a wheel only loads in the Python it was
built for and Blender 4.2.x may not filter a zip's wheels by Python tag:
``blender4.2-5.0`` (CPython 3.11 wheels) and ``blender5.1plus`` (CPython 3.13 wheels).

1. Download each build's pinned wheels for every platform (``pip download --only-binary=:all:
   --no-deps --python-version X``) into build/wheels/<build>/ (git-ignored, reused between
   builds; --offline uses only what is there). numpy is never bundled: Blender has its own.
2. Stage the add-on once per platform in build/extension/<build>/<platform>/: the files git
   knows (tracked or not ignored), that platform's wheels, and a copy of blender_manifest.toml
   with the build's Blender range, that one platform and its wheels written in. The committed
   manifest keeps ``wheels = []`` so the pins live here.
3. ``blender_ext.py build`` (Blender's own tool from the bpy wheel) on each staged copy, into
   ``cd_spectra-<version>-<build>-<platform>.zip``. Not ``--split-platforms``: it keeps every
   platform's wheels in the manifest's ``wheels`` and lists the zip's own only in an appended
   ``[build.generated]`` table, so the manifest names wheels the zip does not hold.
4. Each zip is checked where it is built (``check_zip``: the manifest's wheels are exactly the
   zip's, its platform is the zip's, no numpy, only the build's Python tag) and by
   ``blender_ext.py validate``; only then is it moved into dist/.
5. Smoke test on this machine: the wheels of this platform's zip are unpacked next to numpy of
   the kind that Blender bundles (1.26 from .venv for 3.11, 2.x from .venv313 for 3.13) in a
   Python started with ``-S`` (no site-packages), and must import; onnxruntime must load every
   model in models/ and run it.

Why these wheels and versions: see README, "Installing the extension".
"""

from __future__ import annotations

import argparse
import json
import os
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
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = ROOT / "blender_manifest.toml"
WHEEL_CACHE = ROOT / "build" / "wheels"
STAGE = ROOT / "build" / "extension"


@dataclass(frozen=True)
class Platform:
    blender: str  # Blender's platform name (manifest "platforms")
    pip: str  # the pip --platform tag: the oldest OS this Blender platform supports


@dataclass(frozen=True)
class Build:
    """One extension build: a Blender range with one Python, and its wheels per platform.

    The ranges never overlap, so each Blender sees exactly one build, and every wheel in it
    matches that Blender's Python (Blender 4.2.x does not yet filter wheels by Python tag).
    """

    name: str  # in the zip names: cd_spectra-<version>-<name>-<platform>.zip
    python: str  # the CPython version of every Blender in the range
    blender_min: str
    blender_max: str | None  # exclusive; None = open-ended
    platforms: tuple[Platform, ...]
    pins: dict[str, dict[str, str]]  # package -> Blender platform -> version
    numpy_major: int  # the numpy that Blender bundles (never ours)


# Blender 4.2–5.0 need glibc 2.28 on Linux and macOS 11.2 on both Macs; 5.0 dropped Intel Macs.
LINUX = Platform("linux-x64", "manylinux_2_28_x86_64")
WINDOWS = Platform("windows-x64", "win_amd64")
MAC_ARM_11 = Platform("macos-arm64", "macosx_11_0_arm64")
MAC_INTEL_11 = Platform("macos-x64", "macosx_11_0_x86_64")
# Every cp313 onnxruntime macOS wheel (1.20–1.23) needs macOS 13: the 5.1+ Mac build does too.
MAC_ARM_13 = Platform("macos-arm64", "macosx_13_0_arm64")


def _same(version: str, platforms: tuple[Platform, ...]) -> dict[str, str]:
    return {p.blender: version for p in platforms}


_P42 = (LINUX, WINDOWS, MAC_ARM_11, MAC_INTEL_11)
_P51 = (LINUX, WINDOWS, MAC_ARM_13)

# Blender 4.2–5.0 (Python 3.11, numpy 1.26). onnxruntime 1.18.1 everywhere: the last release
# built with the VS 2019 toolset (1.19+ fail to load inside Blender 4.2–5.0 on Windows, whose
# bundled VC++ runtime is older than they need), the last with macOS 11 wheels (a universal2
# wheel serves both Macs), built against numpy 1.x. Its declared dependencies (sympy, protobuf,
# coloredlogs, flatbuffers, packaging) are not needed to load and run a model (the smoke test
# proves it with none of them installed) and are left out: ~8 MB a zip. rawpy 0.28.0 has no
# Intel-Mac wheel: 0.25.1 there. pillow-heif reads HEIC (see README for its libraries' licences).
BLENDER_42 = Build(
    name="blender4.2-5.0", python="3.11", blender_min="4.2.0", blender_max="5.1.0", platforms=_P42,
    pins={
        "onnxruntime": _same("1.18.1", _P42),
        "pillow": _same("13.0.0", _P42),
        "openexr": _same("3.5.3", _P42),
        "rawpy": {**_same("0.28.0", _P42), "macos-x64": "0.25.1"},
        "pillow-heif": _same("1.8.1", _P42),
    },
    numpy_major=1,
)
# Blender 5.1+ (Python 3.13, numpy 2; Blender's newer VC++ runtime loads current onnxruntime).
BLENDER_51 = Build(
    name="blender5.1plus", python="3.13", blender_min="5.1.0", blender_max=None, platforms=_P51,
    pins={
        "onnxruntime": _same("1.23.2", _P51),
        "pillow": _same("13.0.0", _P51),
        "openexr": _same("3.5.3", _P51),
        "rawpy": _same("0.28.0", _P51),
        "pillow-heif": _same("1.8.1", _P51),
    },
    numpy_major=2,
)
BUILDS = (BLENDER_42, BLENDER_51)
NEVER_BUNDLE = ("numpy",)  # Blender's own numpy must stay the only one
SMOKE_IMPORTS = {"onnxruntime": "onnxruntime", "pillow": "PIL.Image", "openexr": "OpenEXR",
                 "rawpy": "rawpy", "pillow-heif": "pillow_heif"}


def build_for_python(version: str | None = None) -> Build:
    """The build whose Blenders run this Python (default: the running one)."""
    version = version or f"{sys.version_info[0]}.{sys.version_info[1]}"
    for candidate in BUILDS:
        if candidate.python == version:
            return candidate
    raise SystemExit(f"error: no extension build for Python {version} (Blender runs "
                     f"{', '.join(b.python for b in BUILDS)})")


_FIND_BPY = "import importlib.util; s = importlib.util.find_spec('bpy'); print(s.origin if s and s.origin else '')"


def blender_ext_script(python: Path | None = None) -> Path:
    """Blender's extension tool from the bpy wheel of ``python`` (default: this interpreter)."""
    import importlib.util

    if python is None:
        spec = importlib.util.find_spec("bpy")
        origin = spec.origin if spec is not None else None
    else:
        found = subprocess.run([str(python), "-c", _FIND_BPY], capture_output=True, text=True)
        origin = found.stdout.strip() or None
    if origin is None:
        raise SystemExit("error: the bpy wheel is needed for Blender's extension tool (make setup)")
    bpy_dir = Path(origin).parent
    found = sorted(bpy_dir.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        raise SystemExit(f"error: blender_ext.py not found under {bpy_dir}")
    return found[-1]


def wheel_name_ok(name: str) -> bool:
    return not any(name.lower().startswith(f"{bad}-") for bad in NEVER_BUNDLE)


def download_wheels(build_spec: Build, offline: bool) -> dict[str, list[Path]]:
    """Wheels per Blender platform of one build, cached in build/wheels/<build>/<platform>/."""
    per_platform: dict[str, list[Path]] = {}
    for platform in build_spec.platforms:
        dest = WHEEL_CACHE / build_spec.name / platform.blender
        dest.mkdir(parents=True, exist_ok=True)
        wheels = []
        for package, versions in build_spec.pins.items():
            version = versions[platform.blender]
            prefix = package.replace("-", "_").lower() + "-"
            have = [p for p in dest.glob("*.whl") if p.name.lower().startswith(prefix)
                    and f"-{version}-" in p.name]
            if not have:
                if offline:
                    raise SystemExit(f"error: --offline but {package} {version} for {platform.blender} "
                                     f"is not in {dest}")
                cmd = [sys.executable, "-m", "pip", "download", "--quiet", "--disable-pip-version-check",
                       "--only-binary=:all:", "--no-deps", "--platform", platform.pip,
                       "--python-version", build_spec.python, "--implementation", "cp",
                       "--dest", str(dest), f"{package}=={version}"]
                result = subprocess.run(cmd, capture_output=True, text=True)
                if result.returncode != 0:
                    raise SystemExit(f"error: pip could not download {package}=={version} for "
                                     f"{platform.blender} (Python {build_spec.python}):\n"
                                     f"{result.stderr.strip()[-2000:]}")
                have = [p for p in dest.glob("*.whl") if p.name.lower().startswith(prefix)
                        and f"-{version}-" in p.name]
            if len(have) != 1:
                raise SystemExit(f"error: expected one {package} {version} wheel for {platform.blender}, "
                                 f"found {[p.name for p in have]}")
            tag = python_tag(build_spec)
            if f"-{tag}-" not in have[0].name:
                raise SystemExit(f"error: {have[0].name} is not a {tag} wheel ({build_spec.name})")
            wheels.append(have[0])
        bad = [w.name for w in wheels if not wheel_name_ok(w.name)]
        if bad:
            raise SystemExit(f"error: refusing to bundle {bad}: Blender bundles its own numpy")
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


# What the extension is: the add-on package, its model, and the files Blender reads at the zip's
# root. The stage copies only these — an allow-list, so a stray file in the checkout (a photo, a
# log, notes) never ships; the manifest's paths_exclude_pattern then drops caches.
ADDON_TOP = frozenset({"__init__.py", "blender_manifest.toml", "README.md", "cd_spectra_addon", "models"})


def addon_files(files: list[Path]) -> list[Path]:
    """The ``files`` (under ROOT) that belong to the add-on (:data:`ADDON_TOP`)."""
    return [f for f in files if f.relative_to(ROOT).parts[0] in ADDON_TOP]


def manifest_with_wheels(text: str, wheel_names: list[str]) -> str:
    listing = "wheels = [\n" + "".join(f'  "./wheels/{n}",\n' for n in wheel_names) + "]"
    new, count = re.subn(r"^wheels\s*=\s*\[[^\]]*\]", listing, text, count=1, flags=re.MULTILINE)
    if count != 1:
        raise SystemExit("error: blender_manifest.toml needs a `wheels = [...]` line to fill in")
    return new


def _set_field(text: str, key: str, value: str | None) -> str:
    """Rewrite (or, with None, drop) one top-level ``key = ...`` line of the manifest."""
    pattern = rf"^{key}\s*=\s*(\[[^\]]*\]|\"[^\"\n]*\")[^\n]*\n"
    if re.search(pattern, text, flags=re.MULTILINE) is None:
        raise SystemExit(f"error: blender_manifest.toml needs a `{key} = ...` line")
    return re.sub(pattern, "" if value is None else f"{key} = {value}\n", text, count=1, flags=re.MULTILINE)


def manifest_for(text: str, build_spec: Build, wheel_names: list[str],
                 platforms: tuple[Platform, ...] | None = None) -> str:
    """The committed manifest with one build's Blender range, platforms and wheels written in.

    ``platforms`` defaults to the whole build's; a per-platform zip passes its one platform, so
    that Blender offers the zip only where its wheels load.
    """
    chosen = build_spec.platforms if platforms is None else platforms
    text = _set_field(text, "blender_version_min", f'"{build_spec.blender_min}"')
    text = _set_field(text, "blender_version_max",
                      None if build_spec.blender_max is None else f'"{build_spec.blender_max}"')
    text = _set_field(text, "platforms", "[" + ", ".join(f'"{p.blender}"' for p in chosen) + "]")
    return manifest_with_wheels(text, wheel_names)


def stage(wheels: list[Path], build_spec: Build, platform: Platform, where: Path) -> Path:
    """A copy of the add-on for one platform's zip: its wheels only, and a manifest naming them.

    One stage per platform (not one ``--split-platforms`` build) so that the manifest Blender's
    tool puts in each zip lists exactly the wheels that zip holds.
    """
    if where.exists():
        shutil.rmtree(where)
    where.mkdir(parents=True)
    for src in addon_files(source_files()):
        rel = src.relative_to(ROOT)
        dst = where / rel
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dst)
    wheel_dir = where / "wheels"
    wheel_dir.mkdir()
    for wheel in wheels:
        shutil.copy2(wheel, wheel_dir / wheel.name)
    text = manifest_for(MANIFEST.read_text(encoding="utf-8"), build_spec, sorted(w.name for w in wheels),
                        (platform,))
    (where / MANIFEST.name).write_text(text, encoding="utf-8")
    return where


def _manifest_lists(manifest: dict[str, Any], key: str) -> list[tuple[str, list[str]]]:
    """Every list ``key`` that some Blender may read: the top-level one and, in a zip made with
    ``--split-platforms``, the ``[build.generated]`` one that Blender swaps in when present."""
    found = [(key, list(manifest.get(key) or []))]
    generated = manifest.get("build", {}).get("generated")
    if generated is not None and key in generated:
        found.append((f"[build.generated] {key}", list(generated[key])))
    return found


def zip_problems(zip_path: Path, tag: str, platform: str) -> list[str]:
    """Why a built zip would mislead Blender (empty when it would not).

    Each wheel list in its manifest must be exactly the wheels it holds (Blender installs what
    the manifest lists), each platform list must be just ``platform``, no numpy (Blender's own
    must stay the only one), and every wheel must be for ``tag`` (e.g. ``cp311``).
    """
    with zipfile.ZipFile(zip_path) as zf:
        names = zf.namelist()
        if MANIFEST.name not in names:
            return [f"no {MANIFEST.name}"]
        manifest = tomllib.loads(zf.read(MANIFEST.name).decode("utf-8"))
    held = {n for n in names if n.endswith(".whl")}
    problems = []
    for where, listed in _manifest_lists(manifest, "wheels"):
        paths = {w.removeprefix("./") for w in listed}
        if missing := sorted(paths - held):
            problems.append(f"{where} lists wheels the zip lacks: {missing}")
        if unlisted := sorted(held - paths):
            problems.append(f"the zip holds wheels that {where} does not list: {unlisted}")
    for where, platforms in _manifest_lists(manifest, "platforms"):
        if platforms != [platform]:
            problems.append(f"{where} is {platforms}, not [{platform!r}]")
    if numpy := sorted(n for n in held if not wheel_name_ok(n.rpartition("/")[2])):
        problems.append(f"bundles numpy (Blender has its own): {numpy}")
    if foreign := sorted(n for n in held if f"-{tag}-" not in n):
        problems.append(f"wheels not for {tag}: {foreign}")
    return problems


def check_zip(zip_path: Path, tag: str, platform: str) -> None:
    """Stop the build on a zip whose manifest and contents disagree (see ``zip_problems``)."""
    if problems := zip_problems(zip_path, tag, platform):
        raise SystemExit(f"error: {zip_path.name}:\n  " + "\n  ".join(problems))


def check_version() -> str:
    manifest = tomllib.loads(MANIFEST.read_text(encoding="utf-8"))
    init = (ROOT / "cd_spectra_addon" / "__init__.py").read_text(encoding="utf-8")
    match = re.search(r'^__version__\s*=\s*"([^"]+)"', init, flags=re.MULTILINE)
    if match is None or match.group(1) != manifest["version"]:
        raise SystemExit(f"error: manifest version {manifest['version']} differs from "
                         f"cd_spectra_addon.__version__ {match.group(1) if match else '?'}")
    return manifest["version"]


def run_tool(script: Path, *args: str, python: Path | None = None) -> str:
    result = subprocess.run([str(python or sys.executable), str(script), *args], capture_output=True, text=True)
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
assert numpy.__version__.startswith(sys.argv[4] + "."), numpy.__version__
for name in json.loads(sys.argv[2]):
    __import__(name)
import onnxruntime as ort
import numpy as np
out = {"python": sys.version.split()[0], "numpy": numpy.__version__, "onnxruntime": ort.__version__,
       "models": {}}
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

NUMPY_DIR = "import numpy, os; print(os.path.dirname(numpy.__file__))"


def smoke_test(zip_path: Path, build_spec: Build, python: Path) -> dict[str, object]:
    """Import the zip's wheels next to Blender's kind of numpy only, and run every shipped model.

    ``python`` is an interpreter of the build's version whose numpy plays Blender's (the .venv
    for 3.11 / numpy 1.26, .venv313 for 3.13 / numpy 2); it starts with ``-S`` (no site-packages).
    """
    probe = subprocess.run([str(python), "-c", NUMPY_DIR], capture_output=True, text=True)
    if probe.returncode != 0:
        raise SystemExit(f"error: {python} has no numpy for the smoke test:\n{probe.stderr[-1000:]}")
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
        (numpy_dir / "numpy").symlink_to(Path(probe.stdout.strip()), target_is_directory=True)
        models = sorted(str(p) for p in (ROOT / "models").glob("*.onnx")) if (ROOT / "models").is_dir() else []
        imports = [SMOKE_IMPORTS[name] for name in build_spec.pins]
        result = subprocess.run(
            [str(python), "-S", "-c", SMOKE, json.dumps([str(site), str(numpy_dir)]),
             json.dumps(imports), json.dumps(models), str(build_spec.numpy_major)],
            capture_output=True, text=True)
        if result.returncode != 0:
            raise SystemExit(f"error: smoke test of {zip_path.name} failed:\n{result.stderr[-3000:]}")
        return json.loads(result.stdout.strip().splitlines()[-1])


def zip_name(version: str, build_spec: Build, platform: str) -> str:
    return f"cd_spectra-{version}-{build_spec.name}-{platform.replace('-', '_')}.zip"


def python_tag(build_spec: Build) -> str:
    """The wheel tag of the build's Python, e.g. ``cp311``."""
    return "cp" + build_spec.python.replace(".", "")


Validator = tuple[Path, Path | None]  # blender_ext.py and the Python to run it with (None: this one)


def build_platform_zip(validators: list[Validator], wheels: list[Path], build_spec: Build,
                       platform: Platform, stage_dir: Path, out: Path) -> Path:
    """One platform's zip at ``out``: staged, built by Blender's tool, then checked and validated
    here, so that no zip leaves the build unchecked."""
    script = validators[0][0]
    source = stage(wheels, build_spec, platform, stage_dir)
    run_tool(script, "validate", str(source))
    run_tool(script, "build", "--source-dir", str(source), "--output-filepath", str(out))
    check_zip(out, python_tag(build_spec), platform.blender)
    for tool, python in validators:
        run_tool(tool, "validate", str(out), python=python)
    return out


def build_one(build_spec: Build, dist: Path, stage_dir: Path, *, wheels: bool, offline: bool,
              smoke_python: Path | None) -> dict[str, object]:
    """One build's zips (one per platform), each checked and validated before it enters ``dist``."""
    version = check_version()
    validators: list[Validator] = [(blender_ext_script(), None)]
    if smoke_python is not None and Path(smoke_python).resolve() != Path(sys.executable).resolve():
        # and by the tool of the Blender this build is for (bpy 5.x for the 5.1+ build)
        validators.append((blender_ext_script(smoke_python), smoke_python))
    start = time.perf_counter()
    per_platform = download_wheels(build_spec, offline) if wheels else {p.blender: [] for p in build_spec.platforms}
    t_download = time.perf_counter() - start
    shutil.rmtree(stage_dir / build_spec.name, ignore_errors=True)
    dist.mkdir(parents=True, exist_ok=True)
    for old in dist.glob(f"cd_spectra-{version}-{build_spec.name}-*.zip"):
        old.unlink()
    with tempfile.TemporaryDirectory(dir=dist) as raw:
        made = [build_platform_zip(validators, per_platform[p.blender], build_spec, p,
                                   stage_dir / build_spec.name / p.blender,
                                   Path(raw) / zip_name(version, build_spec, p.blender))
                for p in build_spec.platforms]
        zips = [dist / z.name for z in made]
        for z, target in zip(made, zips):  # all or none: a failed check leaves none of them in dist
            os.replace(z, target)
    report: dict[str, object] = {
        "blender": f">= {build_spec.blender_min}" + (f", < {build_spec.blender_max}" if build_spec.blender_max else ""),
        "python": build_spec.python,
        "download_s": round(t_download, 1),
        "zips": {z.name: {"path": str(z), "mb": round(z.stat().st_size / 1e6, 2)} for z in sorted(zips)},
    }
    here = this_platform()
    if here and here in {p.blender for p in build_spec.platforms}:
        report["this_platform_zip"] = str(dist / zip_name(version, build_spec, here))
        if smoke_python is not None and wheels:
            report["smoke_test"] = smoke_test(Path(str(report["this_platform_zip"])), build_spec, smoke_python)
    return report


def build(dist: Path, stage_dir: Path = STAGE, *, wheels: bool = True, offline: bool = False,
          smoke: bool = True, builds: tuple[Build, ...] = BUILDS,
          pythons: dict[str, Path] | None = None) -> dict[str, object]:
    """Build, validate and (with wheels, where an interpreter is given) smoke-test; return a report.

    ``pythons`` maps a build's Python version to the interpreter for its smoke test (the running
    one serves its own version). With one build, the report also has its ``this_platform_zip``.
    """
    start = time.perf_counter()
    pythons = {f"{sys.version_info[0]}.{sys.version_info[1]}": Path(sys.executable), **(pythons or {})}
    report: dict[str, object] = {"version": check_version(), "builds": {}}
    for spec in builds:
        one = build_one(spec, dist, stage_dir, wheels=wheels, offline=offline,
                        smoke_python=pythons.get(spec.python) if smoke else None)
        report["builds"][spec.name] = one  # type: ignore[index]
        if len(builds) == 1 and "this_platform_zip" in one:
            report["this_platform_zip"] = one["this_platform_zip"]
    report["build_s"] = round(time.perf_counter() - start, 1)
    return report


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--dist", type=Path, default=ROOT / "dist", help="where the zips go")
    p.add_argument("--offline", action="store_true", help="use only wheels already in build/wheels/")
    p.add_argument("--skip-smoke-test", action="store_true")
    p.add_argument("--no-wheels", action="store_true",
                   help="leave the wheels out (tests: the dependencies come from the venv)")
    p.add_argument("--stage", type=Path, default=STAGE, help="where the build copies are made")
    p.add_argument("--build", choices=[b.name for b in BUILDS], action="append",
                   help="only this build (repeatable; default: all)")
    p.add_argument("--python313", type=Path, default=ROOT / ".venv313" / "bin" / "python",
                   help="a Python 3.13 with numpy 2 for the 5.1+ smoke test (make setup313)")
    args = p.parse_args(argv)
    chosen = tuple(b for b in BUILDS if not args.build or b.name in args.build)
    pythons = {"3.13": args.python313} if args.python313.exists() else {}
    report = build(args.dist, args.stage, wheels=not args.no_wheels, offline=args.offline,
                   smoke=not args.skip_smoke_test, builds=chosen, pythons=pythons)
    missing = [name for name, one in report["builds"].items()  # type: ignore[union-attr]
               if not args.skip_smoke_test and not args.no_wheels and "this_platform_zip" in one
               and "smoke_test" not in one]
    print(json.dumps(report, indent=2))
    if missing:
        print(f"warning: no interpreter to smoke-test {missing} (pass --python313)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
