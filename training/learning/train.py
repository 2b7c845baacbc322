"""Train the spectral model on the synthetic dataset and export it to ONNX (``make model``).

    python -m training.learning.train [--set buildable|full|smoke|buildable-smoke] [--n-per-cube N] [--epochs N]
                             [--seed N] [--out models/] [--engine cycles|numpy] [--tune-photos N]

Seeded end to end (prior, photos, split, initialisation, batches). Writes
``<out>/cd_spectra.onnx`` and its metadata ``<out>/cd_spectra.json``, checks onnxruntime against
torch (max |Δ| ≤ 1e-5) and refuses to write a model that fails the check.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from cd_spectra_addon import __version__
from cd_spectra_addon.core.spectra import colour
from cd_spectra_addon.core.pose import fit as pose_fit
from cd_spectra_addon.core.readout import readout
from cd_spectra_addon.core.spectrum import solve
from cd_spectra_addon.core.scene.capture import preset_digests
from cd_spectra_addon.core.spectrum.model import INPUT_LAYOUT, INPUT_SIZE, MODEL_NAME, layout_hash, load_model
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

from training.simulation.basis import REPO
from training.learning.dataset import CUBE_SETS, SHIPPED_SET, build_dataset, camera_split, generic_sensitivities
from training.learning.spd_prior import gaussian_prior
from training.learning.tune_fusion import fusion_metadata, report, tune

BAND_WEIGHT = np.where((WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700), 1.0, 0.5)

__all__ = ["SpectralNet", "train", "export_onnx", "main"]


class SpectralNet(nn.Module):
    """MLP from the model inputs to a peak-normalised SPD and a log standard deviation.

    The physics-only solution is both an input and a skip path (the network learns a correction
    on top of it in softplus space), so an untrained or unsure network falls back on physics.
    """

    def __init__(self, hidden: tuple[int, ...] = (512, 512, 256), physics_slice: tuple[int, int] | None = None):
        super().__init__()
        layers: list[nn.Module] = []
        width = INPUT_SIZE
        for h in hidden:
            layers += [nn.Linear(width, h), nn.GELU()]
            width = h
        self.body = nn.Sequential(*layers)
        self.spd = nn.Linear(width, len(WAVELENGTHS_NM))
        self.log_std = nn.Linear(width, len(WAVELENGTHS_NM))
        self.physics_slice = physics_slice or _slice("physics")
        self.skip = nn.Parameter(torch.tensor(1.0))

    def forward(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        h = self.body(x)
        a, b = self.physics_slice
        raw = nn.functional.softplus(self.spd(h) + self.skip * 4.0 * (x[:, a:b] - 0.5))
        spd = raw / raw.amax(dim=1, keepdim=True).clamp_min(1e-12)
        return spd, self.log_std(h).clamp(-9.0, 1.0)


def _slice(name: str) -> tuple[int, int]:
    start = 0
    for key, n in INPUT_LAYOUT:
        if key == name:
            return start, start + n
        start += n
    raise KeyError(name)


# Weight of the u'v' term (10: Δu'v' 0.001, just visible, costs as much as an MAE of 0.01).
# Default 0: trained with 10 the network was *worse* on synthetic photos of physical lamps once
# fused with the photo (score 0.104 vs 0.094, bench/fusion_tuning.md, 48 photos each) — the
# fusion already fixes colour from the photo, and the colour term cost spectral shape.
COLOUR_WEIGHT = 0.0


def _cmf() -> torch.Tensor:
    """CIE 1931 CMFs integrated over each band's hat, (81, 3): the colour the SPD makes."""
    return torch.from_numpy(np.stack([colour.spd_to_xyz(row) for row in np.eye(len(WAVELENGTHS_NM))]).astype(
        np.float32))


