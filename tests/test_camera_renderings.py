"""camera_renderings counts what the product refuses (a real camera's rendering can make it refuse
a photo or its calibration shot) instead of stopping the whole evaluation."""

import numpy as np

from cd_spectra_addon.core.spectrum.model import load_model
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
