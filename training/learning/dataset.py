"""Training data: synthetic photos through the product's own preprocessing, as model inputs.

A handful of capture geometries is rendered once each with Cycles (basis cubes, see
:mod:`training.simulation.basis`); then every sample is a photo made from a cube by a matrix product with a
random SPD from the prior, a random training camera (with unit-to-unit gain and wavelength
errors), random exposure (some clipping), noise, ambient light and file encoding (EXR, 16-bit
PNG, 8-bit PNG, JPEG at several qualities), written to disk and read back by
``core.images.load_photo`` — exactly what a user's photo goes through. A share of the photos
is rendered *in camera* (white balance, colour matrix with gamut clipping, tone curve, 8-bit
JPEG or HEIC; :mod:`training.simulation.camera_pipelines`, randomised within what cameras and
phones do) and read with a calibration made the product's way from a CIE A shot of the same
capture, camera and settings — in-camera files are only estimated after calibration. The profile is taken at
geometries the pose fit actually produced on photos of that cube (its real errors) and the
physics solve runs with the camera profile a user would pick (the named camera, or "generic").
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
import time
from dataclasses import asdict, dataclass, replace
from multiprocessing import get_context
from pathlib import Path
import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon.core.inverse.stages import network_inputs, physics_spd, read_photo
from cd_spectra_addon.core.calibration.calibration import Calibration
from cd_spectra_addon.core.inverse.calibration_shot import fit_calibration
from cd_spectra_addon.core.calibration.camera_fit import camera_prior
from cd_spectra_addon.core.calibration.camera_pipeline import CameraPipeline
from cd_spectra_addon.core.spectra.cameras import GENERIC_CAMERA, CameraProfile, camera_names, load_camera
from cd_spectra_addon.core.scene.capture import (
    DISTANT_LAMP_PRESET, FAR_LIGHT_PRESET, NEAR_AXIS_PRESET, OBLIQUE_PRESET, PAPER_PRESET, REFERENCE_PRESET, Pose,
    Preset, Scene, load_preset)
from cd_spectra_addon.core.scene.diffraction import PixelDiffraction, pixel_diffraction
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.inverse.estimate import solving_camera
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
from cd_spectra_addon.core.photo.images import LinearImage, load_photo
from cd_spectra_addon.core.spectrum.model import INPUT_SIZE
from cd_spectra_addon.core.pose.result import PoseFit
from cd_spectra_addon.core.spectrum.solve import GaussianPrior
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

from training.simulation import camera_pipelines, photo
from training.simulation.basis import REPO, basis_cube
from training.simulation.camera_pipelines import in_camera_exif, pipeline_for, render_in_camera, sample_style
from training.learning.spd_prior import gaussian_prior, sample_spds

DATA_DIR = REPO / "data" / "dataset"
CALIBRATION_LAMP = known_lamp_spd("incandescent")  # what users are told to calibrate with: a household bulb

__all__ = ["CubeSpec", "CUBE_SETS", "camera_split", "generic_sensitivities", "build_dataset", "Degradation", "CubeJob",
           "run_cube"]


@dataclass(frozen=True)
class CubeSpec:
    """One capture geometry of the training set."""

    name: str
    preset: str = REFERENCE_PRESET  # the `full` and `smoke` sets: the tables' geometry
    camera_offset_mm: tuple[float, float] = (0.0, 0.0)
    light_offset_mm: tuple[float, float] = (0.0, 0.0)
    tilt_deg: tuple[float, float] = (0.0, 0.0)
    lobe_sigma: float | None = None
    distance_mm: float | None = None
    groove_height_um: float | None = None
    size: int = 256
    camera_rotation_deg: tuple[float, float] = (0.0, 0.0)  # camera aimed a few degrees off
    light_rotation_deg: tuple[float, float] = (0.0, 0.0)  # lamp swung about the disc centre
    focal_multiplier: float = 1.0  # × the preset's focal length, same camera position: a centred crop
    samples: int | None = None  # Cycles samples per pixel of the basis render (None: the preset's)

    def reading_preset(self) -> Preset:
        """The preset a user would estimate this photo with: the nominal capture (lamp size,
        distance and pose unknown), with the focal length of the crop it was rendered as — what
        EXIF says, and what a file without EXIF (EXR, 16-bit PNG) falls back on."""
        preset = load_preset(self.preset)
        if self.focal_multiplier == 1.0:
            return preset
        camera = preset.camera
        return replace(preset, camera=replace(camera, focal_length_mm=camera.focal_length_mm * self.focal_multiplier))

    def scene(self) -> Scene:
        preset = self.reading_preset().with_image_size(self.size)
        if self.samples is not None:
            preset = replace(preset, samples=self.samples)
        if self.groove_height_um is not None:
            preset = replace(preset, disc=replace(preset.disc, groove_height_um=self.groove_height_um))
        if self.lobe_sigma is not None:
            preset = replace(preset, light=replace(preset.light, lobe_sigma=self.lobe_sigma))
        if self.distance_mm is not None:
            shift = self.distance_mm - preset.camera.distance_mm
            x, y, z = preset.light.position_mm
            attached = abs(z - preset.camera.distance_mm) < 60
            light = replace(preset.light, position_mm=(x, y, z + shift if attached else z))
            preset = replace(preset, camera=replace(preset.camera, distance_mm=self.distance_mm), light=light)
        return Scene(preset, Pose(self.camera_offset_mm, self.light_offset_mm, self.tilt_deg,
                                  self.camera_rotation_deg, self.light_rotation_deg))


def disc_fill_multiplier(preset: str, fill: float = 0.9) -> float:
    """Focal-length multiplier that makes the disc's rim span ``fill`` of the image (its widest
    extent from the image centre, both axes): the centred crop the product reads, rendered
    directly from the preset's camera position. Projection scales about the principal point, so
    one projection at the preset's focal length gives it exactly."""
    scene = Scene(load_preset(preset))
    cam = scene.preset.camera
    angle = np.linspace(0.0, 2.0 * math.pi, 360, endpoint=False)
    r = scene.preset.disc.rim_radius_mm * 1e-3
    rim = np.stack([r * np.cos(angle), r * np.sin(angle), np.zeros_like(angle)], axis=1) @ scene.disc_rotation.T
    rc = scene.project(rim)
    width, height = cam.image_size_px
    half = max(float(np.max(np.abs(rc[:, 1] - (width - 1) / 2.0))) / width,
               float(np.max(np.abs(rc[:, 0] - (height - 1) / 2.0))) / height)
    return round(fill / (2.0 * half), 3)