def _uv_prime(spd: torch.Tensor, cmf: torch.Tensor) -> torch.Tensor:
    xyz = spd @ cmf
    d = (xyz[:, 0] + 15.0 * xyz[:, 1] + 3.0 * xyz[:, 2]).clamp_min(1e-9)
    return torch.stack([4.0 * xyz[:, 0] / d, 9.0 * xyz[:, 1] / d], dim=1)


def loss_fn(spd: torch.Tensor, log_std: torch.Tensor, target: torch.Tensor, weight: torch.Tensor,
            cmf: torch.Tensor | None = None, colour_weight: float = COLOUR_WEIGHT) -> torch.Tensor:
    """Band-weighted L1, the colour the SPD makes (u'v'), and a Laplace likelihood that
    calibrates the uncertainty. Without the colour term the network trades colour for shape:
    a few small errors that all lean the same way move the light's colour visibly."""
    err = (spd - target).abs()
    l1 = (err * weight).mean()
    nll = ((err.detach() / log_std.exp() + log_std) * weight).mean()
    loss = l1 + 0.05 * nll
    if cmf is not None and colour_weight > 0:
        loss = loss + colour_weight * (_uv_prime(spd, cmf) - _uv_prime(target, cmf)).abs().sum(dim=1).mean()
    return loss


