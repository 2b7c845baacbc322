"""camera_renderings counts what the product refuses (a real camera's rendering can make it refuse
a photo or its calibration shot) instead of stopping the whole evaluation."""

import numpy as np

from cd_spectra_addon.core.spectrum.model import load_model
from training.evaluation.camera_renderings import SETTINGS, Photographer, report, run
from training.evaluation.lamps import lspdd_lamps


def _black(native, camera):
    return np.zeros_like(native)  # a rendering that loses the rainbow entirely


def test_refused_photos_and_a_refused_calibration_are_rows_that_say_so(tmp_path):
    ph = Photographer(tmp_path, 96)
    lamps = lspdd_lamps()[:2]
    model = load_model()
    photos = run(ph, SETTINGS[0], "jpeg", _black, lamps, model, ())
    assert photos["n"] == 0 and photos["refused"] == 2 and photos["refusals"]
    calibrated = run(ph, SETTINGS[0], "jpeg", _black, lamps, model, ("incandescent",))
    assert calibrated["n"] == 0 and "refused_calibration" in calibrated
    rows = [{**r, "setting": "dslr", "setting_label": "test", "row": name, "reference": ""}
            for r, name in ((photos, "black JPEG"), (calibrated, "black JPEG + CIE A calibration"))]
    text = report(rows, 2, 96, 1.0, "")
    assert "| test | black JPEG | refused |" in text and "| test | black JPEG + CIE A calibration | refused |" in text
