"""The training pipeline end to end at smoke scale: dataset → torch → ONNX → the runtime loader.

CI trains only this tiny model; the shipped model in models/ is built by `make model`.
"""

import json
import subprocess
import sys

import numpy as np
import pytest

from cd_spectra_addon.core.model import INPUT_SIZE, load_model
from training.learning import dataset
from training.learning import train
from training.learning.spd_prior import gaussian_prior


def test_camera_split_holds_out_a_quarter():
    seen, held = dataset.camera_split()
    assert len(held) == 13 and not set(seen) & set(held)
    assert dataset.generic_sensitivities().max() == pytest.approx(1.0)


@pytest.mark.slow
def test_training_never_imports_the_measured_lamps():
    """Measured lamps are for evaluation only: no training module may load them."""
    code = ("import sys, training.learning.train, training.learning.dataset, training.learning.spd_prior, training.learning.tune_solver;"
            "print('training.evaluation.lamps' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.slow
def test_smoke_model_trains_exports_and_loads(tmp_path):
    out = tmp_path / "model"
    code = train.main(["--set", "smoke", "--n-per-cube", "60", "--epochs", "2", "--engine", "numpy",
                       "--workers", "1", "--out", str(out)])
    assert code == 0
    meta = json.loads((out / "cd_spectra.json").read_text())
    assert meta["onnx_parity_max_abs_diff"] <= 1e-5
    assert len(meta["prior"]["mean"]) == 81 and meta["cameras"]["held_out"]
    model = load_model(out / "cd_spectra.onnx")
    x = np.random.default_rng(0).random((5, INPUT_SIZE)).astype(np.float32)
    spd, std = model.predict(x)
    assert spd.shape == (5, 81) and np.allclose(spd.max(axis=1), 1.0) and spd.min() >= 0
    assert np.all(np.isfinite(std)) and np.all(std > 0)


def test_gaussian_prior_is_deterministic():
    a, b = gaussian_prior(2000, 3), gaussian_prior(2000, 3)
    assert np.array_equal(a.mean, b.mean) and a.covariance.shape == (81, 81)


def test_in_camera_photos_join_the_dataset_without_disturbing_the_rest():
    """A share of in-camera JPEG/HEIC photos, each read with its camera's CIE A calibration (the
    generic ones with fitted sensitivities); the other samples stay exactly what they were."""
    spec = dataset.CUBE_SETS["smoke"][0]
    train_cams, _ = dataset.camera_split()

    def run(share: float) -> dict:
        deg = dataset.Degradation(in_camera=share, in_camera_setups=3, generic_probability=0.5)
        return dataset._run_cube(dataset._CubeJob(spec, 16, 3, train_cams, deg, "numpy", None, 1))

    plain, mixed = run(0.0), run(0.5)
    assert plain["inputs"].shape[0] == mixed["inputs"].shape[0] == 16  # nothing refused: rows align
    in_camera = mixed["meta"][:, 4] > 0
    assert 3 <= in_camera.sum() <= 13 and not np.any(plain["meta"][:, 4])
    assert np.all(mixed["meta"][in_camera, 0] == -1) and np.any(mixed["meta"][in_camera, 3] == 1)  # generic ones too
    np.testing.assert_array_equal(plain["inputs"][~in_camera], mixed["inputs"][~in_camera])
    assert np.all(np.isfinite(mixed["inputs"])) and not np.allclose(plain["inputs"][in_camera],
                                                                   mixed["inputs"][in_camera])
    generic_flag = mixed["inputs"][:, INPUT_SIZE - 2]  # the scalars' generic-camera flag
    assert np.all(generic_flag[in_camera] == 0)  # calibrated: the camera counts as known