# Geometries a careful user gets by hand: lamp beside the lens or on the axis, camera up to a
# few mm off the disc centre, a degree or two of tilt, lamps from pinhole-small to bulb-sized.
CUBE_SETS: dict[str, list[CubeSpec]] = {
    "full": [
        CubeSpec("nominal"),
        CubeSpec("small-lamp", lobe_sigma=0.0015),
        CubeSpec("medium-lamp", lobe_sigma=0.006),
        CubeSpec("large-lamp", lobe_sigma=0.01, camera_offset_mm=(0.5, 0.5)),
        CubeSpec("camera-off", camera_offset_mm=(2.0, -1.0)),
        CubeSpec("lamp-beside", light_offset_mm=(12.0, 0.0)),
        CubeSpec("lamp-beside-2", light_offset_mm=(-6.0, 8.0), lobe_sigma=0.002),
        CubeSpec("tilted", tilt_deg=(1.5, -1.0), lobe_sigma=0.004),
        CubeSpec("far-235", distance_mm=235.0, camera_offset_mm=(1.0, 1.0)),
        CubeSpec("near-190", distance_mm=190.0, light_offset_mm=(0.0, -4.0), lobe_sigma=0.0025),
        CubeSpec("far-light", preset=FAR_LIGHT_PRESET),
        CubeSpec("far-light-off", preset=FAR_LIGHT_PRESET, camera_offset_mm=(1.5, 0.0), lobe_sigma=0.004),
        CubeSpec("paper", preset=PAPER_PRESET),
    ],
    "smoke": [
        CubeSpec("nominal", size=96),
        CubeSpec("lamp-beside", light_offset_mm=(10.0, 0.0), size=96),
    ],
}

