"""What a pose fit returns, and the binned self-consistency that judges it.

:class:`PoseFit` is the fitted capture (a :class:`~..scene.capture.Scene` the readout, the forward
matrix and the advice all use) with the numbers the confidence and the refusals read: the share
of the photo's energy the pose leaves unexplained (``residual``) and what a disc in the wrong place
leaves (``null_residual``); their ratio is the rainbow contrast.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..readout.readout import FEATURE_LAMBDA_NM, FEATURE_STEP_NM, N_FEATURES
from ..scene.capture import Preset, Scene
from ..scene.diffraction import PixelDiffraction, pixel_diffraction
from ..spectra.cameras import camera_colours, unit_colours

# λ₁ bins of the reported consistency: finer than the features, so a lamp line sharper than a
# feature bin does not make pixels of one bin disagree.
FIT_STEP_NM = 2.0
COLOUR_BAND_NM = (400.0, 750.0)  # λ₁ where only the first order shows (the second starts at 760 nm)
ZERO_ORDER_SIGMAS = 6.0  # the mirror glint's lobe, in lamp sizes, left out of the fit

__all__ = ["PoseFit", "consistency", "expected_colours", "colour_blur_nm", "COLOUR_BAND_NM", "glint_mask", "FIT_STEP_NM",
           "ZERO_ORDER_SIGMAS", "contrast"]


@dataclass(frozen=True)
class PoseFit:
    center_px: tuple[float, float]  # disc centre (row, col) in the fitted image
    ring_center_px: tuple[float, float]  # the zero-order (mirror) point, where rings are centred
    lobe_sigma: float
    focal_px: float
    distance_mm: float
    residual: float  # share of the photo's energy the geometry cannot explain (0 = perfect)
    evaluations: int
    null_residual: float = 1.0  # the same with λ₁ dealt out at random: what no rainbow explains
    known_scene: Scene | None = None  # the fitted (or, for synthetic photos, the true) capture
    timing_ms: tuple[tuple[str, float], ...] = ()  # the fit's stages
    strategy: str = ""  # the start the fit came from
    # The photo's thin lines (a small lamp), where it has them (:mod:`.lines`): the weighted share
    # on the fitted curve, their median distance from it (px), the orders they show in 400–700
    # nm, and whether they pinned the capture (then the self-consistency fitted only the lobe).
    line_share: float = 0.0
    line_offset_px: float = math.inf
    line_orders: tuple[int, ...] = ()
    lines_pinned: bool = False

    @classmethod
    def of_scene(cls, scene: Scene) -> "PoseFit":
        """The 'fit' of a photo whose capture is known exactly: training's and tests' ground truth."""
        centre = scene.project(scene.disc_center[None, :])[0]
        cam = scene.preset.camera
        rc = (float(centre[0]), float(centre[1]))
        return cls(center_px=rc, ring_center_px=rc, lobe_sigma=scene.preset.light.lobe_sigma, focal_px=cam.focal_px,
                   distance_mm=cam.distance_mm, residual=0.0, evaluations=0, known_scene=scene)

    @property
    def rainbow_contrast(self) -> float:
        """How much better the fitted disc explains the photo than a disc in the wrong place:
        near 1 for a CD rainbow, near 0 for a photo without one."""
        return contrast(self.residual, self.null_residual)

    def scene(self, preset: Preset, image_size: tuple[int, int]) -> Scene:
        """The fitted capture at ``image_size`` (the size the fit was made at)."""
        if self.known_scene is None:
            raise ValueError("this pose fit holds no capture")
        if tuple(self.known_scene.preset.camera.image_size_px) != tuple(image_size):
            raise ValueError("the capture was fitted at another image size")
        return self.known_scene

    def with_scene(self, scene: Scene) -> "PoseFit":
        """The same fit reporting another capture (an evaluation's injected pose error)."""
        centre = scene.project(scene.disc_center[None, :])[0]
        return replace(self, known_scene=scene, center_px=(float(centre[0]), float(centre[1])))


def contrast(residual: float, null_residual: float) -> float:
    return 0.0 if null_residual <= 0 else max(0.0, 1.0 - residual / null_residual)


def glint_mask(px: PixelDiffraction, scene: Scene) -> NDArray[np.bool_]:
    """Which pixels show the zero-order glint (where the disc mirrors the lamp into the lens).

    A lamp beside the lens or a tilted disc puts that glint on the disc, tens of times brighter
    than the rainbow and clipped: its energy would swamp the first-order fit, which does not
    model it (with the lamp 30 mm beside the lens it held 94 % of the photo's energy, and the
    fit's residual at the true pose was 0.94). It sits where u = v = 0, so it moves with the
    fitted pose; the region is a few pixels across, too small to hide a rainbow in. One pixel
    spans about 2/focal_px in (u, v), so the cut widens by two of those."""
    cut = ZERO_ORDER_SIGMAS * scene.preset.light.lobe_sigma + 4.0 / scene.preset.camera.focal_px
    return np.hypot(px.u, px.v) < cut


def consistency(rgb: NDArray[np.float64], scene: Scene, total: float | None = None,
                scramble: bool = False, step_nm: float = FEATURE_STEP_NM,
                pixels: NDArray[np.int64] | None = None, colour: NDArray[np.float64] | None = None) -> float:
    """Share of the photo's energy on the disc that I = A(λ₁)·amplitude cannot explain,
    with A fitted per λ₁ bin and channel by least squares.

    ``colour`` (bins × 3, unit rows; NaN rows free) is the camera's own colour at each bin's λ₁
    (:func:`expected_colours`): where given, A must be a multiple of it — a green pixel cannot be
    620 nm. ``scramble`` deals the pixels' (λ₁, visibility) pairs out at random (seeded): the same
    coverage and bin sizes, but no rainbow geometry — the baseline a real rainbow must beat.
    """
    px = pixel_diffraction(scene, pixels)
    flat = rgb.reshape(-1, 3)
    glint = glint_mask(px, scene)
    glint_energy = float(np.sum(flat[px.index[glint]] ** 2))
    px = px.select(~glint) if np.any(glint) else px
    if scramble:
        order = np.random.default_rng(0).permutation(px.index.size)
        px = replace(px, lambda1_nm=px.lambda1_nm[order], visibility=px.visibility[order],
                     gain=px.gain[order], on_tracks=px.on_tracks[order])
    lam0 = FEATURE_LAMBDA_NM[0] - FEATURE_STEP_NM / 2
    n_bins = int(round(N_FEATURES * FEATURE_STEP_NM / step_nm))
    b = np.floor((px.lambda1_nm - lam0) / step_nm).astype(np.int64)
    inside = px.on_tracks & (b >= 0) & (b < n_bins)
    vals = flat[px.index]
    energy = float(np.sum(vals ** 2)) if total is None else total - glint_energy
    if energy <= 0:
        return 1.0
    if not np.any(inside):  # no pixel where a first-order rainbow could be (e.g. a telephoto EXIF)
        return 1.0
    bi, vis, v = b[inside], px.amplitude[inside], vals[inside]
    vv = np.bincount(bi, weights=vis * vis, minlength=n_bins)
    vi = np.stack([np.bincount(bi, weights=vis * v[:, c], minlength=n_bins) for c in range(3)], axis=1)
    if colour is None:
        along = np.sum(vi * vi, axis=1)
    else:
        free = np.isnan(colour[:, 0])
        along = np.where(free, np.sum(vi * vi, axis=1), np.nansum(vi * colour, axis=1) ** 2)
    explained = float(np.sum(np.divide(along, vv, out=np.zeros_like(vv), where=vv > 1e-12)))
    return 1.0 - explained / energy


def expected_colours(sensitivities: NDArray[np.float64], step_nm: float, blur_nm: float) -> NDArray[np.float64]:
    """Unit camera colour per fit bin of width ``step_nm`` under a flat spectrum
    (:func:`..spectra.cameras.camera_colours`, blurred by the lobe and the pixel footprint
    ``blur_nm``); NaN outside COLOUR_BAND_NM."""
    lam0 = FEATURE_LAMBDA_NM[0] - FEATURE_STEP_NM / 2
    n_bins = int(round(N_FEATURES * FEATURE_STEP_NM / step_nm))
    centres = lam0 + (np.arange(n_bins) + 0.5) * step_nm
    out = unit_colours(camera_colours(centres, sensitivities, max(float(blur_nm), 1.0)))
    out[(centres < COLOUR_BAND_NM[0]) | (centres > COLOUR_BAND_NM[1])] = np.nan
    return out


def colour_blur_nm(preset: Preset, sigma: float, focal_px: float) -> float:
    """How far in λ₁ one bin's colour is smeared: the lamp's lobe (d·σ) and one pixel's span
    of λ₁ (about d·2/focal_px), as a Gaussian std."""
    pitch_nm = preset.disc.pitch_um * 1e3
    return math.hypot(pitch_nm * sigma, pitch_nm * 2.0 / focal_px / math.sqrt(12.0))
