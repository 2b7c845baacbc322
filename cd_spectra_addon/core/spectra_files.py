"""Reading spectra from the files people actually have: CSV/TSV from meters and databases.

A spectra table has the wavelength (nm) in its first column and one spectrum per further
column, with or without a header row, comma/semicolon/tab separated. Values are resampled
onto the product grid with :func:`~cd_spectra_addon.core.spectral_grid.resample_to_grid`.
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .spectral_grid import WAVELENGTHS_NM, resample_to_grid

MAX_TABLE_BYTES = 64 * 1024 * 1024

__all__ = ["SpectraTable", "read_spectra_csv", "safe_stem"]


@dataclass(frozen=True)
class SpectraTable:
    names: list[str]
    wavelengths_nm: NDArray[np.float64]
    values: NDArray[np.float64]  # (n_spectra, n_wavelengths) as read

    def on_grid(self) -> NDArray[np.float64]:
        """(n_spectra, 81) on 380–780 nm / 5 nm."""
        return resample_to_grid(self.wavelengths_nm, self.values, WAVELENGTHS_NM)


def read_spectra_csv(path: str | Path) -> SpectraTable:
    """Parse a spectra table; ValueError with a specific reason when it is not one."""
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_TABLE_BYTES:
            raise ValueError(f"{path.name} is {size / 1e6:.0f} MB; a spectra table is at most "
                             f"{MAX_TABLE_BYTES // 2**20} MB")
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path.name} is not a text file") from exc
    except OSError as exc:
        raise ValueError(f"cannot read {path}: {exc.strerror or exc}") from exc
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if len(lines) < 2:
        raise ValueError(f"{path.name} has fewer than two rows of data")
    sample = "\n".join(lines[:20])
    delimiter = "\t" if "\t" in sample else (";" if sample.count(";") > sample.count(",") else ",")
    rows = list(csv.reader(io.StringIO("\n".join(lines)), delimiter=delimiter))
    decimal_comma = delimiter != ","

    def parse(cell: str) -> float | None:
        cell = cell.strip()
        if decimal_comma:
            cell = cell.replace(",", ".")
        try:
            return float(cell)
        except ValueError:
            return None

    header: list[str] | None = None
    if any(parse(c) is None for c in rows[0]):
        header = [c.strip() for c in rows[0]]
        rows = rows[1:]
    width = max(len(r) for r in rows)
    if width < 2:
        raise ValueError(f"{path.name}: need a wavelength column and at least one spectrum column")
    data = np.full((len(rows), width), np.nan)
    for i, row in enumerate(rows):
        for j, cell in enumerate(row):
            value = parse(cell)
            if value is None and cell.strip():
                raise ValueError(f"{path.name}, data row {i + 1}, column {j + 1}: {cell.strip()!r} is not a number")
            if value is not None:
                data[i, j] = value
    wl = data[:, 0]
    if np.any(~np.isfinite(wl)):
        raise ValueError(f"{path.name}: every row needs a wavelength in the first column")
    if wl.min() < 100 or wl.max() > 5000:
        raise ValueError(f"{path.name}: first column ({wl.min():g}–{wl.max():g}) is not wavelengths in nm")
    if wl.max() < 380 or wl.min() > 780:
        raise ValueError(f"{path.name}: wavelengths {wl.min():g}–{wl.max():g} nm miss 380–780 nm")
    values = data[:, 1:].T
    if np.any(~np.isfinite(values)):
        raise ValueError(f"{path.name}: missing or non-finite values")
    if np.any(values < 0):
        values = np.clip(values, 0.0, None)  # meters report small negative dark noise
    names = (header[1:width] if header else []) + [f"spd{k + 1}" for k in range(width - 1)]
    names = [n or f"spd{k + 1}" for k, n in enumerate(names[: width - 1])]
    return SpectraTable(names=names, wavelengths_nm=wl, values=values)


def safe_stem(name: str) -> str:
    """A file-name-safe version of a spectrum's column name (keeps letters of any script)."""
    stem = re.sub(r"[^\w.+-]+", "_", name, flags=re.UNICODE).strip("._")
    return stem[:120] or "spd"