# The buildable family (issue 10): the three set-ups a user can build, each with the pose errors a
# person makes building it, lamps from a pinhole to bulb-sized (σ 0.001–0.01), and cd-default as
# the reference. Rendered as the product reads them: a centred crop with the disc 0.9 of the side
# (focal length × :func:`disc_fill_multiplier`), 512 px, so the disc is read at ~460 px — as the
# estimator reads a real photo (its preview keeps a disc of ≥ 400 px, a smaller one is read through
# a window at ~720 px: core/disc_window.py). A cube at 1024 px (disc ≈ 900 px) gave the same
# features to 0.2–0.8 % and the same physics MAE (bench/cube_resolution.md) at twice the dataset
# time; a 256 px one lost the thinnest streaks (MAE 0.015 vs 0.0097, σ 0.001).
# Cycles at 8 samples per pixel: its readout is within 0.04 % of the converged twin's (16 spp:
# 0.02 %, 4: 0.05 %; the photos' own noise is 0.2–3 %) at half the time of 16.
BUILDABLE_SIZE = 512
BUILDABLE_SPP = 8


def _buildable(name: str, preset: str, **pose) -> CubeSpec:
    return CubeSpec(name, preset=preset, size=BUILDABLE_SIZE, focal_multiplier=disc_fill_multiplier(preset),
                    samples=BUILDABLE_SPP, **pose)


# Near-axis phone: the lamp 6–15 mm from the lens (the preset's is 12 mm on −x; offsets move it),
# the camera ±4 mm off the centre and aimed up to 3° off, the disc tilted 0–5°.
_NEAR_AXIS = [
    _buildable("phone-nominal", NEAR_AXIS_PRESET),  # lamp 12 mm, σ 0.0043
    _buildable("phone-lamp-6", NEAR_AXIS_PRESET, light_offset_mm=(6.0, 0.0), lobe_sigma=0.002),
    _buildable("phone-lamp-15", NEAR_AXIS_PRESET, light_offset_mm=(-3.0, 0.0), camera_offset_mm=(0.0, 2.0),
               lobe_sigma=0.006),
    _buildable("phone-lamp-side", NEAR_AXIS_PRESET, light_offset_mm=(4.0, 8.0), camera_rotation_deg=(1.5, -2.0),
               lobe_sigma=0.001),  # lamp 11 mm at 45°
    _buildable("phone-aimed", NEAR_AXIS_PRESET, camera_offset_mm=(-3.0, 2.5), camera_rotation_deg=(-3.0, 2.0),
               lobe_sigma=0.003),  # lamp 9 mm
    _buildable("phone-tilt-3", NEAR_AXIS_PRESET, light_offset_mm=(2.0, 0.0), camera_offset_mm=(1.5, -1.0),
               tilt_deg=(3.0, 0.0), lobe_sigma=0.005),
    _buildable("phone-tilt-5", NEAR_AXIS_PRESET, tilt_deg=(-2.0, 4.5), camera_rotation_deg=(0.0, 1.0),
               lobe_sigma=0.0025),
    _buildable("phone-large-lamp", NEAR_AXIS_PRESET, camera_offset_mm=(0.0, -4.0), tilt_deg=(1.0, 1.0),
               lobe_sigma=0.01),
    _buildable("phone-combined", NEAR_AXIS_PRESET, camera_offset_mm=(3.3, -3.3), camera_rotation_deg=(1.0, -2.0),
               tilt_deg=(3.0, 0.0), lobe_sigma=0.004),  # lamp 15.6 mm
]
# The two oblique set-ups: lamp ±5 mm / ±3°, camera ±5 mm / ±3°, disc tilted 0–5°. Today's
# estimator refuses oblique photos (the general-pose fit is not in yet): the dataset drops them
# after the first refusals and includes them by itself once ``prepare`` reads them.
_OBLIQUE = [
    _buildable(f"{short}-{kind}", preset, **pose)
    for preset, short in ((OBLIQUE_PRESET, "tripod"), (DISTANT_LAMP_PRESET, "distant"))
    for kind, pose in (
        ("nominal", {}),
        ("posed", {"light_offset_mm": (-4.0, 3.0), "light_rotation_deg": (2.0, 0.0), "camera_offset_mm": (5.0, -2.0),
                   "camera_rotation_deg": (-2.0, 2.5), "tilt_deg": (2.0, 0.0), "lobe_sigma": 0.0015}),
        ("tilted", {"light_offset_mm": (3.0, -4.0), "light_rotation_deg": (-3.0, 1.0), "camera_offset_mm": (-3.0, 4.0),
                    "camera_rotation_deg": (3.0, -1.0), "tilt_deg": (-1.0, 4.5), "lobe_sigma": 0.007}),
    )
]
# cd-default, the reference geometry (coaxial: not buildable), and `full`'s lamp beside the lens.
_REFERENCE = [
    _buildable("cd-nominal", REFERENCE_PRESET),
    _buildable("cd-lamp-beside", REFERENCE_PRESET, light_offset_mm=(12.0, 0.0), lobe_sigma=0.002),
]
CUBE_SETS["buildable"] = _NEAR_AXIS + _OBLIQUE + _REFERENCE
# A few buildable geometries at a tenth of the work: the pipeline's end-to-end check (tests, pilots).
CUBE_SETS["buildable-smoke"] = [replace(c, size=128) for c in (_NEAR_AXIS[0], _NEAR_AXIS[4], _OBLIQUE[0])]
SHIPPED_SET = "buildable"  # what `make model` builds


