"""Spectra files: reading what meters and databases export, writing what renderers read.

Reading: a spectra table has the wavelength (nm) in its first column and one spectrum per
further column, with or without a header row, comma/semicolon/tab separated
(:func:`read_spectra_csv`); our own JSON; pbrt-v4 ``.spd``; IES TM-27-14 XML (only where
colour-science is importable, i.e. not inside Blender). :func:`read_reference_spd` picks the
reader from the file's content and extension. Values are resampled onto the product grid with
:func:`~cd_spectra_addon.core.spectral_grid.resample_to_grid`.

Writing: CSV, JSON (values + metadata), pbrt-v4 ``.spd``, TM-27-14 XML and Mitsuba's
``λ:value`` list. Every writer is
atomic (:mod:`..atomic_files`): it writes a temporary file in the target folder and renames it over the target
(``os.replace``), so a crash, a full disk or an exception mid-write leaves the previous file
as it was and never a half-written one. Failures raise :class:`CDSpectraError` with a message
for the user.
"""

from __future__ import annotations

import codecs
import contextlib
import csv
import io
import json
import locale
import math
import os
import re
import unicodedata
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..atomic_files import atomic_write as _atomic_write, write_bytes as _write_bytes
from ..errors import CDSpectraError
from .grid import N_BANDS, WAVELENGTHS_NM, resample_to_grid

MAX_TABLE_BYTES = 64 * 1024 * 1024
JSON_FORMAT = "cd-spectra-spd"
JSON_VERSION = 1

__all__ = [
    "EXPORT_FORMATS",
    "JSON_FORMAT",
    "JSON_VERSION",
    "ExportFormat",
    "SpectraTable",
    "export_format",
    "read_reference_spd",
    "read_spd_json",
    "read_spd_mitsuba",
    "read_spd_pbrt",
    "read_spd_tm2714",
    "read_spectra_csv",
    "safe_stem",
    "write_spd_csv",
    "write_spd_json",
    "write_spd_mitsuba",
    "write_spd_pbrt",
    "write_spd_tm2714",
]


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
    text = _read_text(path, "a spectra table")  # CDSpectraError is a ValueError
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


# --- shared helpers -----------------------------------------------------------------------------