def train(data: dict[str, np.ndarray], epochs: int, seed: int, hidden: tuple[int, ...] = (512, 512, 256),
          batch: int = 256, lr: float = 2e-3, colour_weight: float = COLOUR_WEIGHT,
          log=print) -> tuple[SpectralNet, dict[str, Any]]:
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    x = torch.from_numpy(data["inputs"].astype(np.float32))
    y = torch.from_numpy(data["targets"].astype(np.float32))
    n = x.shape[0]
    order = rng.permutation(n)
    n_val = max(1, n // 10)
    val, tr = order[:n_val], order[n_val:]
    model = SpectralNet(hidden)
    opt = torch.optim.AdamW(model.parameters(), lr=lr, weight_decay=1e-4)
    steps = epochs * max(1, len(tr) // batch)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=lr, total_steps=steps, pct_start=0.1)
    weight = torch.from_numpy(BAND_WEIGHT.astype(np.float32))
    cmf = _cmf()
    gen = torch.Generator().manual_seed(seed)
    history = []
    start = time.perf_counter()
    for epoch in range(epochs):
        model.train()
        perm = torch.from_numpy(tr)[torch.randperm(len(tr), generator=gen)]
        for i in range(0, len(perm) - batch + 1, batch):
            idx = perm[i:i + batch]
            spd, log_std = model(x[idx])
            loss = loss_fn(spd, log_std, y[idx], weight, cmf, colour_weight)
            opt.zero_grad()
            loss.backward()
            opt.step()
            sched.step()
        if epoch % 10 == 9 or epoch == epochs - 1:
            model.eval()
            with torch.no_grad():
                spd, _ = model(x[val])
                mae = float((spd - y[val]).abs().mean())
                duv = float((_uv_prime(spd, cmf) - _uv_prime(y[val], cmf)).norm(dim=1).mean())
            history.append({"epoch": epoch + 1, "val_mae": mae, "val_duv": duv})
            log(f"epoch {epoch + 1}: synthetic validation MAE {mae:.4f}, Δu'v' {duv:.4f}")
    info = {"epochs": epochs, "train_samples": int(len(tr)), "val_samples": int(n_val),
            "seconds": time.perf_counter() - start, "history": history, "hidden": list(hidden),
            "val_mae": history[-1]["val_mae"], "val_duv": history[-1]["val_duv"],
            "colour_weight": colour_weight}
    return model.eval(), info


def export_onnx(model: SpectralNet, path: Path, metadata: dict[str, Any], probe: np.ndarray) -> float:
    """Write the ONNX file (opset 17, metadata in metadata_props) and return the max |Δ| between
    onnxruntime and torch on ``probe`` (real model inputs from the dataset)."""
    import onnx
    import onnxruntime as ort

    dummy = torch.zeros(1, INPUT_SIZE)
    tmp = path.with_suffix(".tmp.onnx")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        torch.onnx.export(model, (dummy,), str(tmp), input_names=["inputs"], output_names=["spd", "log_std"],
                          dynamic_axes={"inputs": {0: "batch"}, "spd": {0: "batch"}, "log_std": {0: "batch"}},
                          opset_version=17, dynamo=False)
    proto = onnx.load(str(tmp))
    for key in ("version", "layout_hash", "data_hash", "wavelength_nm"):
        entry = proto.metadata_props.add()
        entry.key, entry.value = key, json.dumps(metadata[key]) if not isinstance(metadata[key], str) else metadata[key]
    proto.producer_name = "cd-spectra"
    onnx.checker.check_model(proto)
    onnx.save(proto, str(tmp))
    session = ort.InferenceSession(str(tmp), providers=["CPUExecutionProvider"])
    x = torch.from_numpy(np.ascontiguousarray(probe, dtype=np.float32))
    with torch.no_grad():
        ref_spd, ref_std = model(x)
    spd, log_std = session.run(["spd", "log_std"], {"inputs": x.numpy()})
    diff = max(float(np.abs(spd - ref_spd.numpy()).max()), float(np.abs(log_std - ref_std.numpy()).max()))
    if diff > 1e-5:
        tmp.unlink()
        raise RuntimeError(f"onnxruntime and torch disagree by {diff:.2e} (> 1e-5); model not written")
    os.replace(tmp, path)
    return diff


def write_json(path: Path, payload: dict[str, Any]) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".json")
    with os.fdopen(fd, "w", encoding="utf-8") as handle:
        json.dump(payload, handle, indent=1)
        handle.write("\n")
    os.replace(tmp, path)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", default=SHIPPED_SET, choices=sorted(CUBE_SETS))
    parser.add_argument("--n-per-cube", type=int, default=1000,
                        help="photos per geometry (buildable: 11 read today × 1000, 17 × 1000 once oblique photos are read)")
    parser.add_argument("--epochs", type=int, default=60)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--engine", default="cycles", choices=("cycles", "numpy"))
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--hidden", type=int, nargs="+", default=[512, 512, 256])
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--colour-weight", type=float, default=COLOUR_WEIGHT,
                        help="weight of the u'v' colour term in the loss (0 = shape only)")
    parser.add_argument("--tune-photos", type=int, default=96,
                        help="synthetic photos per case for the fusion and per-band choice (refused ones are left out)")
    parser.add_argument("--unseen-epochs", type=int, default=30,
                        help="epochs of each held-out-family probe (0: choose bands on the training families only)")
    parser.add_argument("--unseen-photos", type=int, default=48, help="photos of each held-out family group")
    parser.add_argument("--fusion-report", type=Path, default=None,
                        help="where the fusion tables go (default: bench/fusion_tuning.md for the shipped set in models/)")
    parser.add_argument("--out", type=Path, default=REPO / "models")
    args = parser.parse_args(argv)
    torch.set_num_threads(max(1, min(args.threads, os.cpu_count() or 1)))
    t0 = time.perf_counter()
    path = build_dataset(args.set, args.n_per_cube, args.seed, args.engine, workers=args.workers)
    dataset_seconds = time.perf_counter() - t0  # 0 when the dataset was cached
    data = dict(np.load(path))
    model, info = train(data, args.epochs, args.seed, tuple(args.hidden), colour_weight=args.colour_weight)
    train_cams, held = camera_split()
    prior = gaussian_prior()
    args.out.mkdir(parents=True, exist_ok=True)
    metadata: dict[str, Any] = {
        "name": MODEL_NAME,
        "version": f"{__version__}+{str(data['key'])}",
        "layout_hash": layout_hash(),
        "data_hash": str(data["key"]),
        "wavelength_nm": WAVELENGTHS_NM.tolist(),
        "feature_lambda_nm": readout.FEATURE_LAMBDA_NM.tolist(),
        "input_layout": [list(item) for item in INPUT_LAYOUT],
        "preprocessing": {"fit_side": pose_fit.COARSE_SIDE, "min_visibility": readout.MIN_VISIBILITY,
                          "outlier_mads": readout.OUTLIER_MADS, "feature_step_nm": readout.FEATURE_STEP_NM,
                          "smoothness": solve.SMOOTHNESS, "model_error_floor": solve.MODEL_ERROR_FLOOR},
        "presets": preset_digests(),
        "cameras": {"train": train_cams, "held_out": held},
        "generic_camera": generic_sensitivities(train_cams).round(6).tolist(),
        "training": {**info, "cube_set": args.set, "cubes": [c.name for c in CUBE_SETS[args.set]],
                     "n_per_cube": args.n_per_cube, "seed": args.seed, "engine": args.engine,
                     "dataset_seconds": dataset_seconds, "tune_seconds": None, "total_seconds": None},
        "metrics": {},
        "prior": {"mean": prior.mean.round(7).tolist(), "covariance": prior.covariance.round(9).tolist(),
                  "strength": solve.PRIOR_STRENGTH, "jitter": solve.PRIOR_JITTER,
                  "source": "training.learning.spd_prior.gaussian_prior() (synthetic spectra only)"},
    }
    onnx_path = args.out / f"{MODEL_NAME}.onnx"
    n_probe = min(512, len(data["inputs"]))
    probe = data["inputs"][np.random.default_rng(args.seed + 1).choice(len(data["inputs"]), n_probe, replace=False)]
    diff = export_onnx(model, onnx_path, metadata, probe)
    metadata["onnx_parity_max_abs_diff"] = diff
    write_json(onnx_path.with_suffix(".json"), metadata)
    # How far the final solve trusts the network: chosen on synthetic photos, stored with it.
    # …and, per band, whether the network beats physics + prior at all (else physics + prior ships there).
    t_tune = time.perf_counter()
    unseen = None
    shipped = args.set == SHIPPED_SET and args.out.resolve() == (REPO / "models").resolve()
    if args.unseen_epochs > 0:
        from training.learning import heldout_families  # it trains through this module

        probes = heldout_families.run(data, args.set, args.unseen_epochs, args.unseen_photos, args.engine)
        unseen = probes["pooled"]
        if shipped:
            text = heldout_families.report(probes, path.name)
            (REPO / "bench" / "heldout_families.md").write_text(text, encoding="utf-8")
    fusion = tune(load_model(onnx_path), args.set, args.tune_photos, args.engine, unseen)
    metadata["training"]["tune_seconds"] = time.perf_counter() - t_tune
    metadata["fusion"] = fusion_metadata(fusion)
    # When the blind tails follow a Planck curve (synthetic photos of the reference geometry).
    from training.learning import tune_tails

    tails = tune_tails.tune(tune_tails.tail_cases(max(4 * args.tune_photos, 8), model=load_model(onnx_path)))
    metadata["tails"] = tune_tails.tails_metadata(tails)
    if shipped:
        (REPO / "bench" / "tails_tuning.md").write_text(tune_tails.report(tails), encoding="utf-8")
    fusion_report = args.fusion_report
    if fusion_report is None and shipped:
        fusion_report = REPO / "bench" / "fusion_tuning.md"
    if fusion_report is not None:
        fusion_report.write_text(report(fusion), encoding="utf-8")
    metadata["training"]["total_seconds"] = time.perf_counter() - t0
    write_json(onnx_path.with_suffix(".json"), metadata)
    print(f"wrote {onnx_path} ({onnx_path.stat().st_size / 1e6:.1f} MB), parity {diff:.1e}, "
          f"{metadata['training']['total_seconds'] / 60:.1f} min")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