def camera_split() -> tuple[list[str], list[str]]:
    """(training cameras, held-out cameras): every fourth camera, alphabetically, is never
    trained on, so the evaluation can say how the model does on a camera it has not seen."""
    names = camera_names()
    held = names[2::4]
    return [n for n in names if n not in held], held


def generic_sensitivities(names: list[str] | None = None) -> NDArray[np.float64]:
    """Mean of the training cameras' sensitivities, max 1: the profile for an unknown camera."""
    names = names or camera_split()[0]
    mean = np.mean([load_camera(n).sensitivities for n in names], axis=0)
    return mean / mean.max()


@dataclass(frozen=True)
class Degradation:
    """What happens between the lens and the file (ranges sampled per photo)."""

    exposure: tuple[float, float] = (0.3, 2.0)  # × auto exposure (log-uniform); above 1.25 the peak clips
    noise: tuple[float, float] = (0.002, 0.03)
    ambient_probability: float = 0.5  # room light, per channel tinted (0.6–1 × the level per channel)
    ambient: tuple[float, float] = (0.0, 0.05)
    formats: tuple[tuple[str, float], ...] = (("exr", 0.15), ("png16", 0.15), ("png", 0.25), ("jpg", 0.45))
    jpeg_quality: tuple[int, int] = (75, 98)
    gain_error: float = 0.02  # camera unit vs its published curve, per channel (std)
    shift_error_nm: float = 1.0  # wavelength shift of the curve (std)
    generic_probability: float = 0.2
    upsample: int = 2  # photo pixels per cube pixel; the loader reduces it back (see photo.upsample)
    # In-camera JPEG/HEIC photos (share of all), each read with a CIE A calibration of its camera
    # and rendering; a geometry draws them from `in_camera_setups` (camera × rendering × file
    # type) so the calibration shots stay few. 0 reproduces a dataset without them exactly.
    in_camera: float = 0.15
    in_camera_formats: tuple[tuple[str, float], ...] = (("jpg", 0.6), ("heic", 0.4))
    in_camera_setups: int = 4


def perturbed_camera(camera: CameraProfile, rng: np.random.Generator, deg: Degradation) -> CameraProfile:
    shift = rng.normal(0.0, deg.shift_error_nm)
    sens = np.stack([np.interp(WAVELENGTHS_NM - shift, WAVELENGTHS_NM, camera.sensitivities[:, c])
                     for c in range(3)], axis=1)
    sens *= 1.0 + rng.normal(0.0, deg.gain_error, size=3)
    return CameraProfile(camera.name, np.clip(sens, 0.0, None))


# A cube whose first photos are all refused is a geometry the estimator does not read (today: the
# oblique set-ups, refused up front); it is skipped, and included as soon as the estimator reads it.
GIVE_UP_AFTER = 16


@dataclass
class _Variant:
    """A geometry the readout is taken at: the truth, or what the pose fit found on another
    photo of the same capture (its real errors), with the scene's per-pixel coordinates."""

    fit: PoseFit
    pixels: PixelDiffraction


@dataclass
class CubeJob:
    spec: CubeSpec
    n_samples: int
    seed: int
    cameras: list[str]
    deg: Degradation
    engine: str
    samples: int | None
    n_fits: int
    cache_dir: str | None = None
    families: tuple[str, ...] | None = None


