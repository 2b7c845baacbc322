"""The one geometric kernel: rotations, camera rays, projection, and the diffraction coordinate.

Everything that asks "which wavelength does the first order show here, and how visible is it"
comes through :func:`diffraction_at` — the readout and its forward matrix (per pixel), the pose
fit (per camera ray, thousands of times), the BRDF of the numpy renderer, the set-up checks and
the planner (along lines on the disc). The kernel is frame-free: it takes the eye, the disc
centre and normal and the lamp in one frame (the world's for a :class:`~.capture.Scene`, the
camera's for the pose fit), so there is one formula to get right.

For a disc point with unit vectors ωi (to the lamp) and ωo (to the camera), order m lights up
where u = (ωi + ωo)·r̂ = mλ/d and v = (ωi + ωo)·t̂ ≈ 0 (r̂ radial, t̂ = n × r̂ tangential):
λ₁ = d·|u| is the first order's wavelength and exp(−v²/2σ²) its visibility for a lamp of
angular size σ. The slowly varying rest of the BRDF, irradiance × Stam's G/w², is the ``gain``
(relative to its value where the lamp's axis meets the disc centre).

:func:`diffraction_along` also returns, on request, the derivatives of u, v and the gain with
respect to the disc centre, the disc normal and the lamp (camera frame, the eye at the origin):
the pose fit's Jacobian comes from them instead of from re-evaluating the kernel per parameter.

Pixel convention everywhere: the centre of pixel ``[i, j]`` is ``(row, col) = (i, j)``, row 0 at
the top; the camera looks down its own −z with x to the image's right and y up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

COS_EPS = 1e-3  # cosines are clamped here: keeps G/w² finite at grazing angles
# Rays per pass of the derivatives: their ~60 (rays × changes) arrays then stay in the CPU's cache
# (the fine pose fit's 8000 rays × 7 changes: 12.3 ms in one pass, 6.2 ms in passes of 2000;
# 500: 9.6 ms). The values are the same, element by element.
DERIVATIVE_CHUNK = 2048

__all__ = ["COS_EPS", "rotation_xy", "rotation_about", "turn_between", "camera_rays", "index_rays", "project",
           "intersect_plane", "Diffraction", "Derivatives", "diffraction_at", "diffraction_along"]


def rotation_xy(ax_deg: float, ay_deg: float) -> NDArray[np.float64]:
    """Rotation about x by ``ax_deg`` then about y by ``ay_deg`` (the disc tilt's convention)."""
    ax, ay = math.radians(ax_deg), math.radians(ay_deg)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, math.cos(ax), -math.sin(ax)], [0.0, math.sin(ax), math.cos(ax)]])
    ry = np.array([[math.cos(ay), 0.0, math.sin(ay)], [0.0, 1.0, 0.0], [-math.sin(ay), 0.0, math.cos(ay)]])
    return ry @ rx


def rotation_about(axis: NDArray[np.float64], angle_deg: float) -> NDArray[np.float64]:
    """Rotation by ``angle_deg`` about the unit ``axis`` (Rodrigues)."""
    a = math.radians(angle_deg)
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(a) * k + (1.0 - math.cos(a)) * k @ k


