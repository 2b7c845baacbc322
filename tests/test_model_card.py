"""models/MODEL_CARD.md's account of the network (issue 21: what it does, where, what it wins)."""

import json

from training.evaluation import model_card
from training.simulation.basis import REPO

META = json.loads((REPO / "models" / "cd_spectra.json").read_text(encoding="utf-8"))


def _band_choice(version, blend_380, prior_380):
    bands = [[380, 400], [400, 450]]
    row = {"mae_400_700": 0.02, "mae_380_780": 0.03, "delta_uv_prime": 0.0004}
    return {"bands_nm": bands, "real": {"n": 312, "model_version": version,
                                        "blend": {**row, "bands": [blend_380, 0.1]},
                                        "prior": {**row, "bands": [prior_380, 0.1]}}}


def test_the_card_names_each_band_the_network_is_used_in_and_its_measured_lead():
    used = [r for r in META["fusion"]["bands"]["uncalibrated"] if r["network"]]
    assert used  # the shipped model uses the network somewhere
    lines = model_card._wins_lines(META["fusion"], _band_choice(META["version"], 0.0123, 0.0456))
    text = "\n".join(lines)
    for r in used:
        assert f"{r['band'][0]}–{r['band'][1]} nm: MAE {r['mae_network']:.4f}" in text
    if any(r["band"] == [380, 400] for r in used):
        assert "380–400 nm 0.0123 against 0.0456" in text and "312 measured lamps" in text


def test_no_band_no_claim_and_no_lamps_no_lamp_figures():
    fusion = {**META["fusion"], "bands": {"uncalibrated": [{**r, "network": False}
                                                           for r in META["fusion"]["bands"]["uncalibrated"]]}}
    assert model_card._wins_lines(fusion, _band_choice(META["version"], 0.01, 0.02)) == []
    assert "measured lamps" not in "\n".join(model_card._wins_lines(META["fusion"], None))


def test_the_card_says_which_set_ups_changed_after_training():
    """A preset whose file digest differs from the one the model recorded is named (its training
    photos came from the earlier geometry); none changed, nothing said."""
    trained = {"phone-near-axis": "a" * 16, "tripod-oblique": "b" * 16}
    meta = {"presets": trained}
    assert model_card._drift_lines(meta, dict(trained)) == []
    text = "\n".join(model_card._drift_lines(meta, {**trained, "tripod-oblique": "c" * 16}))
    assert "`tripod-oblique`" in text and "`phone-near-axis`" not in text and "earlier file" in text
    text = "\n".join(model_card._drift_lines(meta, {**trained, "kim": "d" * 16}))
    assert "`kim` (new)" in text and "earlier file" not in text