def _write_and_load(image: NDArray[np.float64], fmt: str, quality: int, tmpdir: str, exif: bytes, max_side: int
                    ) -> LinearImage:
    ext = {"png16": "png"}.get(fmt, fmt)
    path = Path(tmpdir) / f"sample.{ext}"
    photo.write_photo(path, image, fmt, exif, quality)
    return load_photo(path, max_side=max_side)


def _variants(spec: CubeSpec, cube: NDArray[np.float32], rng: np.random.Generator, n_fits: int,
              train_cameras: list[str], tmpdir: str) -> list[_Variant]:
    """The true geometry, and the pose the product's own path (``prepare``) fits on ``n_fits``
    photos of this capture; photos it refuses give no variant."""
    scene = spec.scene()
    preset = spec.reading_preset()
    meter = photo.track_mask(scene)
    out = [_Variant(PoseFit.of_scene(scene), pixel_diffraction(scene))]
    spds, _ = sample_spds(n_fits, rng)
    for spd in spds:
        cam = load_camera(train_cameras[int(rng.integers(len(train_cameras)))])
        img, _ = photo.synthesize(cube, spd, cam, 0.9, 0.01, rng, meter)
        loaded = _write_and_load(img, "exr", 0, tmpdir, b"", spec.size)
        try:
            fit = read_photo(loaded, preset, cam).fit
        except CDSpectraError:
            continue
        out.append(_Variant(fit, pixel_diffraction(fit.scene(preset, scene.preset.camera.image_size_px))))
    return out


def sample_features(loaded: LinearImage, preset: Preset, camera: CameraProfile, generic: bool, fit: PoseFit | None,
                    pixels: PixelDiffraction | None, prior: tuple[GaussianPrior, NDArray[np.float64]],
                    calibration: Calibration | None = None
                    ) -> tuple[NDArray[np.float32], NDArray[np.float64]] | None:
    """One training sample's network inputs and physics SPD through the product's own inverse path
    (``prepare`` → ``physics_spd`` → ``network_inputs``, with the calibration's camera as
    :func:`~cd_spectra_addon.core.inverse.estimate.estimate_image` takes it), or None where the product
    refuses the photo."""
    camera, generic = solving_camera(camera, generic, calibration)
    try:
        analysis = read_photo(loaded, preset, camera, generic_camera=generic, fit=fit, pixels=pixels,
                           calibration=calibration)
    except CDSpectraError:
        return None
    e_phys = physics_spd(analysis, prior)
    return network_inputs(analysis, e_phys), e_phys


@dataclass
class _InCameraSetup:
    """One camera × rendering × file type of a geometry, with its calibration (None: the product
    refused the calibration shot, so photos taken this way teach nothing)."""

    camera: CameraProfile  # the profile a user would name
    unit: CameraProfile  # the unit that takes the photos (its own small errors)
    pipeline: CameraPipeline
    fmt: str
    generic: bool
    calibration: Calibration | None


def _in_camera_photo(native: NDArray[np.float64], setup: _InCameraSetup, meter: NDArray[np.bool_], deg: Degradation,
                     quality: int, tmpdir: str, exif: bytes, max_side: int) -> LinearImage:
    """The in-camera file of a camera-native photo (upsampled, with noise), as loaded."""
    rendered = render_in_camera(native, setup.pipeline, photo.upsample(meter, deg.upsample).astype(bool))
    return _write_and_load(rendered, setup.fmt, quality, tmpdir, in_camera_exif(exif), max_side)


