"""camera_renderings counts what the product refuses (a real camera's rendering can make it refuse
a photo or its calibration shot) instead of stopping the whole evaluation."""

import numpy as np

from cd_spectra_addon.core.spectra.cameras import load_camera
from cd_spectra_addon.core.spectrum.model import load_model
from training.evaluation.camera_files import UPSAMPLE
from training.evaluation.camera_renderings import SETTINGS, Photographer, report, run
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd, planck_spd
from training.evaluation.lamps import Lamp


def _black(native, camera):
    return np.zeros_like(native)  # a rendering that loses the rainbow entirely


def test_refused_photos_and_a_refused_calibration_are_rows_that_say_so(tmp_path):
    ph = Photographer(tmp_path, 96)
    lamps = [Lamp("A", "incandescent", "CIE", known_lamp_spd("incandescent")),
             Lamp("5000 K", "blackbody", "test", planck_spd(5000.0))]  # not the measured lamps: CI has none
    model = load_model()
    photos = run(ph, SETTINGS[0], "jpeg", _black, lamps, model, ())
    assert photos["n"] == 0 and photos["refused"] == 2 and photos["refusals"]
    calibrated = run(ph, SETTINGS[0], "jpeg", _black, lamps, model, ("incandescent",))
    assert calibrated["n"] == 0 and "refused_calibration" in calibrated
    rows = [{**r, "setting": "dslr", "setting_label": "test", "row": name, "reference": ""}
            for r, name in ((photos, "black JPEG"), (calibrated, "black JPEG + CIE A calibration"))]
    text = report(rows, 2, 96, 1.0, "")
    assert "| test | black JPEG | refused |" in text and "| test | black JPEG + CIE A calibration | refused |" in text


def test_jpegs_are_exposed_as_the_readme_says_in_third_stops(tmp_path):
    """README's step 5 ("no clipped (blinking) highlights in the coloured part") as the held-out
    renderings' exposure: compensation in 1/3 EV steps until at most BLINK_SHARE of the tracks
    show a channel at a clipped code (≥ 250, the loader's); metered on the raw instead, a warm
    lamp through daylight white balance blinks over much of the rainbow."""
    from training.evaluation.camera_renderings import BLINK_SHARE, STOP
    from training.evaluation.renderings import ordinary

    camera = load_camera(SETTINGS[0].camera)
    lamp = known_lamp_spd("incandescent")
    blinks = {}
    for metering in ("raw", "rendering"):
        (tmp_path / metering).mkdir()
        ph = Photographer(tmp_path / metering, 64, metering)
        ph.jpeg(lamp, camera, SETTINGS[0].exif, "ordinary", 3, "a")
        ev = ph.compensation_ev[-1]
        exposure = STOP ** round(-3 * ev)
        native = ph.shooter.native(lamp, camera, 3, UPSAMPLE, exposure=exposure)
        blinks[metering] = (ev, ph.blinking(ordinary(native, camera)))
    (raw_ev, raw_blink), (ev, blink) = blinks["raw"], blinks["rendering"]
    assert raw_ev == 0.0 and raw_blink > 10 * BLINK_SHARE
    assert ev < 0 and abs(3 * ev - round(3 * ev)) < 1e-9 and blink <= BLINK_SHARE
    # a third of a stop brighter would still blink: it is the brightest exposure that does not
    brighter = ph.shooter.native(lamp, camera, 3, UPSAMPLE, exposure=STOP ** (round(-3 * ev) - 1))
    assert ph.blinking(ordinary(brighter, camera)) > BLINK_SHARE


def test_every_held_out_rendering_writes_a_brighter_colour_no_darker():
    """A camera's tone curve is monotone: the same colour, exposed brighter, is never written darker
    in any channel (the `phone` look's roll-off once turned past 0.7 and wrote highlights darker than
    midtones, which no camera does and no calibration can undo)."""
    from training.evaluation.renderings import RENDERINGS

    camera = load_camera(SETTINGS[0].camera)
    colours = np.random.default_rng(3).uniform(0.02, 1.0, (64, 3))
    exposures = np.geomspace(0.05, 4.0, 40)
    for name, render in RENDERINGS.items():
        # Each exposure a uniform 8×8 frame (local tone mapping sees a uniform neighbourhood).
        frames = np.stack([render(np.broadcast_to(e * colours[:, None, None, :], (64, 8, 8, 3)).copy(), camera)
                           for e in exposures])
        steps = np.diff(frames[:, :, 4, 4, :], axis=0)
        assert steps.min() > -1e-9, f"{name}: a brighter exposure wrote a channel darker by {-steps.min():.3f}"
        assert frames[-1].max() > frames[0].max(), name


def test_the_section_says_how_well_the_confidence_orders_its_rows_errors():
    from training.evaluation.camera_renderings import confidence_ranking

    rows = [{"n": 10, "mae_400_700": m, "confidence": c} for m, c in ((0.01, 0.99), (0.02, 0.9), (0.4, 0.05))]
    assert "over the 3 rows read: rank correlation -1.00" in confidence_ranking(rows + [{"n": 0}])
    rows[0]["confidence"] = 0.01  # the best estimate the least trusted
    assert "rank correlation 0.50" in confidence_ranking(rows)


def test_renderings_can_be_written_as_the_file_each_camera_writes(tmp_path):
    """A DSLR writes a 4:2:2 fine JPEG and a phone a HEIC: the held-out renderings are measured on
    those too (their own sections), read by the product as the in-camera files they are."""
    from training.evaluation.camera_renderings import FILES, _section

    camera = load_camera(SETTINGS[0].camera)
    sections = {_section("rendering", UPSAMPLE, f) for f in FILES}
    assert len(sections) == len(FILES) and _section("rendering", UPSAMPLE) == _section("rendering", UPSAMPLE, "jpeg")
    for f in ("dslr-jpeg", "heic"):
        (tmp_path / f).mkdir()
        ph = Photographer(tmp_path / f, 64, file=f)
        image = ph.jpeg(known_lamp_spd("incandescent"), camera, SETTINGS[0].exif, "ordinary", 3, "a")
        assert image.processed and image.path.endswith(FILES[f][1]), (f, image.path)
