"""A real camera's own JPEG rendering, learned from one of its raw files and the JPEG it wrote of
the same shot (evaluation only; issue 20's third validation).

The renderings of :mod:`.renderings` are written from what cameras do; this one is measured. A
raw file holds the sensor's values and (most do) the camera's own full-size JPEG of the same
shot, the one the camera would have written as its JPEG. Fitting the map between them gives the
camera maker's rendering — its tone curve per channel, and its colour "look" beyond colorimetry
(saturation, hue twists) — which is then applied to simulated CD captures of another camera:

    file-linear = decode(T_c(encode((L · S · diag(g) · native)_c)))

``S · diag(g)`` is the colorimetric part of the simulated camera (its daylight white balance and
camera→sRGB matrix, as :func:`.renderings.camera_to_srgb`), ``L`` (3×3) and ``T_c`` (monotone,
on sRGB-encoded values) are what the real camera adds, learned from its pair: there the same
model is fitted with the raw file's own colorimetric matrix (its ``rgb_xyz_matrix``) as ``S``
and the white balance that renders the scene's neutral as neutral. ``L`` keeps the real
camera's exposure mapping (how bright a raw value comes out), the curves its contrast and
highlight roll-off. Pixels at a code of 0 or 255, or clipped in the raw file, are left out of
the fit: they are bounds, not values. The photos themselves are never stored in the repository
(their licences are unknown): commands read them from a folder.
"""

from __future__ import annotations

import hashlib
import io
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon.core.numerics.least_squares import levenberg_marquardt
from cd_spectra_addon.core.photo.resample import box_downsample
from cd_spectra_addon.core.photo.srgb import srgb_decode, srgb_encode
from cd_spectra_addon.core.spectra import colour
from cd_spectra_addon.core.spectra.cameras import CameraProfile

from training.evaluation.renderings import camera_to_srgb, white_gains

__all__ = ["LearnedRendering", "fit_rendering", "load_pair", "learn_from_file"]

KNOTS = 17  # the tone curves' knots on encoded input 0…1
ROUNDS = 6  # alternations of matrix and curves
BLOCK = 8  # pixels averaged per side before fitting: misregistration and demosaicing fall out
SMOOTH = 1e-2  # the curves' second-difference penalty, relative to the data's weight per knot
ANCHOR_WEIGHT = 5.0  # (0, 0) and (1, 1) count as this many blocks
RIDGE = 1e-3  # pull of the matrix towards the colorimetric one, relative to the data's weight


@dataclass(frozen=True)
class LearnedRendering:
    """A camera's rendering learned from one raw + JPEG pair; callable like :data:`.renderings.RENDERINGS`."""

    name: str
    look: NDArray[np.float64]  # (3, 3): colorimetric linear sRGB → the camera's linear, before the curves
    curves: NDArray[np.float64]  # (3, KNOTS): encoded output at encoded inputs linspace(0, 1, KNOTS)
    rms_codes: float  # the fit's error on its own pair, 8-bit codes (blocks not clipped)
    blocks: int  # blocks fitted
    pair_gains: NDArray[np.float64] = field(default_factory=lambda: np.ones(3))  # the pair's white balance (green 1)
    # The raw file it was learned from, "NAME, sha256 PREFIX": two files of one camera model
    # learn different renderings (a D30 sample read 3.8 codes RMS, another 4.2), so a bench says which.
    source: str = ""

    def tone(self, display: NDArray[np.float64]) -> NDArray[np.float64]:
        """Linear values (…, 3) → the camera's file-linear output."""
        return srgb_decode(np.clip(_curved(display, self.curves), 0.0, 1.0))

    def __call__(self, native: NDArray[np.float64], camera: CameraProfile) -> NDArray[np.float64]:
        colorimetric = (native * white_gains(camera)) @ camera_to_srgb(camera).T
        return self.tone(colorimetric @ self.look.T)


def _curved(display: NDArray[np.float64], curves: NDArray[np.float64]) -> NDArray[np.float64]:
    """Linear values (…, 3), clipped to 0…1 and sRGB-encoded, through each channel's curve: codes 0…1."""
    x = srgb_encode(np.clip(display, 0.0, 1.0))
    knots = np.linspace(0.0, 1.0, KNOTS)
    return np.stack([np.interp(x[..., c], knots, curves[c]) for c in range(3)], axis=-1)


def _blocks(image: NDArray[np.float64], block: int) -> NDArray[np.float64]:
    """``block`` × ``block`` means, flattened to one row per block (…, channels)."""
    image = np.asarray(image, np.float64)
    return box_downsample(image if image.ndim == 3 else image[..., None], block).reshape(-1, 1 if image.ndim == 2
                                                                                           else image.shape[-1])