def _new_in_camera_setup(rng: np.random.Generator, cube: NDArray[np.float32], meter: NDArray[np.bool_],
                         preset: Preset, cameras: list[str], generic: NDArray[np.float64], deg: Degradation,
                         tmpdir: str, exif_for_camera, max_side: int) -> _InCameraSetup:
    """Draw a camera, a rendering and a file type; take and calibrate the CIE A shot the product's way."""
    camera = load_camera(cameras[int(rng.integers(len(cameras)))])
    unit = perturbed_camera(camera, rng, deg)
    names = [f for f, _ in deg.in_camera_formats]
    probs = np.array([w for _, w in deg.in_camera_formats], dtype=np.float64)
    fmt = names[int(rng.choice(len(names), p=probs / probs.sum()))]
    use_generic = bool(rng.random() < deg.generic_probability)
    setup = _InCameraSetup(camera, unit, pipeline_for(camera, sample_style(rng)), fmt, use_generic, None)
    shot, _ = photo.expose(photo.linear_photo(cube, CALIBRATION_LAMP, unit), 1.0, meter)
    shot = np.minimum(photo.add_noise(photo.upsample(shot, deg.upsample), float(np.mean(deg.noise)), rng), 1.0)
    loaded = _in_camera_photo(shot, setup, meter, deg, deg.jpeg_quality[1], tmpdir, exif_for_camera(camera.name),
                              max_side)
    solve = CameraProfile(GENERIC_CAMERA, generic) if use_generic else camera
    try:
        setup.calibration, _ = fit_calibration(loaded, CALIBRATION_LAMP, preset, solve, use_generic, pipeline=True,
                                               prior=camera_prior(cameras) if use_generic else None)
    except CDSpectraError:
        pass
    return setup


def run_cube(job: CubeJob) -> dict[str, NDArray]:
    rng = np.random.default_rng(job.seed)
    spec = job.spec
    scene = spec.scene()
    cache = Path(job.cache_dir) if job.cache_dir else None
    cube, _ = basis_cube(scene, job.engine, job.samples, **({"cache_dir": cache} if cache else {}))
    meter = photo.track_mask(scene)
    generic = generic_sensitivities(job.cameras)
    prior = gaussian_prior()
    precision = prior.precision()
    cam = scene.preset.camera
    preset = spec.reading_preset()
    spds, families = sample_spds(job.n_samples, rng, families=job.families)
    refused = np.zeros(job.n_samples, dtype=bool)
    inputs = np.zeros((job.n_samples, INPUT_SIZE), dtype=np.float32)
    physics = np.zeros((job.n_samples, 81), dtype=np.float32)
    meta = np.zeros((job.n_samples, 5), dtype=np.float32)  # format index, noise, exposure, generic, in camera
    fmt_names = [f for f, _ in job.deg.formats]
    fmt_p = np.array([p for _, p in job.deg.formats])
    fmt_p /= fmt_p.sum()
    deg = job.deg
    # In-camera photos draw from their own generator, so in_camera = 0 leaves every other draw as it was.
    rng_in_camera = np.random.default_rng([job.seed, 11])
    setups: list[_InCameraSetup] = []

    def exif_for_camera(name: str) -> bytes:
        return photo.exif_for(cam.focal_length_mm, cam.sensor_width_mm, cam.image_size_px[0] * deg.upsample, name)

    with tempfile.TemporaryDirectory() as tmp:
        variants = _variants(spec, cube, rng, job.n_fits, job.cameras, tmp)
        for i, spd in enumerate(spds):
            if i == GIVE_UP_AFTER and refused[:i].all():
                refused[i:] = True  # a geometry the estimator does not read (yet): no time spent on it
                break
            camera = load_camera(job.cameras[int(rng.integers(len(job.cameras)))])
            true_cam = perturbed_camera(camera, rng, deg)
            exposure = math.exp(rng.uniform(math.log(deg.exposure[0]), math.log(deg.exposure[1])))
            noise = rng.uniform(*deg.noise)
            setup = None
            if deg.in_camera > 0 and rng_in_camera.random() < deg.in_camera:
                slot = int(rng_in_camera.integers(deg.in_camera_setups))
                while len(setups) <= slot:
                    setups.append(_new_in_camera_setup(rng_in_camera, cube, meter, preset, job.cameras, generic, deg,
                                                       tmp, exif_for_camera, max(cam.image_size_px)))
                setup = setups[slot]
                camera, true_cam, exposure = setup.camera, setup.unit, 1.0  # the camera meters its own rendering
            image, _ = photo.expose(photo.linear_photo(cube, spd, true_cam), exposure, meter)
            image = photo.upsample(image, deg.upsample)
            if rng.random() < deg.ambient_probability:
                image = image + rng.uniform(*deg.ambient) * rng.uniform(0.6, 1.0, size=3)
            image = np.minimum(photo.add_noise(image, noise, rng), 1.0)
            k = int(rng.choice(len(fmt_names), p=fmt_p))
            quality = int(rng.integers(deg.jpeg_quality[0], deg.jpeg_quality[1] + 1))
            exif = exif_for_camera(camera.name)
            variant = variants[int(rng.integers(len(variants)))]
            use_generic = rng.random() < deg.generic_probability
            calibration = None
            if setup is not None:
                if setup.calibration is None:
                    refused[i] = True  # its calibration shot was refused: the product cannot read these
                    continue
                loaded = _in_camera_photo(image, setup, meter, deg, quality, tmp, exif, max(cam.image_size_px))
                use_generic, calibration = setup.generic, setup.calibration
            else:
                loaded = _write_and_load(image, fmt_names[k], quality, tmp, exif, max(cam.image_size_px))
            solve_camera = CameraProfile(GENERIC_CAMERA, generic) if use_generic else camera
            features = sample_features(loaded, preset, solve_camera, use_generic, variant.fit, variant.pixels,
                                       (prior, precision), calibration)
            if features is None:
                refused[i] = True  # the product would refuse this photo: it teaches nothing
                continue
            inputs[i], e_phys = features
            peak = float(e_phys.max())
            physics[i] = e_phys / peak if peak > 0 else 0.0
            in_camera = 0.0 if setup is None else 1.0 + [f for f, _ in deg.in_camera_formats].index(setup.fmt)
            meta[i] = (-1 if setup is not None else k, noise, exposure, float(use_generic), in_camera)
    keep = ~refused
    print(f"  cube {spec.name}: {int(keep.sum())} samples ({int(refused.sum())} refused by the estimator"
          f"{', given up' if refused.all() else ''})", flush=True)
    return {"inputs": inputs[keep], "targets": spds.astype(np.float32)[keep], "physics": physics[keep],
            "meta": meta[keep], "family": np.array(families)[keep], "cube": np.array([spec.name] * int(keep.sum()))}


