"""A photo resized or cropped after it was taken, its EXIF kept as it was (what many apps and
editors do): the EXIF's two focal lengths then disagree, and the pose stage keeps the one that
explains the photo. Before, a 512 px copy of the sample photo was read with twice its lens and
gave no white light at all."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from cd_spectra_addon.core.inverse.estimate import estimate_photo
from cd_spectra_addon.core.inverse.stages import EXIF_FOCAL_AGREEMENT, focal_px_options
from cd_spectra_addon.core.photo.image_formats import ExifInfo
from cd_spectra_addon.core.photo.images import LinearImage
from cd_spectra_addon.core.scene.capture import DEFAULT_PRESET

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "cd_photo.jpg"  # FL11 (4000 K), `make sample-photo`
TRUE_CCT_K = 4000.0


def _image(exif: ExifInfo, side: int = 512) -> LinearImage:
    empty = np.zeros((side, side), bool)
    return LinearImage(rgb=np.zeros((side, side, 3), np.float32), saturated=empty, invalid=empty, scale=1.0,
                       original_size=(side, side), encoding="srgb-8", exif=exif, path="")


AGREE = 26.0 / 36.0 * 512  # px/mm that make a 1 mm lens the 26 mm equivalent's field of view at 512 px


@pytest.mark.parametrize("plane, equivalent, n", [(AGREE, 26.0, 1), (AGREE * 1.1, 26.0, 1), (AGREE * 2, 26.0, 2),
                                                  (AGREE, 26.0 * 2, 2), (None, 26.0, 1), (AGREE, None, 1),
                                                  (None, None, 0)])
def test_both_focal_lengths_are_offered_only_where_they_disagree(plane, equivalent, n):
    exif = ExifInfo(focal_length_mm=None if plane is None else 1.0, focal_plane_px_per_mm=plane,
                    focal_length_35mm=equivalent)
    options = focal_px_options(_image(exif))
    assert len(options) == n
    if n == 2:
        a, b = sorted(v for v, _ in options)
        assert b > EXIF_FOCAL_AGREEMENT * a
        assert [s for _, s in options] == ["exif", "exif-35mm"]


@pytest.mark.slow  # two estimates with two pose fits each: ~5 s
@pytest.mark.parametrize("edit, source", [("resized", "exif-35mm, resized"), ("cropped", "exif, cropped")])
def test_a_resized_or_cropped_photo_is_read_with_the_focal_length_that_explains_it(tmp_path, edit, source):
    with Image.open(SAMPLE) as im:
        exif = im.info["exif"]
        side = im.size[0]
        if edit == "resized":
            out = im.resize((side // 2, side // 2), Image.LANCZOS)
        else:
            o = side // 10
            out = im.crop((o, o, side - o, side - o))
        path = tmp_path / f"{edit}.jpg"
        out.save(path, quality=92, exif=exif)
    est = estimate_photo(path, preset=DEFAULT_PRESET, model=None, method="prior")
    assert est.extra["focal_px_source"] == source
    assert est.cct_k is not None and abs(est.cct_k - TRUE_CCT_K) < 200
    assert any(f"it was {edit} after it was taken" in w for w in est.warnings)
