"""A camera without a profile, read with the generic one: its colours are not the camera's, and the
pose fit must not take a wider lamp for the way to hide that mismatch.

camera_files' "held-out camera (EXIF unknown → generic)" row read two Sony ILCE-6400 photos of 30
with the lamp 2.7× too large and the disc 2° tilted (MAE 0.36 / 0.40 against 0.086 / 0.081 at
the true pose): the coarse stage weighs the camera's colour fully and a wider lobe blurs the
expected colours. Here the same camera photographs a Planck lamp (synthetic, not a measured one).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cd_spectra_addon.core.inverse.estimate import estimate_image, resolve_camera
from cd_spectra_addon.core.inverse.stages import pose_photo
from cd_spectra_addon.core.spectra.cameras import load_camera
from cd_spectra_addon.core.spectrum.model import load_model
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.spectra.illuminants import planck_spd
from training.evaluation import camera_files

HELD_OUT = "Sony_ILCE-6400"  # not among the training cameras; its EXIF names no camera here


@pytest.fixture(scope="module")
def photo(tmp_path_factory):
    shooter = camera_files.Shooter(tmp_path_factory.mktemp("generic"), 192)
    row = next(r for _, r in camera_files.ROWS if r.label.startswith("DNG, held-out camera (EXIF unknown"))
    spd = planck_spd(3000.0)
    spd = spd / spd.max()
    image = shooter.shoot(row, spd, load_camera(HELD_OUT), camera_files.UNKNOWN_CAMERA, None, seed=1010, tag="p")
    return shooter.scene.preset, image, spd


@pytest.mark.slow
def test_generic_profile_keeps_the_lamp_size_and_reads_the_lamp(photo):
    preset, image, spd = photo
    model = load_model()
    camera, generic, _, _ = resolve_camera("auto", image, model)
    assert generic  # the shipped model's generic profile, not the photographing camera's
    posed = pose_photo(image, preset, camera, generic_camera=True)
    # Was 0.0082 for the preset's 0.003 on the bench's photos (and MAE 0.29 on this one).
    assert posed.fit.lobe_sigma < 1.5 * preset.light.lobe_sigma
    est = estimate_image(image, preset=preset, camera="auto", model=model)
    mae = compare_spds(est.spd, spd)["mae_400_700"]
    assert np.isfinite(mae) and mae < 0.2, mae  # 0.13 now: what the generic profile's colours allow