def dataset_key(cube_set: str, n_per_cube: int, seed: int, engine: str, deg: Degradation) -> str:
    cams, held = camera_split()
    # The samples go through the product's own inverse path: a change anywhere in the core (a pose
    # fit that reads oblique photos, a new readout) makes a new dataset, not a stale cached one.
    core = sorted((Path(__file__).resolve().parents[2] / "cd_spectra_addon" / "core").rglob("*.py"))
    code = b"".join(Path(p).read_bytes() for p in (__file__, photo.__file__, camera_pipelines.__file__, *core))
    blob = json.dumps({"set": [asdict(c) for c in CUBE_SETS[cube_set]], "n": n_per_cube, "seed": seed,
                       "engine": engine, "deg": asdict(deg), "held": held, "input": INPUT_SIZE},
                      sort_keys=True, default=str).encode() + code
    return hashlib.sha256(blob).hexdigest()[:12]


def build_dataset(cube_set: str = SHIPPED_SET, n_per_cube: int = 2500, seed: int = 0, engine: str = "cycles",
                  samples: int | None = None, workers: int = 2, n_fits: int = 3,
                  deg: Degradation = Degradation(), out_dir: Path = DATA_DIR,
                  cache_dir: Path | None = None, log=print) -> Path:
    """Build (or reuse) the dataset file; returns its path."""
    key = dataset_key(cube_set, n_per_cube, seed, engine, deg)
    path = Path(out_dir) / f"{cube_set}-{key}.npz"
    if path.is_file():
        log(f"dataset {path.name} exists")
        return path
    train_cams, _ = camera_split()
    specs = CUBE_SETS[cube_set]
    # Render (or load) the cubes first, in this process: Cycles must not run in two workers.
    for spec in specs:
        basis_cube(spec.scene(), engine, samples, **({"cache_dir": cache_dir} if cache_dir else {}),
                   log=log)
    gaussian_prior()  # computed once here; forked workers inherit the cached value
    jobs = [CubeJob(spec, n_per_cube, seed * 1000 + i, train_cams, deg, engine, samples, n_fits,
                     str(cache_dir) if cache_dir else None) for i, spec in enumerate(specs)]
    start = time.perf_counter()
    if workers > 1:
        with get_context("fork").Pool(workers) as pool:
            parts = pool.map(run_cube, jobs, chunksize=1)
    else:
        parts = [run_cube(job) for job in jobs]
    merged = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    log(f"{len(merged['inputs'])} samples kept of {len(specs) * n_per_cube} photos in {time.perf_counter() - start:.0f} s")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, **merged, key=key)
    os.replace(tmp, path)
    return path
