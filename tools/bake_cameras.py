"""Bake the 52 measured camera sensitivities (rawtoaces-data, Apache-2.0) into one shipped file.

    make bake-cameras   (python -m tools.bake_cameras [--source ../shared/data/cameras])

The add-on reads ``cd_spectra_addon/cameras/cameras.json``; the per-camera JSON files stay the
reference. Re-run only when the source data changes (the output is committed).
"""

from __future__ import annotations

import argparse
import json
import shutil
from pathlib import Path

import numpy as np

from cd_spectra_addon.core.spectra.cameras import CAMERA_FILE
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

DEFAULT_SOURCE = Path(__file__).resolve().parents[2] / "shared" / "data" / "cameras"


def bake(source: Path, target: Path = CAMERA_FILE) -> int:
    cameras: dict[str, dict] = {}
    for path in sorted(source.glob("*_380_780_5.json")):
        data = json.loads(path.read_text(encoding="utf-8"))
        header = data["header"]
        rows = data["spectral_data"]["data"]["main"]
        wl = np.array(sorted(float(k) for k in rows))
        if not np.allclose(wl, WAVELENGTHS_NM):
            raise ValueError(f"{path.name}: not sampled at 380-780 nm / 5 nm")
        rgb = np.array([rows[k] for k in sorted(rows, key=float)], dtype=float)
        name = path.name.removesuffix("_380_780_5.json")
        cameras[name] = {
            "manufacturer": header.get("manufacturer", ""),
            "model": header.get("model", ""),
            "laboratory": header.get("laboratory", ""),
            "unique_identifier": header.get("unique_identifier", ""),
            "rgb": np.round(rgb, 7).tolist(),
        }
    payload = {
        "source": "AcademySoftwareFoundation/rawtoaces-data, data/camera/ (relative R, G, B sensitivity)",
        "license": "Apache-2.0",
        "wavelength_nm": WAVELENGTHS_NM.tolist(),
        "cameras": cameras,
    }
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(json.dumps(payload, separators=(",", ":")) + "\n", encoding="utf-8")
    licence = source / "LICENSE_Apache-2.0.txt"
    if licence.is_file():
        shutil.copyfile(licence, target.parent / "LICENSE_Apache-2.0.txt")
    return len(cameras)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=DEFAULT_SOURCE)
    args = parser.parse_args()
    print(f"baked {bake(args.source)} cameras into {CAMERA_FILE}")


if __name__ == "__main__":
    main()