def _grid_spd(spd: ArrayLike) -> NDArray[np.float64]:
    """One SPD on the product grid, checked before anything is written."""
    arr = np.asarray(spd, dtype=np.float64)
    if arr.shape != (N_BANDS,):
        raise CDSpectraError(f"an SPD to export has {N_BANDS} values (380–780 nm, 5 nm); "
                             f"got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise CDSpectraError("the SPD contains NaN or infinite values; nothing was written")
    if np.any(arr < 0):
        raise CDSpectraError("the SPD has negative values; nothing was written")
    if not np.any(arr > 0):
        raise CDSpectraError("the SPD is zero everywhere; nothing was written")
    return arr


def _clean_name(name: str) -> str:
    """One printable line: control characters (newlines, tabs) would break CSV and pbrt files."""
    text = "".join(" " if unicodedata.category(c).startswith("C") else c for c in str(name))
    return " ".join(text.split()) or "spd"


def _number(value: float) -> str:
    """Shortest text that reads back as the same float64 (and has no locale decimal comma)."""
    return repr(float(value))


def _wavelength(value: float) -> str:
    return f"{float(value):g}"


def _read_text(path: Path, what: str) -> str:
    try:
        size = path.stat().st_size
        if size > MAX_TABLE_BYTES:
            raise CDSpectraError(f"{path.name} is {size / 1e6:.0f} MB; {what} is at most "
                                 f"{MAX_TABLE_BYTES // 2**20} MB")
        return path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise CDSpectraError(f"{path.name} is not a UTF-8 text file") from exc
    except OSError as exc:
        raise CDSpectraError(f"cannot read {path}: {exc.strerror or exc}") from exc


def _checked_reference(path: Path, wavelengths: ArrayLike, values: ArrayLike) -> NDArray[np.float64]:
    """Values → grid; clip meters' small negative dark noise; refuse what can't be a light."""
    wl = np.asarray(wavelengths, dtype=np.float64)
    val = np.asarray(values, dtype=np.float64)
    if wl.ndim != 1 or wl.size < 2 or val.shape != wl.shape:
        raise CDSpectraError(f"{path.name}: needs matching lists of at least two wavelengths and values")
    if not (np.all(np.isfinite(wl)) and np.all(np.isfinite(val))):
        raise CDSpectraError(f"{path.name}: missing or non-finite values")
    if wl.max() < 380 or wl.min() > 780:
        raise CDSpectraError(f"{path.name}: wavelengths {wl.min():g}–{wl.max():g} nm miss 380–780 nm")
    try:
        grid = resample_to_grid(wl, np.clip(val, 0.0, None))
    except ValueError as exc:
        raise CDSpectraError(f"{path.name}: {exc}") from exc
    if not np.any(grid > 0):
        raise CDSpectraError(f"{path.name}: the spectrum is zero everywhere in 380–780 nm")
    return grid


# --- CSV ------------------------------------------------------------------------------------------


def write_spd_csv(path: str | Path, spd: ArrayLike, name: str = "spd") -> Path:
    """``wavelength_nm,<name>`` then one row per grid sample; reads back with :func:`read_spectra_csv`."""
    values = _grid_spd(spd)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(["wavelength_nm", _clean_name(name)])
    for wl, value in zip(WAVELENGTHS_NM, values, strict=True):
        writer.writerow([_wavelength(wl), _number(value)])
    return _atomic_write(path, _write_bytes(buffer.getvalue().encode("utf-8")))


# --- JSON -----------------------------------------------------------------------------------------


def _json_ready(value: Any, key: str) -> Any:
    """Metadata as plain JSON: numpy → Python, Path → str, NaN/inf → null (JSON has none)."""
    if isinstance(value, Mapping):
        return {str(k): _json_ready(v, f"{key}.{k}") for k, v in value.items()}
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return [_json_ready(v, f"{key}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, (bool, int, str)):
        return value
    if isinstance(value, Path):
        return str(value)
    raise CDSpectraError(f"metadata {key!r}: {type(value).__name__} cannot be stored in JSON")


def write_spd_json(path: str | Path, spd: ArrayLike, name: str = "spd",
                   metadata: Mapping[str, Any] | None = None) -> Path:
    """Our lossless format: wavelengths, values and a metadata dict (photo, model, CCT, xy, ...)."""
    values = _grid_spd(spd)
    payload = {
        "format": JSON_FORMAT,
        "version": JSON_VERSION,
        "name": _clean_name(name),
        "wavelength_nm": [float(w) for w in WAVELENGTHS_NM],
        "values": [float(v) for v in values],
        "metadata": _json_ready(dict(metadata or {}), "metadata"),
    }
    text = json.dumps(payload, ensure_ascii=False, allow_nan=False, indent=1)
    return _atomic_write(path, _write_bytes((text + "\n").encode("utf-8")))


def read_spd_json(path: str | Path) -> tuple[str, NDArray[np.float64], dict[str, Any]]:
    """(name, SPD on the grid, metadata) from a file written by :func:`write_spd_json`."""
    path = Path(path)
    try:
        data = json.loads(_read_text(path, "an SPD file"))
    except json.JSONDecodeError as exc:
        raise CDSpectraError(f"{path.name} is not valid JSON (line {exc.lineno}: {exc.msg})") from exc
    if not isinstance(data, dict) or data.get("format") != JSON_FORMAT:
        raise CDSpectraError(f"{path.name} is JSON but not a CD Spectra SPD file (no \"format\": "
                             f"\"{JSON_FORMAT}\")")
    version = data.get("version")
    if not isinstance(version, int) or version > JSON_VERSION:
        raise CDSpectraError(f"{path.name} is version {version} of the SPD format; this add-on reads "
                             f"up to {JSON_VERSION} (update the add-on)")
    try:
        wl = np.asarray(data["wavelength_nm"], dtype=np.float64)
        values = np.asarray(data["values"], dtype=np.float64)
    except (KeyError, TypeError, ValueError) as exc:
        raise CDSpectraError(f"{path.name}: \"wavelength_nm\" and \"values\" must be lists of "
                             "numbers") from exc
    metadata = data.get("metadata") or {}
    if not isinstance(metadata, dict):
        raise CDSpectraError(f"{path.name}: \"metadata\" must be an object")
    name = str(data.get("name") or path.stem)
    return name, _checked_reference(path, wl, values), metadata


# --- pbrt-v4 --------------------------------------------------------------------------------------


def write_spd_pbrt(path: str | Path, spd: ArrayLike, name: str = "spd") -> Path:
    """A pbrt-v4 spectrum file: ``"spectrum L" "lamp.spd"`` in a light or area light.

    pbrt-v4 (``PiecewiseLinearSpectrum::Read`` / ``ReadFloatFile``) reads whitespace-separated
    (wavelength nm, value) pairs with strictly increasing wavelengths and ``#`` comments to the
    end of a line, and interpolates linearly, zero outside the range: the same curve as ours.
    Two of its quirks shape this writer: a number not followed by whitespace at the end of the
    file is dropped (so the file ends with a newline), and a ``#`` only starts a comment
    outside a number (so comments get their own lines, ASCII only). pbrt-v4 divides a light's
    spectrum by its photometric value, so brightness is set with "scale" / "power" there.
    """
    values = _grid_spd(spd)
    label = json.dumps(_clean_name(name), ensure_ascii=True)  # ASCII, reversible
    lines = [
        f"# CD Spectra SPD {label}",
        "# wavelength_nm value; relative spectral power, linear between samples",
        '# pbrt-v4: "spectrum L" "<this file>"; pbrt normalises light spectra photometrically',
    ]
    lines += [f"{_wavelength(wl)} {_number(v)}" for wl, v in zip(WAVELENGTHS_NM, values, strict=True)]
    return _atomic_write(path, _write_bytes(("\n".join(lines) + "\n").encode("ascii")))


def read_spd_pbrt(path: str | Path) -> tuple[str, NDArray[np.float64]]:
    """(name, SPD on the grid) from a pbrt-v4 spectrum file (ours or anyone's)."""
    path = Path(path)
    text = _read_text(path, "a spectrum file")
    name = path.stem
    numbers: list[float] = []
    for number, raw in enumerate(text.splitlines(), start=1):
        body, _, comment = raw.partition("#")
        match = re.match(r'\s*CD Spectra SPD (".*")\s*$', comment)
        if match and number <= 3:
            with contextlib.suppress(json.JSONDecodeError, TypeError):
                name = str(json.loads(match.group(1)))
        for token in body.split():
            try:
                value = float(token)
            except ValueError:
                raise CDSpectraError(f"{path.name}, line {number}: {token!r} is not a number") from None
            numbers.append(value)
    if len(numbers) % 2:
        raise CDSpectraError(f"{path.name}: an odd count of numbers; a spectrum file holds "
                             "wavelength/value pairs")
    pairs = np.asarray(numbers, dtype=np.float64).reshape(-1, 2)
    if pairs.shape[0] >= 2 and np.any(np.diff(pairs[:, 0]) <= 0):
        raise CDSpectraError(f"{path.name}: wavelengths must increase (pbrt rejects the file too)")
    return name, _checked_reference(path, pairs[:, 0], pairs[:, 1])


# --- Mitsuba 3 / "λ:value" --------------------------------------------------------------------------


def write_spd_mitsuba(path: str | Path, spd: ArrayLike, name: str = "spd") -> Path:
    """One line of ``wavelength:value`` pairs, comma separated: the string Mitsuba 3 takes in
    ``<spectrum name="radiance" value="380:0.1, 385:0.12, ..."/>`` (linear interpolation between
    samples, as ours), and the pair list other spectral renderers' scene formats paste in.

    Nothing else is in the file (no comment syntax is shared by the formats it is pasted into),
    so ``name`` is not written; it is kept for the writers' common signature.
    """
    values = _grid_spd(spd)
    pairs = ", ".join(f"{_wavelength(wl)}:{_number(v)}" for wl, v in zip(WAVELENGTHS_NM, values, strict=True))
    return _atomic_write(path, _write_bytes((pairs + "\n").encode("ascii")))


def read_spd_mitsuba(path: str | Path) -> tuple[str, NDArray[np.float64]]:
    """(name = file stem, SPD on the grid) from a ``λ:value, ...`` file (:func:`write_spd_mitsuba`)."""
    path = Path(path)
    text = _read_text(path, "a spectrum file").strip()
    try:
        pairs = np.array([[float(x) for x in item.split(":")] for item in text.split(",")], dtype=np.float64)
    except ValueError as exc:
        raise CDSpectraError(f"{path.name}: expected comma-separated wavelength:value pairs") from exc
    if pairs.ndim != 2 or pairs.shape[1] != 2:
        raise CDSpectraError(f"{path.name}: expected comma-separated wavelength:value pairs")
    return path.stem, _checked_reference(path, pairs[:, 0], pairs[:, 1])


# --- IES TM-27-14 (needs colour-science) ----------------------------------------------------------

_NOT_A_LIGHT = {"reflectance", "transmittance", "absorptance", "R-Factor", "T-Factor"}


def _tm2714() -> tuple[Any, Any]:
    try:
        from colour.io import SpectralDistribution_IESTM2714
        from colour.io.tm2714 import Header_IESTM2714
    except ImportError as exc:
        raise CDSpectraError("IES TM-27-14 XML needs the colour-science package, which Blender does "
                             "not bundle; use CSV or JSON here") from exc
    return SpectralDistribution_IESTM2714, Header_IESTM2714


def write_spd_tm2714(path: str | Path, spd: ArrayLike, name: str = "spd",
                     metadata: Mapping[str, Any] | None = None) -> Path:
    """IES TM-27-14 XML through colour-science (offline or CLI; CDSpectraError without it).

    Spectral quantity "relative"; the metadata go into ``<Comments>`` as JSON. colour writes
    values with 12 significant digits (plenty for a meter format; JSON is the lossless one),
    and with the locale's encoding but no encoding declaration, so the file is re-encoded to
    UTF-8 (what an XML reader assumes) before it replaces the target.
    """
    values = _grid_spd(spd)
    sd_class, header_class = _tm2714()
    label = _clean_name(name)
    comments = json.dumps(_json_ready(dict(metadata or {}), "metadata"), ensure_ascii=False, allow_nan=False)
    header = header_class(
        manufacturer="", catalog_number="", description=label, document_creator="CD Spectra",
        unique_identifier="", measurement_equipment="CD Spectra: photo of a CD diffraction grating",
        laboratory="", report_number="", report_date="",
        document_creation_date=datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        comments=comments,
    )

    def write(temp: Path) -> None:
        sd = sd_class(header=header, spectral_quantity="relative",
                      data=dict(zip(WAVELENGTHS_NM.tolist(), values.tolist(), strict=True)), name=label)
        sd.path = str(temp)  # after construction: given a path, the constructor reads it
        encoding = locale.getpreferredencoding(False)
        try:
            sd.write()
        except UnicodeEncodeError as exc:
            raise CDSpectraError(f"this system's text encoding ({encoding}) cannot hold the name or "
                                 "metadata; use JSON, or Latin letters in the name") from exc
        if codecs.lookup(encoding).name != "utf-8":
            text = temp.read_bytes().decode(encoding)
            temp.write_bytes(text.encode("utf-8"))
        with open(temp, "rb+") as handle:
            os.fsync(handle.fileno())

    return _atomic_write(path, write)


def read_spd_tm2714(path: str | Path) -> tuple[str, NDArray[np.float64]]:
    """(name, SPD on the grid) from IES TM-27-14 XML (a light's spectrum, not a reflectance)."""
    path = Path(path)
    sd_class, _ = _tm2714()
    _read_text(path, "a TM-27-14 file")  # size, existence and encoding, with our messages
    try:
        sd = sd_class(str(path)).read()
    except Exception as exc:  # ElementTree.ParseError, KeyError, ValueError, ...: all mean "not valid"
        raise CDSpectraError(f"{path.name} is not a readable IES TM-27-14 file ({exc})") from exc
    if sd.spectral_quantity in _NOT_A_LIGHT:
        raise CDSpectraError(f"{path.name} holds a {sd.spectral_quantity} spectrum, not a light's")
    description = sd.header.description
    name = description if description and description != "None" else path.stem
    return name, _checked_reference(path, sd.wavelengths, sd.values)


# --- one entry point for a reference SPD -------------------------------------------------------------


def read_reference_spd(path: str | Path, column: str | None = None) -> tuple[str, NDArray[np.float64]]:
    """(name, SPD on the grid) of a reference (a meter's measurement) from any supported file.

    The format comes from the content where it is plain (``{`` JSON, ``<`` XML), else from the
    extension (``.json``, ``.xml`` / ``.spdx``, ``.spd`` pbrt); anything else is a CSV/TSV
    table, or failing that whitespace-separated wavelength/value pairs (many meters' ``.txt``).
    A table with several spectra needs ``column`` (its header name).
    """
    path = Path(path)
    if not path.is_file():
        raise CDSpectraError(f"{path} does not exist or is not a file")
    try:
        with open(path, "rb") as handle:
            head = handle.read(512).lstrip(b"\xef\xbb\xbf \t\r\n")
    except OSError as exc:
        raise CDSpectraError(f"cannot read {path}: {exc.strerror or exc}") from exc
    suffix = path.suffix.lower()
    if head.startswith(b"{") or (suffix == ".json" and not head.startswith(b"<")):
        name, spd, _ = read_spd_json(path)
        return name, spd
    if head.startswith(b"<") or suffix in (".xml", ".spdx"):
        return read_spd_tm2714(path)
    if suffix == ".spd":
        return read_spd_pbrt(path)
    if re.match(rb"\s*\d+(\.\d*)?\s*:", head):  # "380:0.1, 385:..." (Mitsuba-style pairs)
        return read_spd_mitsuba(path)
    try:
        table = read_spectra_csv(path)
    except ValueError as exc:
        if suffix not in (".csv", ".tsv"):
            with contextlib.suppress(ValueError):
                return read_spd_pbrt(path)
        raise CDSpectraError(str(exc)) from exc
    if column is None:
        if len(table.names) > 1:
            raise CDSpectraError(f"{path.name} has {len(table.names)} spectra ({', '.join(table.names)}); "
                                 "choose one")
        index = 0
    elif column in table.names:
        index = table.names.index(column)
    else:
        raise CDSpectraError(f"{path.name} has no spectrum {column!r}; it has {', '.join(table.names)}")
    name = path.stem if table.names == ["spd1"] else table.names[index]  # no header: the file's name
    return name, _checked_reference(path, table.wavelengths_nm, table.values[index])


# --- export registry ------------------------------------------------------------------------


@dataclass(frozen=True)
class ExportFormat:
    """A file format an SPD can be exported to: what menus show and how to write it."""

    identifier: str
    label: str
    extension: str
    writer: Callable[..., Path]
    takes_metadata: bool  # the writer stores the estimate's colour metrics and provenance too
    description: str
    needs_module: str | None = None  # a package the writer imports, absent inside Blender

    def available(self) -> bool:
        """Whether this Python can write the format (TM-27-14 needs colour-science)."""
        if self.needs_module is None:
            return True
        import importlib.util

        return importlib.util.find_spec(self.needs_module) is not None

    def write(self, path: str | Path, spd: ArrayLike, metadata: Mapping[str, Any]) -> Path:
        """Write one SPD at ``path`` with this format's extension (replacing any other), named
        ``metadata["name"]`` or after the file; atomic like every writer here."""
        target = Path(path)
        if target.suffix.lower() != self.extension:
            target = target.with_suffix(self.extension)
        name = str(metadata.get("name") or target.stem)
        values = np.asarray(spd, dtype=np.float64)
        if self.takes_metadata:
            return Path(self.writer(target, values, name=name, metadata=dict(metadata)))
        return Path(self.writer(target, values, name=name))


EXPORT_FORMATS: dict[str, ExportFormat] = {f.identifier: f for f in (
    ExportFormat("CSV", "CSV", ".csv", write_spd_csv, False,
                 "Wavelength and relative power, one row per 5 nm"),
    ExportFormat("JSON", "JSON", ".json", write_spd_json, True,
                 "The SPD with its colour metrics and provenance"),
    ExportFormat("PBRT", "pbrt-v4", ".spd", write_spd_pbrt, False,
                 "pbrt-v4 spectrum file (wavelength value pairs)"),
    ExportFormat("TM2714", "IES TM-27-14", ".xml", write_spd_tm2714, True,
                 "IES TM-27-14 spectral data XML", needs_module="colour"),
    ExportFormat("MITSUBA", "Mitsuba (λ:value)", ".txt", write_spd_mitsuba, False,
                 "wavelength:value pairs for Mitsuba 3's <spectrum value=...> and similar renderers"),
)}
"""Every export format by identifier, in menu order."""


def export_format(identifier: str) -> ExportFormat:
    """The registered format ``identifier``; CDSpectraError naming the choices otherwise."""
    fmt = EXPORT_FORMATS.get(identifier)
    if fmt is None:
        raise CDSpectraError(f"unknown export format {identifier!r}; "
                             f"choose one of {', '.join(EXPORT_FORMATS)}")
    return fmt
