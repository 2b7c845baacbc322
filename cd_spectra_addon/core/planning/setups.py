"""Can a capture set-up be built and read? Where the first order lands, what is in the way,
and how sharp the spectrum is — from the forward model's geometry, before anyone takes a photo.

The first order shows where the tangential part v = (ωi + ωo)·t̂ is zero (Kim 2023's line
condition), at λ = d·|u|/m for order m (u = (ωi + ωo)·r̂). Where the lamp, the camera and the
disc axis are in one plane (lamp beside the lens, or lamp and tripod on a line through the disc)
that is the straight line where the plane meets the disc, and the grating equation
d(sin θm − sin θi) = mλ fixes where each wavelength is: with ê the line's direction,
sin θi = −ωi·ê and sin θm = ωo·ê (angles from the normal, positive towards ê), so a point at
signed position s shows λ = d|(ωi + ωo)·ê| (m = ±1). Where they are not (a lamp off the
camera's plane, measured where it happened to be), v = 0 is a curve through the centre that
bends: its two arms are followed outwards radius by radius, the azimuth where v changes sign
found by root finding on the kernel's v (:func:`first_order_curve`), and every result below is read
along them — a signed position is then the radius along an arm (+ or −).

The spectrum is blurred by the angular size of the source (σi) and of the lens's entrance
pupil seen from the disc (σo): δλ = d·√((cos θi σi)² + (cos θo σo)²) (Gaussian std; θ in the
radial plane of diffraction). A uniform disc of diameter a at distance D has an angular std of
a / (4D) along any direction.

The preset file's optional ``"setup"`` section says what the forward model cannot know: the
size of the camera body and where its lens is, the lens aperture, the source size, the
objects near the light path (lamp housing, a card with a hole) and the steps to build it.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..scene.capture import PRESET_DIR, Pose, Preset, Scene, load_preset, preset_path
from ..spectra.grid import VISIBLE_NM
from ..errors import CDSpectraError
from ..scene.kernel import diffraction_at
from ..validation import check_number, check_numbers

__all__ = [
    "NEAR_AXIS",
    "OBLIQUE",
    "SETUP_KINDS",
    "Box",
    "Emitter",
    "SetUp",
    "SideCoverage",
    "SetUpReport",
    "camera_body_box",
    "angular_sigma",
    "FirstOrderCurve",
    "incidence_line",
    "first_order_curve",
    "first_order_positions",
    "first_order_visible",
    "visible_share",
    "tilt_tolerance_deg",
    "analyse",
    "setup_from_dict",
    "load_setup",
    "setup_names",
]

NEAR_AXIS = "near-axis"  # the kinds of set-up: the source beside the lens, looking straight down
OBLIQUE = "oblique"  # or lamp and camera on either side, the camera tilted towards the disc
SETUP_KINDS = (NEAR_AXIS, OBLIQUE)

_SAMPLES_PER_MM = 20  # line sampling; wavelengths are interpolated to ≪ 0.1 mm
_EPS_MM = 1e-6
# The curve v = 0 is followed at radii 1 mm apart, looking for v's sign changes in 1° cells
# around each circle (22 000 kernel points: ~25 ms); at any other radius its azimuth is then
# bracketed from the neighbours' (±0.5°, widened up to ±90° where v does not change sign there)
# and refined until |v| < 1e-15 or the bracket is below 1e-14 rad (|∂v/∂ψ| ≤ 2).
_TRACK_STEP_MM = 1.0
_TRACK_CELLS = 360
# How far the disc may lie tilted (any direction) before the first order no longer shows this
# share of 400–700 nm. A tilt δ turns the disc's normal, so d·(sin θi + sin θo) at every point
# moves by ≈ d·(cos θi + cos θo)·δ: 35–56 nm per degree of tilt in the plane of lamp and camera for
# lamp and camera within 45° of the axis, whichever sides they stand on. Searched in
# TILT_STEP_DEG steps up to TILT_LIMIT_DEG.
TILT_COVERAGE = 0.95
TILT_STEP_DEG = 0.5
TILT_LIMIT_DEG = 5.0
_BRACKETS_DEG = (0.5, 2.0, 8.0, 30.0, 90.0)
_ROOT_TOL_RAD = 1e-14


def _frame(facing: NDArray[np.float64], up: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation whose columns are (right, up, facing) for an object facing ``facing``."""
    w = facing / np.linalg.norm(facing)
    r = np.cross(up, w)
    if np.linalg.norm(r) < 1e-9:  # facing along up: any perpendicular will do
        r = np.cross((1.0, 0.0, 0.0), w) if abs(w[0]) < 0.9 else np.cross((0.0, 1.0, 0.0), w)
    r = r / np.linalg.norm(r)
    return np.stack([r, np.cross(w, r), w], axis=1)