def turn_between(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """The smallest rotation taking unit vector ``a`` to unit vector ``b`` (Rodrigues)."""
    v = np.cross(a, b)
    c = float(a @ b)
    if c < -1.0 + 1e-12:  # opposite: half a turn about any perpendicular
        p = np.cross(a, (1.0, 0.0, 0.0) if abs(a[0]) < 0.9 else (0.0, 1.0, 0.0))
        p /= np.linalg.norm(p)
        return 2.0 * np.outer(p, p) - np.eye(3)
    k = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + k + k @ k / (1.0 + c)


def camera_rays(rows: NDArray[np.float64], cols: NDArray[np.float64], size: tuple[int, int],
                focal_px: float) -> NDArray[np.float64]:
    """Unit directions in the camera frame through image positions (principal point at the
    image centre)."""
    width, height = size
    x = np.asarray(cols, dtype=np.float64) + 0.5 - width / 2.0
    y = height / 2.0 - (np.asarray(rows, dtype=np.float64) + 0.5)
    inv = 1.0 / np.sqrt(x * x + y * y + float(focal_px) ** 2)
    return np.stack([x * inv, y * inv, -float(focal_px) * inv], axis=-1)


def index_rays(index: NDArray[np.int64], size: tuple[int, int], focal_px: float) -> NDArray[np.float64]:
    """:func:`camera_rays` through the centres of flat pixel indices."""
    rows, cols = np.divmod(np.asarray(index, dtype=np.int64), size[0])
    return camera_rays(rows, cols, size, focal_px)


def project(points: NDArray[np.float64], size: tuple[int, int], focal_px: float) -> NDArray[np.float64]:
    """(row, col) image positions of camera-frame points (…, 3) in front of the camera."""
    width, height = size
    p = np.asarray(points, dtype=np.float64)
    scale = float(focal_px) / -p[..., 2]
    return np.stack([height / 2.0 - 0.5 - p[..., 1] * scale, p[..., 0] * scale + width / 2.0 - 0.5], axis=-1)


def intersect_plane(rays: NDArray[np.float64], eye: NDArray[np.float64], centre: NDArray[np.float64],
                    normal: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ray parameters t (−1 where a ray runs parallel to the plane) and the points eye + t·ray
    where unit ``rays`` meet the plane through ``centre`` with unit ``normal``; t > 0 in front."""
    d = np.asarray(rays, dtype=np.float64)
    n = np.asarray(normal, dtype=np.float64)
    e = np.asarray(eye, dtype=np.float64)
    denom = d @ n
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(np.abs(denom) > 1e-12, float((np.asarray(centre, dtype=np.float64) - e) @ n) / denom, -1.0)
    return t, e + d * t[..., None]


@dataclass(frozen=True)
class Derivatives:
    """Directional derivatives of u, v, the gain and the radius, (n, k) each: column j along the
    j-th given change of (disc centre, disc normal, lamp). A change of the normal must keep it
    unit (a change perpendicular to it), as a rotation gives."""

    u: NDArray[np.float64]
    v: NDArray[np.float64]
    gain: NDArray[np.float64]
    radius: NDArray[np.float64]


@dataclass(frozen=True)
class Diffraction:
    """The first-order coordinate at disc points (arrays over the points). Vector fields are kept
    component-major, (3, n): every step of the kernel is then one pass of numpy over contiguous
    memory (a 24 MP photo's readout evaluates ~260 000 pixels); ``points`` etc. give (n, 3) views."""

    points_c: NDArray[np.float64]  # (3, n) on the disc plane, the caller's frame and unit
    radius: NDArray[np.float64]  # from the disc centre, the caller's unit
    u: NDArray[np.float64]  # (ωi + ωo)·r̂
    v: NDArray[np.float64]  # (ωi + ωo)·t̂
    cos_i: NDArray[np.float64]  # ωi·n (≤ 0: the lamp is behind the disc)
    cos_o: NDArray[np.float64]  # ωo·n
    dot_io: NDArray[np.float64]  # ωi·ωo
    lamp_dist2: NDArray[np.float64]  # squared distance to the lamp
    gain: NDArray[np.float64]  # irradiance · G/w² relative to the lamp's irradiance at the disc centre
    view_c: NDArray[np.float64]  # (3, n) ωo, unit, towards the eye
    to_lamp_c: NDArray[np.float64]  # (3, n) ωi, unit
    radial_c: NDArray[np.float64]  # (3, n) r̂
    derivatives: Derivatives | None = None

    @property
    def points(self) -> NDArray[np.float64]:
        return self.points_c.T

    @property
    def view(self) -> NDArray[np.float64]:
        return self.view_c.T

    @property
    def to_lamp(self) -> NDArray[np.float64]:
        return self.to_lamp_c.T

    @property
    def radial(self) -> NDArray[np.float64]:
        return self.radial_c.T

    def lambda1_nm(self, pitch_um: float) -> NDArray[np.float64]:
        """First-order wavelength d·|u|."""
        return np.abs(self.u) * (pitch_um * 1e3)

    def visibility(self, sigma: float) -> NDArray[np.float64]:
        """exp(−v²/2σ²): how much of the lobe of a lamp of angular size σ reaches the eye."""
        return np.exp(-(self.v * self.v) / (2.0 * sigma * sigma))

    def take(self, index: NDArray[np.intp]) -> "Diffraction":
        """The coordinate at the points ``index`` only: what the kernel gives those points'
        rays alone, value for value (every step is per point), without evaluating it again."""
        fields = {f: np.take(getattr(self, f), index, axis=-1)
                  for f in Diffraction.__dataclass_fields__ if f != "derivatives"}
        d = self.derivatives
        derivatives = None if d is None else Derivatives(
            **{f: np.take(getattr(d, f), index, axis=0) for f in Derivatives.__dataclass_fields__})
        return Diffraction(**fields, derivatives=derivatives)


def _dot(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Row-wise dot product of (…, 3) arrays (three multiplies: faster than einsum or sum)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def diffraction_at(points: NDArray[np.float64], view: NDArray[np.float64], centre: NDArray[np.float64],
                   normal: NDArray[np.float64], lamp: NDArray[np.float64]) -> Diffraction:
    """u, v, cosines and the gain at ``points`` (n, 3) on the disc plane, seen along unit ``view``
    directions (n, 3, towards the eye), lit from ``lamp``; all in one frame and length unit."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    w = np.asarray(view, dtype=np.float64).reshape(-1, 3)
    return _at(np.ascontiguousarray(p.T), np.ascontiguousarray(w.T), centre, normal, lamp)


def _at(p: NDArray[np.float64], wo: NDArray[np.float64], centre: NDArray[np.float64], normal: NDArray[np.float64],
        lamp: NDArray[np.float64]) -> Diffraction:
    """:func:`diffraction_at` on component-major (3, n) points and view directions."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    c = np.asarray(centre, dtype=np.float64)
    lamp = np.asarray(lamp, dtype=np.float64)
    rel = p - c[:, None]
    along = n[0] * rel[0] + n[1] * rel[1] + n[2] * rel[2]
    radial = rel - along * n[:, None]
    radius = np.sqrt(radial[0] * radial[0] + radial[1] * radial[1] + radial[2] * radial[2])
    r_hat = radial / np.maximum(radius, 1e-300)
    t_hat = np.array([n[1] * r_hat[2] - n[2] * r_hat[1], n[2] * r_hat[0] - n[0] * r_hat[2],
                      n[0] * r_hat[1] - n[1] * r_hat[0]])
    to_lamp = lamp[:, None] - p
    dist2 = to_lamp[0] * to_lamp[0] + to_lamp[1] * to_lamp[1] + to_lamp[2] * to_lamp[2]
    wi = to_lamp / np.sqrt(np.maximum(dist2, 1e-300))
    h = wi + wo
    cos_i = n[0] * wi[0] + n[1] * wi[1] + n[2] * wi[2]
    cos_o = n[0] * wo[0] + n[1] * wo[1] + n[2] * wo[2]
    dot_io = wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2]
    u = h[0] * r_hat[0] + h[1] * r_hat[1] + h[2] * r_hat[2]
    v = h[0] * t_hat[0] + h[1] * t_hat[1] + h[2] * t_hat[2]
    ref = float(np.sum((lamp - c) ** 2))
    return Diffraction(points_c=p, radius=radius, u=u, v=v, cos_i=cos_i, cos_o=cos_o, dot_io=dot_io,
                       lamp_dist2=dist2, gain=_gain(cos_i, cos_o, dot_io, dist2, ref), view_c=wo, to_lamp_c=wi,
                       radial_c=r_hat)


def _gain(cos_i: NDArray[np.float64], cos_o: NDArray[np.float64], dot_io: NDArray[np.float64],
          dist2: NDArray[np.float64], ref: float) -> NDArray[np.float64]:
    """Irradiance × Stam's G/w² (G = (1 + ωi·ωo)² / (cos θi cos θo), w = cos θi + cos θo),
    relative to the irradiance at distance √ref: the BRDF's slowly varying factor. Pixels that
    share λ₁ then share the profile value A in I = A·visibility·gain wherever they are."""
    ci = np.clip(cos_i, COS_EPS, 1.0)
    co = np.clip(cos_o, COS_EPS, 1.0)
    w = ci + co
    g = (1.0 + dot_io) ** 2 / (ci * co * w * w)
    return np.where((cos_i > 0) & (cos_o > 0), g * ci * ref / np.maximum(dist2, 1e-300), 0.0)


def diffraction_along(rays: NDArray[np.float64], eye: NDArray[np.float64], centre: NDArray[np.float64],
                      normal: NDArray[np.float64], lamp: NDArray[np.float64],
                      directions: NDArray[np.float64] | None = None) -> tuple[NDArray[np.bool_], Diffraction]:
    """Where unit ``rays`` from ``eye`` meet the disc plane (in front of the eye) and the
    diffraction coordinate there: (hit mask over the rays, :class:`Diffraction` over the hits).

    ``directions`` (9, k), camera frame only (``eye`` at the origin): k changes of (disc centre,
    disc normal, lamp), stacked; adds the derivatives of u, v, the gain and the radius along
    each (:class:`Derivatives`) — what a pose fit's Jacobian needs, by the chain rule through
    the ray–plane intersection X = t·ray, t = (n·P)/(n·ray)."""
    e = np.asarray(eye, dtype=np.float64)
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    c = np.asarray(centre, dtype=np.float64)
    rays = np.asarray(rays, dtype=np.float64).reshape(-1, 3)
    if directions is not None and rays.shape[0] > DERIVATIVE_CHUNK:
        parts = [diffraction_along(rays[i:i + DERIVATIVE_CHUNK], e, c, n, lamp, directions)
                 for i in range(0, rays.shape[0], DERIVATIVE_CHUNK)]
        return np.concatenate([hit for hit, _ in parts]), _joined([geo for _, geo in parts])
    d = np.ascontiguousarray(rays.T)  # (3, n)
    denom = n[0] * d[0] + n[1] * d[1] + n[2] * d[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(np.abs(denom) > 1e-12, float((c - e) @ n) / denom, -1.0)
    hit = t > 0
    if not hit.all():
        keep = np.flatnonzero(hit)
        d, t = np.take(d, keep, axis=1), t[keep]
    points = e[:, None] + d * t
    out = _at(points, -d, c, n, lamp)
    d = d.T
    if directions is None:
        return hit, out
    if np.any(e != 0.0):
        raise ValueError("derivatives are for the camera frame (eye at the origin)")
    return hit, _with_derivatives(out, d, d @ n, c, n, np.asarray(lamp, dtype=np.float64),
                                  np.asarray(directions, dtype=np.float64))


def _joined(parts: list[Diffraction]) -> Diffraction:
    """One :class:`Diffraction` of consecutive parts (their points in order)."""
    fields = {f: np.concatenate([getattr(p, f) for p in parts], axis=-1)
              for f in Diffraction.__dataclass_fields__ if f != "derivatives"}
    d = [p.derivatives for p in parts]
    derivatives = None if d[0] is None else Derivatives(
        **{f: np.concatenate([getattr(x, f) for x in d], axis=0) for f in Derivatives.__dataclass_fields__})
    return Diffraction(**fields, derivatives=derivatives)


def _with_derivatives(out: Diffraction, d: NDArray[np.float64], denom: NDArray[np.float64],
                      centre: NDArray[np.float64], n: NDArray[np.float64], lamp: NDArray[np.float64],
                      directions: NDArray[np.float64]) -> Diffraction:
    """Directional derivatives of the kernel (see :func:`diffraction_along`). Vector fields are
    kept as three (m, k) component arrays: contiguous, so every step is one pass of numpy."""
    dp, dn, dl = directions[0:3], directions[3:6], directions[6:9]  # (3, k) each
    x = out.points
    # t = (n·P)/(n·d): ∂t = (n·∂P + (P − X)·∂n)/(n·d); ∂X = d ∂t
    dt = ((n @ dp)[None, :] + (centre[None, :] - x) @ dn) / denom[:, None]
    dx = [d[:, i, None] * dt for i in range(3)]
    # radial ρ = X − P (X is on the plane), r = |ρ|, r̂ = ρ/r
    rh = [out.radial[:, i, None] for i in range(3)]
    drho = [dx[i] - dp[i][None, :] for i in range(3)]
    dr = rh[0] * drho[0] + rh[1] * drho[1] + rh[2] * drho[2]
    inv_r = 1.0 / np.maximum(out.radius, 1e-300)[:, None]
    drh = [(drho[i] - rh[i] * dr) * inv_r for i in range(3)]
    # t̂ = n × r̂: ∂t̂ = ∂n × r̂ + n × ∂r̂
    th = np.cross(n, out.radial)
    dth = [dn[1][None] * rh[2] - dn[2][None] * rh[1] + n[1] * drh[2] - n[2] * drh[1],
           dn[2][None] * rh[0] - dn[0][None] * rh[2] + n[2] * drh[0] - n[0] * drh[2],
           dn[0][None] * rh[1] - dn[1][None] * rh[0] + n[0] * drh[1] - n[1] * drh[0]]
    # ωi = q/|q|, q = L − X: ∂ωi = (∂q − ωi (ωi·∂q))/|q|
    wi = [out.to_lamp[:, i, None] for i in range(3)]
    dq = [dl[i][None, :] - dx[i] for i in range(3)]
    wdq = wi[0] * dq[0] + wi[1] * dq[1] + wi[2] * dq[2]
    inv_q = 1.0 / np.sqrt(np.maximum(out.lamp_dist2, 1e-300))[:, None]
    dwi = [(dq[i] - wi[i] * wdq) * inv_q for i in range(3)]
    h = [wi[i] + out.view[:, i, None] for i in range(3)]
    du = sum(rh[i] * dwi[i] + h[i] * drh[i] for i in range(3))
    dv = sum(th[:, i, None] * dwi[i] + h[i] * dth[i] for i in range(3))
    # gain = (1 + ωi·ωo)² / (cos θo w²) · ref/|q|² (w = cos θi + cos θo, ref = |L − P|²)
    dci = sum(n[i] * dwi[i] for i in range(3)) + out.to_lamp @ dn
    dco = out.view @ dn
    ddot = sum(out.view[:, i, None] * dwi[i] for i in range(3))
    ref_vec = lamp - centre
    ref = float(ref_vec @ ref_vec)
    dref = 2.0 * (ref_vec @ (dl - dp))
    ddist2 = 2.0 * sum((lamp[i] - x[:, i, None]) * dq[i] for i in range(3))
    ci = np.clip(out.cos_i, COS_EPS, 1.0)
    co = np.clip(out.cos_o, COS_EPS, 1.0)
    live = (out.cos_i > COS_EPS) & (out.cos_o > COS_EPS)
    w = (ci + co)[:, None]
    one = np.maximum(1.0 + out.dot_io, 1e-300)[:, None]
    dlog = (2.0 * ddot / one - dco / co[:, None] - 2.0 * (dci + dco) / w + dref[None, :] / max(ref, 1e-300)
            - ddist2 / np.maximum(out.lamp_dist2, 1e-300)[:, None])
    dgain = np.where(live[:, None], out.gain[:, None] * dlog, 0.0)
    return replace(out, derivatives=Derivatives(u=du, v=dv, gain=dgain, radius=dr))
