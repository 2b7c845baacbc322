"""Measured lamps for evaluation only: the 205 LSPDD lamps and colour-science's measured sources.

Never imported by training code (a test checks that): a result on data the model has seen is
not a result.
"""

from __future__ import annotations

import csv
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon.core.spectra.grid import peak_normalise, resample_to_grid

from training.simulation.basis import REPO

SHARED_DATA = Path(os.environ.get("CD_SPECTRA_SHARED_DATA", REPO.parent / "shared" / "data"))
LSPDD_FILE = SHARED_DATA / "spds-validation" / "lspdd_lamps_273-899.5nm_0.5nm_wide.csv"
LSPDD_FAMILIES = {"LED": "LED", "CFL": "fluorescent", "FL": "fluorescent", "Halo": "halogen", "INC": "incandescent",
                  "MH": "discharge", "HPS": "discharge", "sun": "daylight"}

__all__ = ["Lamp", "lspdd_lamps", "colour_lamps", "all_lamps"]


@dataclass(frozen=True)
class Lamp:
    name: str
    family: str
    source: str  # "LSPDD" or "colour-science"
    spd: NDArray[np.float64]  # on the product grid, peak 1


def lspdd_lamps(path: Path = LSPDD_FILE) -> list[Lamp]:
    with open(path, newline="", encoding="utf-8") as handle:
        reader = csv.reader(handle)
        header = next(reader)
        data = np.array([[float(v) for v in row] for row in reader])
    spds = peak_normalise(np.clip(resample_to_grid(data[:, 0], data[:, 1:].T), 0.0, None))  # meter dark noise
    lamps = []
    for name, spd in zip(header[1:], spds):
        category = name.split("|")[1] if "|" in name else "other"
        lamps.append(Lamp(name, LSPDD_FAMILIES.get(category, category), "LSPDD", spd))
    return lamps


def _colour_family(name: str) -> str:
    rules = [
        (r"LED|PHOS|Luxeon", "LED"),
        (r"^FL|Triphosphor|TL8|Polylux|Kolor|Luxline|Cool White|Daylight FL|Broadband|Delux|Natural FL|"
         r"Warm White|TL-84|F34T12/LW|^Natural$", "fluorescent"),
        (r"HPS|^HP\d|LPS|Mercury|Metal Halide|MHC|H38", "discharge"),
        (r"^A$|^SA$|Incandescent|Tungsten|Photoflood|Printer|60 A/W", "incandescent"),
        (r"^D\d\d|^ID\d\d|^B$|^C$|^SC$|Daylight", "daylight"),
        (r"Kinoton", "xenon"),
    ]
    for pattern, family in rules:
        if re.search(pattern, name):
            return family
    return "other"


def colour_lamps() -> list[Lamp]:
    """colour-science's measured light sources and CIE illuminants (not E, which is no lamp)."""
    import colour

    lamps = []
    seen: set[str] = set()
    for group in (colour.SDS_LIGHT_SOURCES, colour.SDS_ILLUMINANTS):
        for name, sd in group.items():
            if name == "E" or name in seen:
                continue
            seen.add(name)
            wl, values = np.asarray(sd.wavelengths, float), np.asarray(sd.values, float)
            if wl.min() > 400 or wl.max() < 700:
                continue
            spd = peak_normalise(resample_to_grid(wl, np.clip(values, 0, None)))
            if spd.max() > 0:
                lamps.append(Lamp(name, _colour_family(name), "colour-science", spd))
    return lamps


def all_lamps() -> list[Lamp]:
    return lspdd_lamps() + colour_lamps()