@dataclass(frozen=True)
class Box:
    """An opaque box near the capture (camera body, lamp housing, a card), world mm.

    ``axes`` columns are the box's own x, y, z in the world; ``size_mm`` its extent along them.
    ``passes_source``: the source shines out of it (the lamp's own housing, the card whose hole
    is the source), so it cannot shadow the source's own light.
    """

    name: str
    center_mm: tuple[float, float, float]
    size_mm: tuple[float, float, float]
    axes: tuple[tuple[float, float, float], ...] = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    passes_source: bool = False

    def hits(self, start: NDArray[np.float64], end: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which segments start→end (arrays (..., 3), mm) pass through the box's inside (slab
        test; touching at the segment's ends does not count)."""
        rot = np.asarray(self.axes, dtype=np.float64).T  # columns = box axes
        a = (np.asarray(start, dtype=np.float64) - self.center_mm) @ rot
        b = (np.asarray(end, dtype=np.float64) - self.center_mm) @ rot
        d = b - a
        half = np.asarray(self.size_mm, dtype=np.float64) / 2.0
        t0 = np.full(a.shape[:-1], 0.0)
        t1 = np.full(a.shape[:-1], 1.0)
        for k in range(3):
            dk, ak = d[..., k], a[..., k]
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # near-parallel: dropped below
                lo = (-half[k] - ak) / dk
                hi = (half[k] - ak) / dk
            parallel = np.abs(dk) < 1e-12
            inside = np.abs(ak) < half[k]
            lo_, hi_ = np.minimum(lo, hi), np.maximum(lo, hi)
            t0 = np.where(parallel, np.where(inside, t0, 2.0), np.maximum(t0, lo_))
            t1 = np.where(parallel, np.where(inside, t1, -1.0), np.minimum(t1, hi_))
        length = np.linalg.norm(d, axis=-1)
        margin = _EPS_MM / np.maximum(length, _EPS_MM)
        return (t1 - t0) > margin

    def overlaps(self, other: "Box", tolerance_mm: float = 0.01) -> bool:
        """Do the two boxes share volume (deeper than ``tolerance_mm``)? Separating-axis test
        over the 15 candidate axes of two oriented boxes."""
        a_axes = np.asarray(self.axes, dtype=np.float64)  # rows
        b_axes = np.asarray(other.axes, dtype=np.float64)
        a_half = np.asarray(self.size_mm, dtype=np.float64) / 2.0
        b_half = np.asarray(other.size_mm, dtype=np.float64) / 2.0
        t = np.asarray(other.center_mm, dtype=np.float64) - np.asarray(self.center_mm, dtype=np.float64)
        axes = [*a_axes, *b_axes]
        axes += [np.cross(a, b) for a in a_axes for b in b_axes]
        for axis in axes:
            norm = np.linalg.norm(axis)
            if norm < 1e-9:
                continue
            axis = axis / norm
            ra = float(np.sum(a_half * np.abs(a_axes @ axis)))
            rb = float(np.sum(b_half * np.abs(b_axes @ axis)))
            if abs(float(t @ axis)) >= ra + rb - tolerance_mm:
                return False
        return True

    @staticmethod
    def facing(name: str, center_mm: Any, size_mm: Any, facing: Any, up: Any = (0.0, 0.0, 1.0),
               passes_source: bool = False) -> "Box":
        """A box whose z axis points along ``facing`` (e.g. a card facing the disc)."""
        rot = _frame(np.asarray(facing, dtype=np.float64), np.asarray(up, dtype=np.float64))
        return Box(name, tuple(float(v) for v in center_mm), tuple(float(v) for v in size_mm),
                   tuple(tuple(float(v) for v in rot[:, k]) for k in range(3)), passes_source)


@dataclass(frozen=True)
class Emitter:
    """The glowing part of a lamp behind a hole: a disc of ``diameter_mm`` facing ``facing``.
    Light reaches a disc point through the hole only if the line back through the hole lands
    on it."""

    center_mm: tuple[float, float, float]
    diameter_mm: float
    facing: tuple[float, float, float]


@dataclass(frozen=True)
class SetUp:
    """A buildable capture: the preset (poses) plus what the forward model does not know."""

    preset: Preset
    kind: str  # NEAR_AXIS or OBLIQUE
    camera_body_mm: tuple[float, float, float]  # width, height, depth behind the lens front
    lens_offset_mm: tuple[float, float]  # lens centre from the body's front-face centre (image x, y)
    aperture_mm: float  # entrance pupil diameter (focal length / f-number)
    source_size_mm: float  # diameter of the effective source (filament, LED die, hole)
    bodies: tuple[Box, ...] = ()
    emitter: Emitter | None = None
    steps: tuple[str, ...] = ()


def camera_body_box(setup: SetUp) -> Box:
    """The camera (lens and body as one box) around the preset's camera pose."""
    scene = Scene(setup.preset)
    rot = scene.camera_rotation
    w, h, depth = setup.camera_body_mm
    ox, oy = setup.lens_offset_mm
    center = scene.camera_position * 1e3 + rot @ np.array([-ox, -oy, depth / 2.0])
    return Box("camera body", tuple(center.tolist()), (w, h, depth),
               tuple(tuple(rot[:, k].tolist()) for k in range(3)))


def angular_sigma(size_mm: float, distance_mm: float) -> float:
    """Gaussian-equivalent angular std (rad) of a uniform disc of ``size_mm`` at ``distance_mm``."""
    return size_mm / (4.0 * distance_mm)


def incidence_line(scene: Scene) -> NDArray[np.float64]:
    """Unit direction ê (world, in the disc plane) of the line where the plane through lamp,
    camera and disc axis meets the disc. Raises CDSpectraError if they are not in one plane."""
    n = scene.disc_normal
    c = scene.disc_center
    lamp = scene.light_position - c
    cam = scene.camera_position - c
    lamp_t = lamp - (lamp @ n) * n
    cam_t = cam - (cam @ n) * n
    ref = lamp_t if np.linalg.norm(lamp_t) >= np.linalg.norm(cam_t) else cam_t
    if np.linalg.norm(ref) < 1e-9:
        return _frame(n, np.array([0.0, 1.0, 0.0]))[:, 1]  # both on the axis: any line; use +y
    e = ref / np.linalg.norm(ref)
    other = cam_t if ref is lamp_t else lamp_t
    off_plane = abs(float(other @ np.cross(n, e)))
    if off_plane > 1e-6 * max(1.0, float(np.linalg.norm(other))):
        raise CDSpectraError("the set-up analysis needs the lamp and the camera in one plane with the "
                             "disc axis (lamp beside the lens, or lamp and tripod on a line through the disc)")
    return e


@dataclass(frozen=True)
class FirstOrderCurve:
    """The two arms of the curve v = 0 on the disc, from the centre outwards: arm + (index 0)
    leaves the centre on the lamp's side of the disc (the camera's where the camera's foot is
    farther out), arm − (index 1) on the other side."""

    radii_mm: NDArray[np.float64]  # (n,)
    azimuth_deg: NDArray[np.float64]  # (2, n) in [0, 360), disc frame, counter-clockwise seen from above
    points_mm: NDArray[np.float64]  # (2, n, 3) world mm, on the disc plane
    start: NDArray[np.float64]  # (3,) world direction in which arm + leaves the centre


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _plus_reference(scene: Scene) -> NDArray[np.float64]:
    """The in-plane direction that says which half is +: the lamp's foot, or the camera's where
    it is farther out (as :func:`incidence_line` orients ê)."""
    n = scene.disc_normal
    lamp = scene.light_position - scene.disc_center
    cam = scene.camera_position - scene.disc_center
    lamp_t, cam_t = lamp - (lamp @ n) * n, cam - (cam @ n) * n
    return lamp_t if np.linalg.norm(lamp_t) >= np.linalg.norm(cam_t) else cam_t


class _Track:
    """The arms of v = 0 at radii 1 mm apart; :meth:`azimuths` finds them at any radius."""

    def __init__(self, scene: Scene) -> None:
        self.centre = scene.disc_center * 1e3
        self.frame = scene.disc_rotation
        self.normal = scene.disc_normal
        self.camera = scene.camera_position * 1e3
        self.lamp = scene.light_position * 1e3
        rim = scene.preset.disc.rim_radius_mm
        self.radii = _TRACK_STEP_MM * np.arange(1, int(math.ceil(rim / _TRACK_STEP_MM)) + 2)
        self.start = self._start(scene)
        self.psi = self._follow()

    def points(self, r: NDArray[np.float64], psi: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points (…, 3) at radius ``r`` and azimuth ``psi`` (rad) in the disc's frame."""
        r, psi = np.broadcast_arrays(np.asarray(r, dtype=np.float64), np.asarray(psi, dtype=np.float64))
        return (self.centre + (r * np.cos(psi))[..., None] * self.frame[:, 0]
                + (r * np.sin(psi))[..., None] * self.frame[:, 1])

    def radial(self, psi: NDArray[np.float64]) -> NDArray[np.float64]:
        psi = np.asarray(psi, dtype=np.float64)
        return np.cos(psi)[..., None] * self.frame[:, 0] + np.sin(psi)[..., None] * self.frame[:, 1]

    def v(self, r: NDArray[np.float64], psi: NDArray[np.float64]) -> NDArray[np.float64]:
        """The kernel's v at (r, ψ)."""
        p = self.points(r, psi)
        flat = p.reshape(-1, 3)
        geo = diffraction_at(flat, _unit(self.camera - flat), self.centre, self.normal, self.lamp)
        return geo.v.reshape(p.shape[:-1])

    def _start(self, scene: Scene) -> NDArray[np.float64]:
        """Arm +'s direction at the centre: along the in-plane part of ωi + ωo there (v = 0 needs
        r̂ ∥ ±(ωi + ωo) as r → 0), signed towards the + half."""
        geo = diffraction_at(self.centre[None, :], _unit(self.camera - self.centre)[None, :], self.centre,
                             self.normal, self.lamp)
        h = geo.to_lamp[0] + geo.view[0]
        h_t = h - (h @ self.normal) * self.normal
        if np.linalg.norm(h_t) < 1e-12:  # the mirror glint at the centre: lamp and camera in one plane
            h_t = _plus_reference(scene)
        h_t = h_t / np.linalg.norm(h_t)
        return -h_t if h_t @ _plus_reference(scene) < 0 else h_t

    def _follow(self) -> NDArray[np.float64]:
        """ψ (rad, unwrapped along each arm) at :attr:`radii`: per radius, the cells of a 1° grid
        where v changes sign; each arm takes the one nearest its azimuth at the previous radius;
        then the root in that cell."""
        step = 2.0 * math.pi / _TRACK_CELLS
        edges = step * np.arange(_TRACK_CELLS)
        v = self.v(self.radii[:, None], edges[None, :])
        change = np.sign(v) * np.sign(np.roll(v, -1, axis=1)) <= 0  # cell j: [edge j, edge j + 1]
        local = self.start @ self.frame
        previous = [math.atan2(local[1], local[0]), math.atan2(local[1], local[0]) + math.pi]
        lo = np.empty((2, self.radii.size))
        for k in range(self.radii.size):
            cells = np.flatnonzero(change[k])
            if cells.size == 0:
                raise CDSpectraError(f"the first-order curve could not be followed at r = {self.radii[k]:.2f} mm")
            middles = edges[cells] + step / 2.0
            for arm in (0, 1):
                turn = np.angle(np.exp(1j * (middles - previous[arm])))
                best = int(np.argmin(np.abs(turn)))
                lo[arm, k] = previous[arm] + turn[best] - step / 2.0  # unwrapped
                previous[arm] = lo[arm, k] + step / 2.0
        radii = np.broadcast_to(self.radii, lo.shape)
        return self._root(radii, lo, lo + step)

    def _root(self, r: NDArray[np.float64], lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.float64]:
        """The azimuth in [lo, hi] where v changes sign (v(lo), v(hi) of opposite sign or zero):
        regula falsi with the Illinois step (the bracket always holds the root; a few steps where
        bisection needs ~40), each step on the points not yet converged (|v| or the bracket
        negligible)."""
        r, lo, hi = (np.array(np.broadcast_to(a, np.broadcast_shapes(np.shape(r), np.shape(lo))), dtype=np.float64)
                     for a in (r, lo, hi))
        v_lo, v_hi = self.v(r, lo), self.v(r, hi)
        side = np.zeros(lo.shape)  # which end was kept last: −1 lo, +1 hi (Illinois halves the other's v)
        live = np.flatnonzero(((np.abs(v_lo) > 0.0) & (np.abs(v_hi) > 0.0) & (hi - lo >= _ROOT_TOL_RAD)).ravel())
        flat = [a.reshape(-1) for a in (r, lo, hi, v_lo, v_hi, side)]
        rf, lof, hif, vlf, vhf, sf = flat
        for _ in range(100):
            if live.size == 0:
                break
            a, b, va, vb, sd = lof[live], hif[live], vlf[live], vhf[live], sf[live]
            denom = vb - va
            secant = np.where(denom != 0.0, a - va * (b - a) / np.where(denom != 0.0, denom, 1.0), 0.5 * (a + b))
            x = np.where((secant > a) & (secant < b), secant, 0.5 * (a + b))
            vx = self.v(rf[live], x)
            right = np.sign(vx) == np.sign(va)  # the root lies in [x, b]
            vb = np.where(right & (sd == 1), 0.5 * vb, vb)
            va = np.where(~right & (sd == -1), 0.5 * va, va)
            lof[live], vlf[live] = np.where(right, x, a), np.where(right, vx, va)
            hif[live], vhf[live] = np.where(right, b, x), np.where(right, vb, vx)
            sf[live] = np.where(right, 1.0, -1.0)
            live = live[(np.abs(vx) >= 1e-15) & (hif[live] - lof[live] >= _ROOT_TOL_RAD)]
        lo, hi = lof.reshape(lo.shape), hif.reshape(hi.shape)
        v_lo, v_hi = self.v(r, lo), self.v(r, hi)
        return np.where(np.abs(v_lo) <= np.abs(v_hi), lo, hi)

    def azimuths(self, arm: int, radii: NDArray[np.float64]) -> NDArray[np.float64]:
        """ψ (rad) of arm 0 (+) or 1 (−) at any radii: bracketed around the followed arm's
        azimuth, widened where v does not change sign, then refined to the root."""
        radii = np.asarray(radii, dtype=np.float64)
        guess = np.interp(radii, self.radii, self.psi[arm])
        lo, hi = guess.copy(), guess.copy()
        need = np.ones(radii.shape, dtype=bool)
        for width in np.radians(_BRACKETS_DEG):
            if not need.any():
                break
            a, b = guess[need] - width, guess[need] + width
            ok = np.sign(self.v(radii[need], a)) * np.sign(self.v(radii[need], b)) <= 0
            idx = np.flatnonzero(need)[ok]
            lo[idx], hi[idx] = a[ok], b[ok]
            need[idx] = False
        if need.any():
            raise CDSpectraError("the first-order curve could not be followed at r = "
                                 f"{float(radii[need][0]):.2f} mm")
        return self._root(radii, lo, hi)


def first_order_curve(scene: Scene, radii_mm: Any) -> FirstOrderCurve:
    """Where v = 0 on the disc at the given radii (> 0, mm): the two arms of the first order's
    curve, found with the kernel's v (:func:`~..scene.kernel.diffraction_at`) by root finding
    around each circle. For lamp and camera in one plane with the axis it is the incidence line."""
    radii = np.atleast_1d(np.asarray(radii_mm, dtype=np.float64))
    if radii.ndim != 1 or not np.all(np.isfinite(radii)) or np.any(radii <= 0):
        raise ValueError("radii_mm must be positive, finite radii")
    track = _Track(scene)
    psi = np.stack([track.azimuths(0, radii), track.azimuths(1, radii)])
    return FirstOrderCurve(radii_mm=radii, azimuth_deg=np.degrees(psi) % 360.0, points_mm=track.points(radii[None, :], psi),
                           start=track.start)


class _Streak:
    """Where the first order lies, as positions s along it (mm): the straight incidence line
    (s along ê) where lamp, camera and axis share a plane, else the two arms of the curve v = 0
    (s = +r on arm +, −r on arm −)."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        try:
            self.direction = incidence_line(scene)
            self.track: _Track | None = None
        except CDSpectraError:
            self.track = _Track(scene)
            self.direction = self.track.start

    @property
    def coplanar(self) -> bool:
        return self.track is None

    def locate(self, s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World points (n, 3) at positions ``s`` and the in-plane direction of the plane of
        diffraction there (ê on the line, r̂ on the curve)."""
        s = np.asarray(s, dtype=np.float64)
        if self.track is None:
            return _line_points(self.scene, s, self.direction), np.broadcast_to(self.direction, (s.size, 3))
        psi = np.empty(s.shape)
        for arm, side in ((0, s > 0), (1, s < 0)):
            if side.any():
                psi[side] = self.track.azimuths(arm, np.abs(s[side]))
        return self.track.points(np.abs(s), psi), self.track.radial(psi)

    def kernel(self, s: NDArray[np.float64]) -> tuple[NDArray[np.float64], Any]:
        """Points at ``s`` and the kernel's diffraction coordinate there."""
        points, _ = self.locate(s)
        scene = self.scene
        geo = diffraction_at(points, _unit(scene.camera_position * 1e3 - points), scene.disc_center * 1e3,
                             scene.disc_normal, scene.light_position * 1e3)
        return points, geo

    def lambda1(self, s: NDArray[np.float64] | None = None
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Positions (default: hole to rim on both halves), their points and λ₁ there."""
        disc = self.scene.preset.disc
        if s is None:
            n = int((disc.rim_radius_mm - disc.hole_radius_mm) * _SAMPLES_PER_MM) + 1
            half = np.linspace(disc.hole_radius_mm, disc.rim_radius_mm, n)
            s = np.concatenate([-half[::-1], half])
        points, geo = self.kernel(s)
        return s, points, geo.lambda1_nm(disc.pitch_um)

    def azimuth_deg(self, s: float) -> float:
        """Azimuth (degrees, disc frame, counter-clockwise seen from above) of the point at ``s``."""
        points, _ = self.locate(np.array([s]))
        local = (points[0] - self.scene.disc_center * 1e3) @ self.scene.disc_rotation
        return math.degrees(math.atan2(local[1], local[0])) % 360.0 + 0.0


def first_order_positions(scene: Scene, wavelengths_nm: Any) -> list[list[float]]:
    """For each wavelength, the signed positions s (mm along ê from the centre, or ±radius along
    the curve's arms) on the disc where the first order shows it (λ = d·|u|, v = 0), from the
    hole to the rim."""
    s, _, lam = _Streak(scene).lambda1()
    return _crossings(s, lam, wavelengths_nm)


def first_order_visible(scene: Scene, samples_per_mm: float = 10.0) -> list[tuple[float, float]]:
    """The stretches of 400–700 nm (1 nm steps) the first order shows on the data area of either
    arm, where the point is in the frame and both lamp and camera are above it — read along the
    streak, so a streak thinner than a pixel counts (nothing near the light path is known here)."""
    disc = scene.preset.disc
    n = int((disc.grating_r_max_mm - disc.grating_r_min_mm) * samples_per_mm) + 1
    half = np.linspace(disc.grating_r_min_mm, disc.grating_r_max_mm, n)
    s, points, lam = _Streak(scene).lambda1(np.concatenate([-half[::-1], half]))
    rc = scene.project(points * 1e-3)
    width, height = scene.preset.camera.image_size_px
    normal = scene.disc_normal
    ok = ((rc[:, 0] >= 0) & (rc[:, 0] <= height - 1) & (rc[:, 1] >= 0) & (rc[:, 1] <= width - 1)
          & ((scene.light_position * 1e3 - points) @ normal > 0) & ((scene.camera_position * 1e3 - points) @ normal > 0))
    joined = (np.sign(s[:-1]) == np.sign(s[1:])) & ok[:-1] & ok[1:]
    return [(float(_GRID_NM[a]), float(_GRID_NM[b - 1])) for a, b in _runs(_seen_nm(lam, joined))]


_GRID_NM = np.arange(VISIBLE_NM[0], VISIBLE_NM[1] + 0.5, 1.0)  # 400–700 nm in the 1 nm steps coverage is told in


def _seen_nm(lam: NDArray[np.float64], joined: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """Which steps of :data:`_GRID_NM` the segments between neighbouring samples ``lam[i]``,
    ``lam[i + 1]`` show where ``joined[i]`` (each widened by half a step): marked by their ends
    and summed, not step by step (a planned capture analyses ~60 set-ups of ~2 400 segments)."""
    lo = np.minimum(lam[:-1], lam[1:])[joined] - 0.5
    hi = np.maximum(lam[:-1], lam[1:])[joined] + 0.5
    start = np.searchsorted(_GRID_NM, lo, side="left")  # the first step ≥ lo
    stop = np.searchsorted(_GRID_NM, hi, side="right")  # past the last step ≤ hi
    keep = start < stop
    mark = np.zeros(_GRID_NM.size + 1, np.int64)
    np.add.at(mark, start[keep], 1)
    np.add.at(mark, stop[keep], -1)
    return np.cumsum(mark[:-1]) > 0


def _runs(seen: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """The runs of True in ``seen`` as [start, stop) index pairs, in order."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], seen.astype(np.int8), [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2])]


def visible_share(scene: Scene) -> float:
    """Share of 400–700 nm (1 nm steps) that :func:`first_order_visible` finds on the data area."""
    lo, hi = VISIBLE_NM
    return float(sum(b - a + 1.0 for a, b in first_order_visible(scene)) / (hi - lo + 1.0))


def tilt_tolerance_deg(preset: Preset, limit_deg: float = TILT_LIMIT_DEG) -> float:
    """The largest disc tilt (TILT_STEP_DEG steps, up to ``limit_deg``) for which the first order
    still shows TILT_COVERAGE of 400–700 nm whichever way the disc tips (about x and about y, both
    signs): how level a user must lay it. A disc on a table is rarely within 1° without a level;
    the near-axis capture, whose first order only slides along the line, keeps 400–700 nm to 3°."""
    ok = 0.0
    for k in range(1, int(round(limit_deg / TILT_STEP_DEG)) + 1):
        tilt = k * TILT_STEP_DEG
        for about in ((tilt, 0.0), (-tilt, 0.0), (0.0, tilt), (0.0, -tilt)):
            if visible_share(Scene(preset, Pose(tilt_deg=about))) < TILT_COVERAGE:
                return ok
        ok = tilt
    return ok


def _crossings(s: NDArray[np.float64], lam: NDArray[np.float64], wavelengths_nm: Any) -> list[list[float]]:
    out: list[list[float]] = []
    for target in np.atleast_1d(np.asarray(wavelengths_nm, dtype=np.float64)):
        found = []
        for side in (1.0, -1.0):
            m = np.sign(s) == side
            ss, ll = s[m], lam[m] - target
            k = np.flatnonzero(np.sign(ll[:-1]) * np.sign(ll[1:]) <= 0)
            for i in k:
                if ll[i] == ll[i + 1]:
                    continue
                found.append(float(ss[i] - ll[i] * (ss[i + 1] - ss[i]) / (ll[i + 1] - ll[i])))
        out.append(sorted(set(round(v, 9) for v in found)))
    return out


def _line_points(scene: Scene, s: NDArray[np.float64], e: NDArray[np.float64]) -> NDArray[np.float64]:
    return scene.disc_center * 1e3 + np.asarray(s, dtype=np.float64)[:, None] * e[None, :]


@dataclass(frozen=True)
class SideCoverage:
    """One half of the streak (side +1 along ê or arm +, −1 the other) over the data area."""

    side: int
    lambda_range_nm: tuple[float, float]  # first-order λ shown between the data area's radii
    blocked_fraction: float  # of the data-area points on this side whose light or view is blocked
    azimuth_deg: tuple[float, float] = (0.0, 0.0)  # where it crosses the data area's inner / outer radius
    orders_nm: tuple[tuple[int, float, float], ...] = ()  # (|m| ≥ 2, λ from, to): visible light of order m there


@dataclass(frozen=True)
class SetUpReport:
    """What a set-up delivers, for the README, the planner and the panel."""

    name: str
    line_direction: tuple[float, float, float]  # ê, or the direction arm + leaves the centre in
    positions_mm: dict[float, list[float]]  # λ → signed positions on the line / arms (whole disc)
    sides: tuple[SideCoverage, SideCoverage]
    covered_nm: tuple[float, float] | None  # the part of 400–700 on the unblocked data area
    covers_visible: bool
    glint_mm: list[float]  # zero-order (mirror) points on the streak
    sigma_source: float
    sigma_aperture: float
    resolution_nm: dict[float, float]  # FWHM of the spectral blur at λ
    nm_per_px: dict[float, float]  # sampling along the streak in the preset's image
    occlusions: tuple[str, ...]  # plain-language findings, empty when nothing is in the way
    disc_in_frame: bool
    notes: tuple[str, ...] = field(default=())
    read_side: int = 0  # +1 / −1: this half of the line alone shows 400–700 nm unblocked; 0: split
    coplanar: bool = True  # lamp, camera and disc axis in one plane: the streak is straight

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "line_direction": list(self.line_direction),
            "coplanar": self.coplanar,
            "positions_mm": {f"{k:g}": v for k, v in self.positions_mm.items()},
            "sides": [{"side": c.side, "lambda_range_nm": list(c.lambda_range_nm),
                       "blocked_fraction": c.blocked_fraction, "azimuth_deg": list(c.azimuth_deg),
                       "orders_nm": [{"order": m, "from_nm": a, "to_nm": b} for m, a, b in c.orders_nm]}
                      for c in self.sides],
            "covered_nm": list(self.covered_nm) if self.covered_nm else None,
            "covers_400_700": self.covers_visible,
            "glint_mm": self.glint_mm,
            "sigma_source_rad": self.sigma_source,
            "sigma_aperture_rad": self.sigma_aperture,
            "resolution_fwhm_nm": {f"{k:g}": v for k, v in self.resolution_nm.items()},
            "nm_per_px": {f"{k:g}": v for k, v in self.nm_per_px.items()},
            "occlusions": list(self.occlusions),
            "disc_in_frame": self.disc_in_frame,
            "notes": list(self.notes),
            "read_side": self.read_side,
        }


REPORT_NM = (400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0)


def _on_data(s: NDArray[np.float64], disc: Any, side: int = 0) -> NDArray[np.bool_]:
    """Line samples on the data area (on one half if ``side`` is ±1)."""
    mask = (np.abs(s) >= disc.grating_r_min_mm) & (np.abs(s) <= disc.grating_r_max_mm)
    return mask & (np.sign(s) == side) if side else mask


def _visible_orders(lam: NDArray[np.float64], max_order: int) -> tuple[tuple[int, float, float], ...]:
    """Orders |m| ≥ 2 that show part of 400–700 nm where the first order shows ``lam`` (λm = λ₁/m;
    along a streak λ₁ is continuous, so each order shows one stretch)."""
    lo_nm, hi_nm = VISIBLE_NM
    out = []
    for m in range(2, int(max_order) + 1):
        a, b = float(lam.min()) / m, float(lam.max()) / m
        if a <= hi_nm and b >= lo_nm:
            out.append((m, max(a, lo_nm), min(b, hi_nm)))
    return tuple(out)


def analyse(setup: SetUp, report_nm: tuple[float, ...] = REPORT_NM) -> SetUpReport:
    """Coverage, occlusion, glint and resolution of a set-up (nominal pose)."""
    preset = setup.preset
    scene = Scene(preset)
    disc = preset.disc
    streak = _Streak(scene)
    e = streak.direction
    s, points, lam = streak.lambda1()
    lamp = scene.light_position * 1e3
    cam = scene.camera_position * 1e3
    boxes = (camera_body_box(setup), *setup.bodies)
    light_blocked = np.zeros(s.size, dtype=bool)
    view_blocked = np.zeros(s.size, dtype=bool)
    findings: list[str] = []
    on_data = _on_data(s, disc)
    none = np.zeros(s.size, dtype=bool)
    for box in boxes:
        lb = none if box.passes_source else box.hits(np.broadcast_to(lamp, points.shape), points)
        vb = none if box.name == "camera body" else box.hits(np.broadcast_to(cam, points.shape), points)
        if np.any(lb & on_data):
            findings.append(f"the {box.name} shadows the lamp's light on {np.mean(lb[on_data]):.0%} "
                            "of the streak line")
        if np.any(vb & on_data):
            findings.append(f"the {box.name} hides {np.mean(vb[on_data]):.0%} of the streak line from the camera")
        light_blocked |= lb
        view_blocked |= vb
    if setup.emitter is not None:
        unlit = ~_emitter_reaches(setup.emitter, lamp, points)
        # Between the glowing lamp and the hole only the source's own parts may be.
        behind = _emitter_hits(setup.emitter, lamp, points)
        for box in boxes:
            if box.passes_source:
                continue
            shadow = box.hits(behind, np.broadcast_to(lamp, points.shape))
            if np.any(shadow & on_data):
                findings.append(f"the {box.name} stands between the lamp and the hole for "
                                f"{np.mean(shadow[on_data]):.0%} of the streak line (move the hole past its edge)")
            unlit |= shadow
        if np.any(unlit & on_data):
            findings.append(f"the lamp behind the hole does not fill it for {np.mean(unlit[on_data]):.0%} of "
                            "the streak line (move the lamp closer to the card or use a bigger lamp)")
        light_blocked |= unlit
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            if a.overlaps(b):
                findings.append(f"the {a.name} and the {b.name} would have to be in the same place")
    blocked = light_blocked | view_blocked
    # Lamp and camera must both be above the disc for the point to be lit and seen.
    n = scene.disc_normal
    blocked |= ((lamp - points) @ n <= 0) | ((cam - points) @ n <= 0)

    sides = []
    for side in (1, -1):
        data = _on_data(s, disc, side)
        lam_side = lam[data]
        sides.append(SideCoverage(side, (float(lam_side.min()), float(lam_side.max())),
                                  float(np.mean(blocked[data])),
                                  (streak.azimuth_deg(side * disc.grating_r_min_mm),
                                   streak.azimuth_deg(side * disc.grating_r_max_mm)),
                                  _visible_orders(lam_side, disc.max_order)))
    covered, covers = _coverage(lam, s, data_blocked=blocked, disc=disc)
    lo_nm, hi_nm = VISIBLE_NM
    read_side = next((c.side for c in sides if c.lambda_range_nm[0] <= lo_nm and c.lambda_range_nm[1] >= hi_nm
                      and c.blocked_fraction == 0.0), 0)

    report = tuple(float(x) for x in report_nm)
    positions = dict(zip(report, _crossings(s, lam, report)))
    glint = _glint(streak)
    sig_src = angular_sigma(setup.source_size_mm, float(np.linalg.norm(lamp - scene.disc_center * 1e3)))
    sig_ap = angular_sigma(setup.aperture_mm, float(np.linalg.norm(cam - scene.disc_center * 1e3)))
    resolution: dict[float, float] = {}
    at_nm: dict[float, float] = {}  # where on the streak each reported wavelength is read
    for lam_nm, where in positions.items():
        on = [x for x in where if disc.grating_r_min_mm <= abs(x) <= disc.grating_r_max_mm]
        on.sort(key=lambda x: x * read_side < 0)  # the half that shows the whole range first
        if not on:
            continue
        x = on[0]
        at, radial = streak.locate(np.array([x]))
        p, e_here = at[0], radial[0]
        wi, wo = _unit(lamp - p), _unit(cam - p)
        ci, co = float(wi @ n), float(wo @ n)
        # cos θ in the plane of diffraction (the radial plane): √(1 − (ω·ê)²) for ω in that plane
        ci_r, co_r = math.sqrt(max(1e-12, 1 - (wi @ e_here) ** 2)), math.sqrt(max(1e-12, 1 - (wo @ e_here) ** 2))
        std = disc.pitch_um * 1e3 * math.hypot(ci_r * sig_src, co_r * sig_ap)
        resolution[lam_nm] = float(2.3548 * std) if ci > 0 and co > 0 else float("inf")
        at_nm[lam_nm] = x
    per_px = dict(zip(at_nm, _nm_per_px(streak, np.array(list(at_nm.values()), dtype=np.float64))))
    rim = _rim_points(scene)
    rc = scene.project(rim * 1e-3)
    width, height = preset.camera.image_size_px
    in_frame = bool(np.all((rc >= 0) & (rc <= np.array([height - 1, width - 1]))))
    notes = []
    if not streak.coplanar:
        notes.append("lamp and camera are not in one vertical plane with the disc's axis: the streak is a curve "
                     f"through the centre; arm + crosses the data area from azimuth {sides[0].azimuth_deg[0]:.0f}° to "
                     f"{sides[0].azimuth_deg[1]:.0f}°, arm − from {sides[1].azimuth_deg[0]:.0f}° to {sides[1].azimuth_deg[1]:.0f}° "
                     "(seen from above the disc, counter-clockwise)")
    for g in glint:
        if disc.grating_r_min_mm <= abs(g) <= disc.grating_r_max_mm:
            notes.append(f"the mirror glint (zero order) falls on the data area at r = {abs(g):.0f} mm: "
                         "expose so it does not spread, or move the lamp")
    if not in_frame:
        notes.append("the disc's rim leaves the frame: step back or use a wider lens")
    return SetUpReport(
        name=preset.name, line_direction=tuple(float(v) for v in e), positions_mm=positions,
        sides=(sides[0], sides[1]), covered_nm=covered, covers_visible=covers, glint_mm=glint,
        sigma_source=sig_src, sigma_aperture=sig_ap, resolution_nm=resolution, nm_per_px=per_px,
        occlusions=tuple(findings), disc_in_frame=in_frame, notes=tuple(notes), read_side=read_side,
        coplanar=streak.coplanar,
    )


def _coverage(lam: NDArray[np.float64], s: NDArray[np.float64], data_blocked: NDArray[np.bool_],
              disc: Any) -> tuple[tuple[float, float] | None, bool]:
    """The contiguous stretch of 400–700 nm (1 nm steps) shown somewhere on the unblocked data
    area, allowing the two sides of the disc to share it."""
    joined = np.zeros(s.size - 1, dtype=bool)
    for side in (1, -1):
        data = _on_data(s, disc, side)
        joined |= data[:-1] & data[1:]
    seen = _seen_nm(lam, joined & ~data_blocked[:-1] & ~data_blocked[1:])
    if not np.any(seen):
        return None, False
    a, b = max(_runs(seen), key=lambda run: run[1] - run[0])  # the longest (the first of equals)
    return (float(_GRID_NM[a]), float(_GRID_NM[b - 1])), bool(np.all(seen))


def _glint(streak: _Streak) -> list[float]:
    """Signed positions on the streak where ωi + ωo is along the normal (u = 0): the mirror glint."""
    disc = streak.scene.preset.disc
    s = np.linspace(-disc.rim_radius_mm, disc.rim_radius_mm, int(2 * disc.rim_radius_mm * _SAMPLES_PER_MM) + 1)
    s = s[s != 0.0]  # the radial direction, hence u's sign, is undefined at the centre itself
    _, geo = streak.kernel(s)
    u = geo.u * np.sign(s)  # (ωi + ωo)·ê: r̂ = ±ê on the line (the arm's outward r̂ on the curve)
    k = np.flatnonzero(np.sign(u[:-1]) * np.sign(u[1:]) <= 0)
    out = []
    for i in k:
        if u[i] == u[i + 1]:
            continue
        x = float(s[i] - u[i] * (s[i + 1] - s[i]) / (u[i + 1] - u[i]))
        if abs(x) >= disc.hole_radius_mm:
            out.append(round(x, 3))
    return out


def _nm_per_px(streak: _Streak, s_mm: NDArray[np.float64]) -> list[float]:
    """How many nm one image pixel spans along the streak at each signed position ``s_mm``
    (all in one pass of the kernel)."""
    if s_mm.size == 0:
        return []
    h = 0.05
    _, pts, lam = streak.lambda1(np.concatenate([s_mm - h, s_mm + h]))
    rc = streak.scene.project(pts * 1e-3)
    n = s_mm.size
    px = np.linalg.norm(rc[n:] - rc[:n], axis=1)
    return [float(v) for v in np.abs(lam[n:] - lam[:n]) / np.maximum(px, 1e-12)]


def _rim_points(scene: Scene) -> NDArray[np.float64]:
    a = np.linspace(0, 2 * math.pi, 73)
    r = scene.preset.disc.rim_radius_mm
    local = np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(a)], axis=1)
    return local @ scene.disc_rotation.T + scene.disc_center * 1e3


def _emitter_hits(emitter: Emitter, hole: NDArray[np.float64], points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Where the line from each disc point back through the hole meets the emitter's plane."""
    c = np.asarray(emitter.center_mm, dtype=np.float64)
    f = _unit(np.asarray(emitter.facing, dtype=np.float64))
    d = hole[None, :] - points
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((c - points) @ f) / (d @ f)
    return points + np.nan_to_num(t, nan=1.0, posinf=1.0, neginf=1.0)[:, None] * d


def _emitter_reaches(emitter: Emitter, hole: NDArray[np.float64], points: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Does the line from each disc point back through the hole land on the glowing disc?"""
    c = np.asarray(emitter.center_mm, dtype=np.float64)
    f = _unit(np.asarray(emitter.facing, dtype=np.float64))
    d = hole[None, :] - points
    denom = d @ f
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((c - points) @ f) / denom
    hit = points + t[:, None] * d
    return (np.abs(denom) > 1e-12) & (t > 1.0) & (np.linalg.norm(hit - c, axis=1) <= emitter.diameter_mm / 2.0)


def _triple(value: Any, where: str) -> tuple[float, float, float]:
    x, y, z = check_numbers(f"setup.{where}", value, 3)
    return (x, y, z)


def _positive(value: Any, where: str) -> float:
    return check_number(f"setup.{where}", value, above=0.0)


def setup_from_dict(preset: Preset, data: dict[str, Any]) -> SetUp:
    """A :class:`SetUp` from a preset and its file's ``"setup"`` section (ValueError if bad)."""
    if not isinstance(data, dict):
        raise ValueError("setup must be an object")
    kind = data.get("kind")
    if kind not in SETUP_KINDS:
        raise ValueError(f"setup.kind must be {' or '.join(map(repr, SETUP_KINDS))}, not {kind!r}")
    x, y, z = check_numbers("setup.camera_body_mm", data.get("camera_body_mm"), 3, above=0.0)
    body = (x, y, z)
    offset = check_numbers("setup.lens_offset_mm", data.get("lens_offset_mm", [0.0, 0.0]), 2)
    bodies = []
    for i, b in enumerate(data.get("bodies", [])):
        size = _triple(b.get("size_mm"), f"bodies[{i}].size_mm")
        bodies.append(Box.facing(str(b.get("name", f"object {i}")), _triple(b.get("center_mm"), f"bodies[{i}].center_mm"),
                                 size, _triple(b.get("facing", [0, 0, -1]), f"bodies[{i}].facing"),
                                 _triple(b.get("up", [0, 1, 0]), f"bodies[{i}].up"), bool(b.get("passes_source", False))))
    emitter = None
    if data.get("emitter") is not None:
        em = data["emitter"]
        emitter = Emitter(_triple(em.get("center_mm"), "emitter.center_mm"),
                          _positive(em.get("diameter_mm"), "emitter.diameter_mm"),
                          _triple(em.get("facing", [0, 0, -1]), "emitter.facing"))
    return SetUp(
        preset=preset, kind=kind, camera_body_mm=body,
        lens_offset_mm=(offset[0], offset[1]),
        aperture_mm=_positive(data.get("aperture_mm"), "aperture_mm"),
        source_size_mm=_positive(data.get("source_size_mm"), "source_size_mm"),
        bodies=tuple(bodies), emitter=emitter, steps=tuple(str(x) for x in data.get("steps", [])),
    )


def setup_names() -> list[str]:
    """Presets that describe a buildable set-up (their file has a ``"setup"`` section)."""
    names = []
    for path in sorted(PRESET_DIR.glob("*.json")):
        try:
            if "setup" in json.loads(path.read_text(encoding="utf-8")):
                names.append(path.stem)
        except ValueError:
            continue
    return names


def load_setup(name_or_path: str | Path) -> SetUp:
    """The set-up of a preset by name or path; CDSpectraError if it has none or it is invalid."""
    preset = load_preset(name_or_path)
    path = preset_path(name_or_path)
    data = json.loads(path.read_text(encoding="utf-8"))
    if "setup" not in data:
        raise CDSpectraError(f"preset {preset.name!r} describes no buildable set-up (no 'setup' section); "
                             f"set-ups: {', '.join(setup_names())}")
    try:
        return setup_from_dict(preset, data["setup"])
    except (ValueError, TypeError, AttributeError) as exc:
        raise CDSpectraError(f"preset file {path} has an invalid setup section: {exc}") from exc