def _fit_curves(x: NDArray[np.float64], codes: NDArray[np.float64], ok: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Monotone curves (3, KNOTS): piecewise-linear least squares on the knots' hat functions,
    lightly smoothed (second differences), with (0, 0) and (1, 1) as weak anchors - raw black
    renders black, raw full scale white; the shot need not show either, and where it does not,
    the smoothing carries the curve there on a straight line - then made non-decreasing."""
    knots = np.linspace(0.0, 1.0, KNOTS)
    d2 = np.diff(np.eye(KNOTS), n=2, axis=0)
    curves = np.zeros((3, KNOTS))
    for c in range(3):
        xc = np.concatenate([np.clip(x[ok[:, c], c], 0.0, 1.0), [0.0, 1.0]])
        yc = np.concatenate([codes[ok[:, c], c], [0.0, 1.0]])
        w = np.concatenate([np.ones(xc.size - 2), [ANCHOR_WEIGHT, ANCHOR_WEIGHT]])
        pos = xc * (KNOTS - 1)
        i = np.minimum(pos.astype(int), KNOTS - 2)
        t = pos - i
        hat = np.zeros((xc.size, KNOTS))
        hat[np.arange(xc.size), i] = 1.0 - t
        hat[np.arange(xc.size), i + 1] += t
        gram = hat.T @ (hat * w[:, None]) + SMOOTH * w.sum() / KNOTS * d2.T @ d2
        v = np.linalg.solve(gram, hat.T @ (w * yc))
        curves[c] = np.maximum.accumulate(np.clip(v, 0.0, 1.0))
    return curves


def _invert(curves: NDArray[np.float64], codes: NDArray[np.float64]) -> NDArray[np.float64]:
    """Encoded inputs that the curves map to ``codes`` (per channel; flat stretches: their middle)."""
    knots = np.linspace(0.0, 1.0, KNOTS)
    out = np.empty_like(codes)
    for c in range(3):
        y = curves[c] + np.arange(KNOTS) * 1e-9  # strictly increasing for interp
        out[:, c] = np.interp(codes[:, c], y, knots)
    return out


def fit_rendering(raw_linear: NDArray[np.float64], jpeg_codes: NDArray[np.float64], colorimetric: NDArray[np.float64],
                  raw_clipped: NDArray[np.bool_] | None = None, name: str = "learned", block: int = BLOCK
                  ) -> LearnedRendering:
    """Learn ``L`` and ``T_c`` from a camera-native linear image (H, W, 3; full scale 1) and the
    camera's JPEG of the same shot as codes 0…1 (same H, W), given the raw camera's colorimetric
    matrix ``colorimetric`` (3, 3: camera RGB → linear sRGB, white → equal).

    The white balance is the one under which the fitted rendering is neutral: ``M = L · S ·
    diag(g)`` is fitted as a whole, then split with ``g`` ∝ 1 / (M⁻¹ · 1)."""
    cam = _blocks(raw_linear, block)
    codes = _blocks(jpeg_codes, block)
    clipped = np.zeros(cam.shape[0], bool) if raw_clipped is None else _blocks(raw_clipped, block)[:, 0] > 0
    ok = (codes > 2.5 / 255) & (codes < 252.5 / 255) & ~clipped[:, None] & np.all(cam > 0, axis=1)[:, None]
    rows = np.all(ok, axis=1)
    if rows.sum() < 100:
        raise ValueError(f"{name}: only {int(rows.sum())} unclipped blocks to learn a rendering from")
    # Start: gray-world white balance through the colorimetric matrix, the sRGB curve.
    g0 = cam[rows].mean(axis=0)
    m = colorimetric @ np.diag(g0[1] / g0)
    target0 = srgb_decode(codes)
    k = float(np.median(target0[rows].sum(axis=1) / np.maximum((cam[rows] @ m.T).sum(axis=1), 1e-9)))
    m = m * k
    curves = np.tile(np.linspace(0.0, 1.0, KNOTS), (3, 1))
    for _ in range(ROUNDS):
        target = srgb_decode(_invert(curves, codes))
        a = cam[rows]
        gram = a.T @ a
        lam = RIDGE * np.trace(gram) / 3
        m = np.linalg.solve(gram + lam * np.eye(3), a.T @ target[rows] + lam * m.T).T
        x = srgb_encode(np.clip(cam @ m.T, 0.0, 1.0))
        curves = _fit_curves(x, codes, ok)
    m, curves = _polish(cam, codes, ok, m, curves)
    rms = float(np.sqrt(np.mean(((_render_blocks(cam, m, curves) - codes)[rows] * 255) ** 2)))
    neutral = np.linalg.solve(m, np.ones(3))
    g = neutral[1] / neutral  # the white balance under which M renders neutral as neutral
    look = m @ np.linalg.inv(colorimetric @ np.diag(g))
    return LearnedRendering(name, look, curves, rms, int(rows.sum()), g)


def _render_blocks(cam: NDArray[np.float64], m: NDArray[np.float64], curves: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
    return _curved(cam @ m.T, curves)


def _polish(cam: NDArray[np.float64], codes: NDArray[np.float64], ok: NDArray[np.bool_], m: NDArray[np.float64],
            curves: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Matrix and curves refined together (Levenberg-Marquardt from the alternation's answer):
    alternating, each half chases the other along the trade between exposure and curve."""
    d2 = np.diff(np.eye(KNOTS), n=2, axis=0)
    smooth = np.sqrt(SMOOTH * ok.sum(axis=0) / KNOTS)
    anchor = np.sqrt(ANCHOR_WEIGHT)

    def residuals(p: NDArray[np.float64]) -> NDArray[np.float64]:
        mm, cv = p[:9].reshape(3, 3), p[9:].reshape(3, KNOTS)
        data = (_render_blocks(cam, mm, cv) - codes)[ok]
        reg = [np.concatenate([smooth[c] * (d2 @ cv[c]), anchor * np.array([cv[c, 0], cv[c, -1] - 1.0])])
               for c in range(3)]
        return np.concatenate([data, *reg])

    p0 = np.concatenate([m.ravel(), curves.ravel()])
    steps = np.concatenate([np.full(9, 1e-4), np.full(3 * KNOTS, 1e-4)])
    p, _, _ = levenberg_marquardt(residuals, p0, steps, max_iter=40, tol=1e-7)
    return p[:9].reshape(3, 3), np.maximum.accumulate(np.clip(p[9:].reshape(3, KNOTS), 0.0, 1.0), axis=1)


def load_pair(raw_path: Path, jpeg_path: Path | None = None
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_], str]:
    """(camera-native linear image, the camera's JPEG as codes 0…1 at its size, colorimetric matrix,
    raw clipping, camera name) of a raw file and its JPEG (``jpeg_path``, else the full-size
    preview the raw file embeds), registered on the raw file's default crop."""
    import rawpy
    from PIL import Image

    with rawpy.imread(str(raw_path)) as raw:
        native = raw.postprocess(output_color=rawpy.ColorSpace.raw, gamma=(1, 1), no_auto_bright=True,
                                 user_wb=[1.0, 1.0, 1.0, 1.0], output_bps=16, user_flip=0,
                                 highlight_mode=rawpy.HighlightMode.Clip).astype(np.float64) / 65535.0
        cam_from_xyz = np.asarray(raw.rgb_xyz_matrix[:3], np.float64)
        sizes = raw.sizes
        if jpeg_path is None:
            thumb = raw.extract_thumb()
            if thumb.format != rawpy.ThumbFormat.JPEG:
                raise ValueError(f"{raw_path.name}: no JPEG of the shot inside the raw file")
            data = thumb.data
        else:
            data = Path(jpeg_path).read_bytes()
    jpeg = Image.open(io.BytesIO(data))
    exif = jpeg.getexif()
    name = " ".join(str(v).strip() for v in (exif.get(271), exif.get(272)) if v) or raw_path.stem
    codes = np.asarray(jpeg.convert("RGB"), np.float64) / 255.0
    if not np.any(cam_from_xyz):
        raise ValueError(f"{raw_path.name}: the raw file has no colour matrix")
    # The JPEG shows the raw file's default crop (where it has one), scaled.
    top = max(0, sizes.crop_top_margin - sizes.top_margin) if sizes.crop_height else 0
    left = max(0, sizes.crop_left_margin - sizes.left_margin) if sizes.crop_width else 0
    height = sizes.crop_height or native.shape[0]
    width = sizes.crop_width or native.shape[1]
    native = native[top:top + height, left:left + width]
    native = _resize(native, codes.shape[:2])
    clipped = np.max(native, axis=-1) >= 0.98
    srgb_from_cam = colour.xyz_to_working_rgb(np.linalg.inv(cam_from_xyz).T, colour.LINEAR_REC709).T
    colorimetric = srgb_from_cam / (srgb_from_cam @ np.ones(3))[:, None]
    return native, codes, colorimetric, clipped, name


def _resize(image: NDArray[np.float64], shape: tuple[int, int]) -> NDArray[np.float64]:
    """Area-average ``image`` to ``shape`` (linear light)."""
    h, w = shape
    ys = np.linspace(0, image.shape[0], h + 1).astype(int)
    xs = np.linspace(0, image.shape[1], w + 1).astype(int)
    c = np.cumsum(np.cumsum(np.pad(image, ((1, 0), (1, 0), (0, 0))), axis=0), axis=1)
    total = c[ys[1:]][:, xs[1:]] - c[ys[:-1]][:, xs[1:]] - c[ys[1:]][:, xs[:-1]] + c[ys[:-1]][:, xs[:-1]]
    area = np.diff(ys)[:, None, None] * np.diff(xs)[None, :, None]
    return total / np.maximum(area, 1)


def learn_from_file(raw_path: Path, jpeg_path: Path | None = None) -> LearnedRendering:
    native, codes, colorimetric, clipped, name = load_pair(raw_path, jpeg_path)
    digest = hashlib.sha256(Path(raw_path).read_bytes()).hexdigest()[:12]
    return replace(fit_rendering(native, codes, colorimetric, clipped, name=name),
                   source=f"{Path(raw_path).name}, sha256 {digest}")
