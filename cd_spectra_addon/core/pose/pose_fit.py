"""Capture geometry of a photo: where the disc is and where camera and lamp stood.

Three steps, cheapest first:
1. the centre of the ring pattern, from the photo's 180° symmetry (FFT autoconvolution, refined
   to sub-pixel) — a good start for the disc centre;
2. the camera's focal length in pixels (EXIF, else the preset's field of view) — for a coaxial
   lamp this alone fixes λ₁ at every pixel, whatever the distance;
3. a fit of the pose (disc centre, lamp offset beside the lens, disc tilt, lamp size σ) that
   makes the photo most self-consistent: pixels that share λ₁ must share colour once divided
   by the lobe's visibility. A wrong centre mixes rings of different colour in one λ₁ bin; a
   wrong lamp position predicts light where the photo is dark. No spectrum is needed for this.
   The zero-order glint (the lamp's mirror image, clipped) is left out of that comparison, and
   with the camera's sensitivities each λ₁ bin must have the camera's colour at λ₁, which
   pins the wavelength axis along a single streak (bench/pose_errors.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..scene.capture import Camera, Light, Pose, Preset, Scene
from ..scene.diffraction import PixelDiffraction, pixel_diffraction
from ..spectra.grid import WAVELENGTHS_NM
from ..readout.readout import FEATURE_LAMBDA_NM, FEATURE_STEP_NM, N_FEATURES

FIT_SIDE = 160  # the pose is fitted on an image of about this size
# λ₁ bins of the fit: finer than the features, so a lamp line sharper than a feature bin does not
# make pixels of one bin disagree (and pull the fit towards putting lines at bin centres).
FIT_STEP_NM = 2.0
FINE_PIXELS = 12_000  # pixels the full-resolution refinement looks at
RETRY_CONTRAST = 0.5  # below this rainbow contrast the fit is tried again from a grid of centres
RETRY_GRID = 7  # centres per image axis for that second start
RETRY_MAX_RESIDUAL = 0.15  # ...whose fit is kept only if it explains a CD's share of the photo
__all__ = ["PoseFit", "symmetry_centre", "scene_for", "consistency", "fit_pose", "ZERO_ORDER_SIGMAS", "box_downsample"]


@dataclass(frozen=True)
class PoseFit:
    center_px: tuple[float, float]  # disc centre (row, col) in the image given to fit_pose
    ring_center_px: tuple[float, float]  # where the rings are centred (lamp/camera "midpoint foot")
    lobe_sigma: float
    focal_px: float
    distance_mm: float
    residual: float  # share of the photo's energy the geometry cannot explain (0 = perfect)
    symmetry_center_px: tuple[float, float]
    evaluations: int
    null_residual: float = 1.0  # the same with λ₁ dealt out at random: what no rainbow explains
    known_scene: Scene | None = None  # the exact capture, where it is known (synthetic photos)

    @classmethod
    def of_scene(cls, scene: Scene) -> "PoseFit":
        """The 'fit' of a photo whose capture is known exactly: training's and tests' ground truth."""
        centre = scene.project(scene.disc_center[None, :])[0]
        cam = scene.preset.camera
        rc = (float(centre[0]), float(centre[1]))
        return cls(center_px=rc, ring_center_px=rc, lobe_sigma=scene.preset.light.lobe_sigma, focal_px=cam.focal_px,
                   distance_mm=cam.distance_mm, residual=0.0, symmetry_center_px=rc, evaluations=0,
                   known_scene=scene)

    @property
    def rainbow_contrast(self) -> float:
        """How much better the fitted disc explains the photo than a disc in the wrong place:
        near 1 for a CD rainbow, near 0 for a photo without one."""
        return _contrast(self.residual, self.null_residual)

    def scene(self, preset: Preset, image_size: tuple[int, int]) -> Scene:
        if self.known_scene is not None:
            if tuple(self.known_scene.preset.camera.image_size_px) != tuple(image_size):
                raise ValueError("the known capture was rendered at another image size")
            return self.known_scene
        return scene_for(preset, image_size, self.focal_px, self.center_px, self.ring_center_px,
                         self.lobe_sigma, self.distance_mm)


def box_downsample(image: NDArray[np.floating], factor: int) -> NDArray[np.float64]:
    """Mean over factor × factor blocks (trailing rows/columns dropped)."""
    if factor <= 1:
        return np.asarray(image, dtype=np.float64)
    h, w = image.shape[0] // factor * factor, image.shape[1] // factor * factor
    a = np.asarray(image[:h, :w], dtype=np.float64)
    return a.reshape(h // factor, factor, w // factor, factor, *a.shape[2:]).mean(axis=(1, 3))


def symmetry_centre(lum: NDArray[np.floating]) -> tuple[float, float]:
    """Centre of 180° symmetry (row, col) of a non-negative image.

    The autoconvolution (I * I)(s) peaks at s = 2c when I is point-symmetric about c.
    """
    img = np.asarray(lum, dtype=np.float64)
    img = img - np.median(img)
    img = np.clip(img, 0, None)
    h, w = img.shape
    spec = np.fft.rfft2(img, s=(2 * h, 2 * w))
    conv = np.fft.irfft2(spec * spec, s=(2 * h, 2 * w))
    peak = np.unravel_index(int(np.argmax(conv)), conv.shape)
    r, c = (float(p) + _parabola(conv, peak, axis) for axis, p in enumerate(peak))
    return r / 2.0, c / 2.0


def _parabola(a: NDArray[np.float64], peak: tuple[int, ...], axis: int) -> float:
    idx = list(peak)
    if not 0 < idx[axis] < a.shape[axis] - 1:
        return 0.0
    idx[axis] -= 1
    left = a[tuple(idx)]
    idx[axis] += 2
    right = a[tuple(idx)]
    mid = a[peak]
    denom = left - 2 * mid + right
    return 0.0 if denom >= 0 else 0.5 * (left - right) / denom


def scene_for(
    preset: Preset,
    image_size: tuple[int, int],
    focal_px: float,
    center_px: tuple[float, float],
    ring_center_px: tuple[float, float] | None = None,
    lobe_sigma: float | None = None,
    distance_mm: float | None = None,
) -> Scene:
    """The Scene seen in a photo of ``image_size`` (width, height) with the disc centre at
    ``center_px`` and the rings centred at ``ring_center_px`` (row, col; default: the disc centre).

    The camera looks straight down (its foot is the image centre). In the small-angle picture
    the rings are centred on the point m of the disc plane where the lamp's and the camera's
    feet balance, m = (D_L·c + D·l)/(D + D_L); so the lamp's foot follows from m and c. A disc
    tilt moves m the same way to first order and is absorbed into it.
    """
    width, height = image_size
    dist = float(distance_mm or preset.camera.distance_mm)
    cam = Camera(distance_mm=dist, focal_length_mm=float(focal_px), sensor_width_mm=float(width),
                 image_size_px=(int(width), int(height)))
    lx, ly, lz = preset.light.position_mm
    # A lamp beside the lens moves with the camera; a distant lamp stays where it is.
    attached = math.hypot(lx, ly) < 60.0 and abs(lz - preset.camera.distance_mm) < 60.0
    light_z = lz + (dist - preset.camera.distance_mm if attached else 0.0)

    def disc_mm(rc: tuple[float, float]) -> NDArray[np.float64]:
        """Disc-plane position (mm, x right, y up) of an image point, camera foot at 0."""
        return np.array([rc[1] - (width / 2.0 - 0.5), (height / 2.0 - 0.5) - rc[0]]) * dist / focal_px

    centre = disc_mm(center_px)
    ring = centre if ring_center_px is None else disc_mm(ring_center_px)
    light_foot = ring + ring * (light_z / dist)  # l = m + (m − c)·D_L/D with c = 0
    if ring_center_px is None:
        light_foot = np.array([lx, ly])  # nominal lamp position relative to the camera foot
        if not attached:
            light_foot = np.array([lx, ly]) + centre
    light = Light(position_mm=(0.0, 0.0, light_z), lobe_sigma=float(lobe_sigma or preset.light.lobe_sigma),
                  intensity=preset.light.intensity)
    pose = Pose(camera_offset_mm=tuple(-centre), light_offset_mm=tuple(light_foot - centre))
    return Scene(replace(preset, camera=cam, light=light), pose)


def consistency(rgb: NDArray[np.float64], scene: Scene, total: float | None = None,
                scramble: bool = False, step_nm: float = FEATURE_STEP_NM,
                pixels: NDArray[np.int64] | None = None, colour: NDArray[np.float64] | None = None) -> float:
    """Share of the photo's energy on the disc that I = A(λ₁)·amplitude cannot explain,
    with A fitted per λ₁ bin and channel by least squares.

    ``colour`` (bins × 3, unit rows; NaN rows free) is the camera's own colour at each bin's λ₁
    (:func:`expected_colours`): where given, A must be a multiple of it — a green pixel cannot be
    620 nm. That pins the wavelength axis, which the self-consistency alone leaves free along a
    single streak, and a pose a few pixels off shows up as a colour mismatch.

    ``scramble`` deals the pixels' (λ₁, visibility) pairs out at random (seeded): the same
    coverage and bin sizes, but no rainbow geometry — the baseline a real rainbow must beat.
    """
    px = pixel_diffraction(scene, pixels)
    flat = rgb.reshape(-1, 3)
    glint = glint_mask(px, scene)
    glint_energy = float(np.sum(flat[px.index[glint]] ** 2))
    px = PixelDiffraction(**{k: v[~glint] for k, v in px.__dict__.items()}) if np.any(glint) else px
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


COLOUR_BAND_NM = (400.0, 750.0)  # λ₁ where only the first order shows (the second starts at 760 nm)


def expected_colours(sensitivities: NDArray[np.float64], step_nm: float, blur_nm: float) -> NDArray[np.float64]:
    """Unit camera colour per fit bin of width ``step_nm``: the sensitivities blurred by the
    lobe and the pixel footprint (``blur_nm``, Gaussian std); NaN outside COLOUR_BAND_NM."""
    lam0 = FEATURE_LAMBDA_NM[0] - FEATURE_STEP_NM / 2
    n_bins = int(round(N_FEATURES * FEATURE_STEP_NM / step_nm))
    centres = lam0 + (np.arange(n_bins) + 0.5) * step_nm
    s = max(float(blur_nm), 1.0)
    kernel = np.exp(-0.5 * ((centres[:, None] - WAVELENGTHS_NM[None, :]) / s) ** 2)
    rgb = kernel @ np.asarray(sensitivities, dtype=np.float64)
    norm = np.linalg.norm(rgb, axis=1, keepdims=True)
    out = np.divide(rgb, norm, out=np.full_like(rgb, np.nan), where=norm > 1e-12)
    out[(centres < COLOUR_BAND_NM[0]) | (centres > COLOUR_BAND_NM[1])] = np.nan
    return out


def colour_blur_nm(preset: Preset, sigma: float, focal_px: float) -> float:
    """How far in λ₁ one bin's colour is smeared: the lamp's lobe (d·σ) and one pixel's span
    of λ₁ (about d·2/focal_px), as a Gaussian std."""
    pitch_nm = preset.disc.pitch_um * 1e3
    return math.hypot(pitch_nm * sigma, pitch_nm * 2.0 / focal_px / math.sqrt(12.0))


ZERO_ORDER_SIGMAS = 6.0  # the mirror glint's lobe, in lamp sizes, left out of the fit


def glint_mask(px: PixelDiffraction, scene: Scene) -> NDArray[np.bool_]:
    """Which pixels show the zero-order glint (where the disc mirrors the lamp into the lens).

    A lamp beside the lens or a tilted disc puts that glint on the disc, tens of times brighter
    than the rainbow and clipped: its energy would swamp the first-order fit, which does not
    model it (with the lamp 30 mm beside the lens it held 94 % of the photo's energy, and the
    fit's residual at the true pose was 0.94). It sits where u = v = 0, i.e. at the ring centre,
    so it moves with the fitted pose; the region is a few pixels across, too small to hide a
    rainbow in. One pixel spans about 2/focal_px in (u, v), so the cut widens by two of those."""
    cut = ZERO_ORDER_SIGMAS * scene.preset.light.lobe_sigma + 4.0 / scene.preset.camera.focal_px
    return np.hypot(px.u, px.v) < cut


def _contrast(residual: float, null_residual: float) -> float:
    return 0.0 if null_residual <= 0 else max(0.0, 1.0 - residual / null_residual)


XTOL_PX = 0.01  # centres are wanted to ~0.05 px; finer moves are noise


def _nelder_mead(f, x0: NDArray[np.float64], steps: NDArray[np.float64], max_evals: int,
                 tol: float = 1e-6, xtol: float = XTOL_PX) -> tuple[NDArray[np.float64], float, int]:
    """Minimise f from x0; stops when the simplex's values or its size (< xtol) stop mattering."""
    n = x0.size
    simplex = np.vstack([x0] + [x0 + np.eye(n)[i] * steps[i] for i in range(n)])
    values = np.array([f(x) for x in simplex])
    evals = n + 1
    while evals < max_evals:
        order = np.argsort(values)
        simplex, values = simplex[order], values[order]
        if values[-1] - values[0] < tol * max(abs(values[0]), 1e-12):
            break
        if float(np.max(np.abs(simplex[1:] - simplex[0]))) < xtol:
            break
        centroid = simplex[:-1].mean(axis=0)
        xr = centroid + (centroid - simplex[-1])
        fr = f(xr)
        evals += 1
        if fr < values[0]:
            xe = centroid + 2.0 * (centroid - simplex[-1])
            fe = f(xe)
            evals += 1
            simplex[-1], values[-1] = (xe, fe) if fe < fr else (xr, fr)
        elif fr < values[-2]:
            simplex[-1], values[-1] = xr, fr
        else:
            xc = centroid + 0.5 * (simplex[-1] - centroid)
            fc = f(xc)
            evals += 1
            if fc < values[-1]:
                simplex[-1], values[-1] = xc, fc
            else:
                simplex[1:] = simplex[0] + 0.5 * (simplex[1:] - simplex[0])
                values[1:] = [f(x) for x in simplex[1:]]
                evals += n
    best = int(np.argmin(values))
    return simplex[best], float(values[best]), evals


def axis_of_arcs(lum: NDArray[np.float64], centre: tuple[float, float], r_min: float, r_max: float
                  ) -> tuple[float, float]:
    """Angle of the line the rainbow concentrates on, and how strongly (0 = full rings, 1 = two
    thin streaks), from the second angular harmonic of the energy around ``centre``."""
    rows, cols = np.indices(lum.shape)
    dy, dx = rows - centre[0], cols - centre[1]
    r = np.hypot(dx, dy)
    sel = (r >= r_min) & (r <= r_max)
    w = lum[sel]
    total = float(w.sum())
    if total <= 0:
        return 0.0, 0.0
    phase = np.exp(2j * np.arctan2(-dy[sel], dx[sel]))
    harmonic = complex(np.sum(w * phase)) / total
    return 0.5 * math.atan2(harmonic.imag, harmonic.real), abs(harmonic)


def informative_pixels(rgb: NDArray[np.float64], count: int) -> NDArray[np.int64]:
    """Flat indices of up to ``count`` pixels: the brightest part of the rainbow, where the
    geometry shows, plus an even share of dark ones, where it must predict darkness."""
    lum = rgb.sum(axis=2).ravel()
    order = np.argsort(lum)[::-1]
    bright = order[: count // 2]
    rest = order[count // 2:]
    step = max(1, rest.size // max(1, count - bright.size))
    return np.sort(np.concatenate([bright, rest[::step]]))


def _refine(rgb: NDArray[np.float64], preset: Preset, focal_px: float, dist: float, centre: tuple[float, float],
            ring: tuple[float, float], sigma: float, max_evals: int,
            sensitivities: NDArray[np.float64] | None = None) -> tuple[tuple[float, float], tuple[float, float],
                                                                       float, int]:
    """Both centres again at full resolution, on a subset of pixels, with fine λ₁ bins.

    Arcs and streaks pin the geometry only through their few pixels; at the coarse fit's
    resolution each pixel spans more than 10 nm of λ₁, too blurred to place the centres to the
    fraction of a pixel the spectrum needs."""
    height, width, _ = rgb.shape
    subset = informative_pixels(rgb, FINE_PIXELS)
    total = float(np.sum(rgb.reshape(-1, 3)[subset] ** 2))
    colour = None if sensitivities is None else \
        expected_colours(sensitivities, FIT_STEP_NM, colour_blur_nm(preset, sigma, focal_px))

    def cost(y: NDArray[np.float64]) -> float:
        scene = scene_for(preset, (width, height), focal_px, (y[0], y[1]), (y[2], y[3]), sigma, dist)
        return consistency(rgb, scene, total, step_nm=FIT_STEP_NM, pixels=subset, colour=colour)

    y = np.array([centre[0], centre[1], ring[0], ring[1]])
    value, evals = cost(y), 1
    for size in (1.0, 0.4, 0.15):
        y, value, more = _nelder_mead(cost, y, np.full(4, size), max_evals // 2)
        evals += more
    return (float(y[0]), float(y[1])), (float(y[2]), float(y[3])), value, evals


def _preset_ring_centre(preset: Preset, image_size: tuple[int, int], focal_px: float, dist: float
                        ) -> tuple[float, float]:
    """Image position (row, col) of the mirror point the preset's lamp gives, camera looking
    straight down at the image centre: m = D·l / (D + D_L) from the camera's foot."""
    width, height = image_size
    lx, ly, lz = preset.light.position_mm
    cam_d = preset.camera.distance_mm
    if lz <= 0:
        return ((height - 1) / 2.0, (width - 1) / 2.0)
    k = cam_d / (cam_d + lz) * focal_px / dist
    return ((height / 2.0 - 0.5) - ly * k, (width / 2.0 - 0.5) + lx * k)


def fit_pose(rgb: NDArray[np.floating], preset: Preset, focal_px: float,
             max_evals: int = 150, distance_mm: float | None = None,
             sensitivities: NDArray[np.float64] | None = None, refine: bool = True) -> PoseFit:
    """Fit disc centre, ring centre and lamp size to a linear photo (coordinates of ``rgb``).

    With the camera's ``sensitivities`` (81 × 3) the fit also asks every λ₁ bin to have the
    camera's colour at that wavelength (see :func:`consistency`). ``refine=False`` skips the
    full-resolution refinement (the general-pose fit, which uses this as a start, refines anyway)."""
    height, width, _ = rgb.shape
    factor = max(1, int(round(max(height, width) / FIT_SIDE)))
    small = box_downsample(rgb, factor)
    sh, sw, _ = small.shape
    scale = 1.0 / factor
    f_small = focal_px * scale
    dist = float(distance_mm or preset.camera.distance_mm)
    lum = small.sum(axis=2)
    sym = symmetry_centre(lum)
    total = float(np.sum(small ** 2))
    sigma0 = preset.light.lobe_sigma
    px_per_mm = f_small / dist

    def cost_at(centre: tuple[float, float], ring: tuple[float, float], log_sigma: float) -> float:
        scene = scene_for(preset, (sw, sh), f_small, centre, ring, sigma0 * math.exp(log_sigma), dist)
        return consistency(small, scene, total)

    # Where is the disc centre? On the line the arcs follow, at a distance the fit decides.
    angle, strength = axis_of_arcs(lum, sym, 20 * px_per_mm, 58 * px_per_mm)
    axis = np.array([-math.sin(angle), math.cos(angle)])  # (row, col) direction
    candidates = [0.0] if strength < 0.05 else [0.0, 1, -1, 2, -2, 4, -4, 8, -8, 16, -16]
    # Where are the rings centred? Where the photo is symmetric, or where the preset's lamp puts
    # the mirror point (a lamp beside the lens moves the rings off the disc centre).
    rings = [sym]
    preset_ring = _preset_ring_centre(preset, (sw, sh), f_small, dist)
    if math.dist(preset_ring, sym) > 1.0:
        rings.append(preset_ring)
    best_t, best_ring, best_cost = 0.0, sym, math.inf
    evals = 0
    for ring0 in rings:
        for t in candidates:
            centre = (sym[0] + t * px_per_mm * axis[0], sym[1] + t * px_per_mm * axis[1])
            c = cost_at(centre, ring0, 0.0)
            evals += 1
            if c < best_cost:
                best_t, best_ring, best_cost = t, ring0, c
    start = np.array([sym[0] + best_t * px_per_mm * axis[0], sym[1] + best_t * px_per_mm * axis[1],
                      best_ring[0], best_ring[1], 0.0])

    def cost(x: NDArray[np.float64], log_sigma: float = 0.0) -> float:
        return cost_at((x[0], x[1]), (x[2], x[3]), log_sigma)

    # Disc and ring centres at the preset's lamp size. With full rings the lamp size is not
    # observable (every pixel sees its lobe head-on), so it stays what the preset says.
    steps = np.array([0.5, 0.5, 0.3, 0.3])
    x, value, more = _nelder_mead(cost, start[:4], steps, max_evals)
    evals += more
    # Restart from the best point with a fresh simplex: Nelder–Mead stalls in the narrow valley
    # where moving both centres together along a streak barely changes the fit. Full rings have
    # no such valley (and the full-resolution refinement is for streaks anyway).
    for shrink in (1.0, 0.3) if strength >= 0.05 else ():
        x, value, more = _nelder_mead(cost, x, steps * shrink, max_evals // 2)
        evals += more
    log_sigma = 0.0
    if strength >= 0.05:
        # Arcs and streaks: their angular width measures the lamp size. Golden-section search
        # on log σ within a factor of 3 of the preset, then the centres again.
        lo, hi = -math.log(3.0), math.log(3.0)
        g = (math.sqrt(5.0) - 1.0) / 2.0
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        fa, fb = cost(x, a), cost(x, b)
        for _ in range(14):
            if fa < fb:
                hi, b, fb = b, a, fa
                a = hi - g * (hi - lo)
                fa = cost(x, a)
            else:
                lo, a, fa = a, b, fb
                b = lo + g * (hi - lo)
                fb = cost(x, b)
        evals += 16
        log_sigma = 0.5 * (lo + hi)
        x, value, more = _nelder_mead(lambda y: cost(y, log_sigma), x, 0.5 * steps, max_evals // 2)
        evals += more
    x = np.append(x, log_sigma)

    def to_full(rc: tuple[float, float]) -> tuple[float, float]:
        return ((rc[0] + 0.5) / scale - 0.5, (rc[1] + 0.5) / scale - 0.5)

    def null_of(y: NDArray[np.float64]) -> float:
        """The fitted disc with its pixels' diffraction coordinates dealt out at random."""
        scene = scene_for(preset, (sw, sh), f_small, (y[0], y[1]), (y[2], y[3]), sigma0 * math.exp(y[4]), dist)
        return consistency(small, scene, total, scramble=True)

    null = null_of(x)
    if _contrast(value, null) < RETRY_CONTRAST:
        # A disc cut by the frame has no 180° twin for part of its rings, so the symmetry centre
        # can land far from it. Start once more from the best of a coarse grid of centres (this
        # costs time only on photos that were failing anyway).
        grid = [(r, c) for r in np.linspace(0.0, sh - 1.0, RETRY_GRID)
                for c in np.linspace(0.0, sw - 1.0, RETRY_GRID)]
        costs = [cost_at(rc, rc, 0.0) for rc in grid]
        r0, c0 = grid[int(np.argmin(costs))]
        y, value2, more = _nelder_mead(cost, np.array([r0, c0, r0, c0]), steps, max_evals)
        y = np.append(y, 0.0)
        null2 = null_of(y)
        evals += len(grid) + more + 1
        # Searching more places finds more chance structure, so the second fit must also explain
        # the photo as a CD rainbow does (a grey blob reached contrast 0.72 at residual 0.27).
        if value2 <= RETRY_MAX_RESIDUAL and _contrast(value2, null2) > _contrast(value, null):
            x, value, null = y, value2, null2
    centre, ring = to_full((x[0], x[1])), to_full((x[2], x[3]))
    if refine and strength >= 0.05 and factor > 1:
        centre, ring, value, more = _refine(np.asarray(rgb, dtype=np.float64), preset, focal_px, dist, centre, ring,
                                            sigma0 * math.exp(x[4]), max_evals, sensitivities)
        evals += more
    return PoseFit(
        center_px=centre,
        ring_center_px=ring,
        lobe_sigma=float(sigma0 * math.exp(x[4])),
        focal_px=float(focal_px),
        distance_mm=dist,
        residual=value,
        symmetry_center_px=to_full(sym),
        evaluations=evals + 1,
        null_residual=null,
    )
