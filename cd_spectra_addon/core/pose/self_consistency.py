"""The photo's self-consistency as a smooth function of the pose, with its exact Jacobian.

Pixels that share λ₁ must share colour once divided by their amplitude: I = a · P(λ₁), with a
the lobe's visibility × the BRDF's gain (:mod:`..scene.kernel`) and P the λ₁ profile, piecewise
linear on a grid of nodes and fitted by least squares for every pose (a variable projection).
A wrong disc centre mixes rings of different colour in one λ₁; a wrong lamp predicts light where
the photo is dark. No spectrum is needed. The camera's colour enters as residuals too: a node's
colour away from the camera's colour at its λ costs its weight × the squared off-colour part.

Binning pixels by λ₁ (:func:`.result.consistency`) makes the cost a staircase in the pose; here
every pixel's amplitude is shared between its two nearest nodes, so every residual moves
continuously with the pose and Levenberg–Marquardt can follow its gradient. The gradient is
exact (Golub & Pereyra's derivative of a variable projection): the kernel's derivatives of u, v
and the gain give ∂a and ∂λ₁ per pixel, and one tridiagonal solve with 3 × (parameters)
right-hand sides gives how the profile moves — instead of re-evaluating every pixel once per
parameter.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..scene.capture import Disc
from ..scene.kernel import DERIVATIVE_CHUNK, Diffraction, camera_rays, diffraction_along
from ..scene.relative_pose import RelativePose
from ..spectra.grid import WAVELENGTHS_NM
from ..spectra.cameras import LAMP_SPD_FLOOR, camera_colours, lamp_light, unit_colours
from .result import COLOUR_BAND_NM

SECOND_ORDER_NM = (800.0, 1140.0)  # λ₁ where only the second order of 400–570 nm shows (the third starts at 1140)
TAPER_NM = 10.0
TINY_AMPLITUDE = 1e-100  # below this the squared weights approach the denormals
RIDGE = 1e-9  # relative to the largest node weight: nodes without pixels stay defined
# First differences of the profile, penalised relative to the mean node weight: where every pixel
# of a stretch sits half-way between two nodes (a downsampled photo: few pixels per node), the
# data leave the two nodes' difference free, and the profile oscillated to ±30× its level —
# which the colour residuals then read as a colour mismatch at the true pose (tripod-oblique at
# a quarter of 768 px: cost 19.7 at the truth, 0.004 at a wrong pose). 1e-3 costs a real lamp
# line (a jump of P over one node) a thousandth of its own weight.
SMOOTH = 1e-3

__all__ = ["ProfileGrid", "profile_residuals", "profile_spd", "solve_tridiagonal", "SelfConsistency", "TINY_AMPLITUDE",
           "footprint_v_span"]


class ProfileGrid:
    """Nodes of the piecewise-linear λ₁ profile, and the camera's unit colour at each (NaN: free)."""

    def __init__(self, lo_nm: float, hi_nm: float, step_nm: float, colour: NDArray[np.float64] | None = None,
                 colour_weight: float = 1.0):
        self.colour_weight = float(colour_weight)
        self.lo = float(lo_nm)
        self.step = float(step_nm)
        self.size = int(round((hi_nm - lo_nm) / step_nm)) + 1
        self.colour = colour  # (size, 3) unit rows or NaN rows, or None

    @property
    def nodes_nm(self) -> NDArray[np.float64]:
        return self.lo + self.step * np.arange(self.size)

    @property
    def hi(self) -> float:
        return self.lo + self.step * (self.size - 1)

    def taper(self, lambda1_nm: NDArray[np.float64]) -> NDArray[np.float64]:
        """1 inside the grid, falling to 0 over its outer TAPER_NM: a bright pixel crossing the
        grid's end must not make the residuals jump."""
        return (np.clip((lambda1_nm - self.lo) / TAPER_NM, 0.0, 1.0)
                * np.clip((self.hi - lambda1_nm) / TAPER_NM, 0.0, 1.0))

    def taper_slope(self, lambda1_nm: NDArray[np.float64]) -> NDArray[np.float64]:
        """d taper / dλ₁."""
        a = (lambda1_nm - self.lo) / TAPER_NM
        b = (self.hi - lambda1_nm) / TAPER_NM
        ca, cb = np.clip(a, 0.0, 1.0), np.clip(b, 0.0, 1.0)
        return (((a > 0) & (a < 1)) * cb - ((b > 0) & (b < 1)) * ca) / TAPER_NM

    @classmethod
    def with_camera(cls, lo_nm: float, hi_nm: float, step_nm: float, sensitivities: NDArray[np.float64] | None,
                    blur_nm: float, colour_weight: float = 1.0, spd: NDArray[np.float64] | None = None
                    ) -> "ProfileGrid":
        """A grid whose nodes carry the camera's unit colour at their λ (blurred by the lobe and
        the pixel, Gaussian std ``blur_nm``) within COLOUR_BAND_NM, and at λ/2 where only the
        second order shows (SECOND_ORDER_NM); free elsewhere. Without the second order's colour
        a streak could be explained as second order with any colour (a fit 290 nm off won).
        ``spd`` (on the product grid): the lamp's light under that blur instead of a flat
        spectrum's — where the lamp's spectrum is steep within the blur (a narrow LED band, a
        line) a pixel at λ₁ gets its colour from the bright side, not from λ₁ itself."""
        grid = cls(lo_nm, hi_nm, step_nm, colour_weight=colour_weight)
        if sensitivities is not None:
            nodes = grid.nodes_nm
            first = (nodes >= COLOUR_BAND_NM[0]) & (nodes <= COLOUR_BAND_NM[1])
            second = (nodes >= SECOND_ORDER_NM[0]) & (nodes <= SECOND_ORDER_NM[1])
            lam = np.where(second, nodes / 2.0, nodes)
            blur = np.where(second, blur_nm / 2.0, blur_nm)
            colour = unit_colours(camera_colours(lam, sensitivities, np.maximum(np.maximum(blur, 1.0), 0.5 * step_nm),
                                                 spd))
            colour[~(first | second)] = np.nan
            grid.colour = colour
        return grid


# A node's lamp level is its colour over the camera's response there, squared: where the camera
# barely sees (the default profile's response is 0.3 % of its peak at 700 nm, 0.02 % at 740) a
# stray value of the profile became the lamp's "peak" and floored its every other colour, and the
# fine stage expected those wrong colours. Only nodes where the response reaches this share of
# its peak (squared: 3 % in amplitude, about 405–685 nm for the default profile) are read; the
# lamp's level is held flat beyond them, where its colour barely counts anyway. Synthetic spectra
# of the training prior (24 per row, scratch dev runs; MAE 400–700 / Δu'v' / λ₁ error before →
# after): phone-distant-lamp nominal 0.0263 / 0.0017 / 0.59 nm → 0.0248 / 0.0011 / 0.37, on a lit
# table 0.0291 / 0.0019 / 0.48 → 0.0283 / 0.0016 / 0.36, tripod-oblique combined 0.0201 / 0.0011
# / 0.42 → 0.0200 / 0.0008 / 0.26; the near-axis rows unchanged.
SEEN_RESPONSE = 1e-3


def profile_spd(profile: NDArray[np.float64], grid: ProfileGrid, sensitivities: NDArray[np.float64],
                blur_nm: float) -> NDArray[np.float64] | None:
    """The lamp's SPD on the product grid (peak 1 above a floor of LAMP_SPD_FLOOR, blurred by the
    lobe) as a fitted λ₁ profile shows it: each first-order node's colour projected on the camera's colour at its λ under a
    flat spectrum, the same blur as :meth:`ProfileGrid.with_camera`'s; None where it shows no
    light. What the colours of a second fit expect (``with_camera(spd=…)``)."""
    nodes = grid.nodes_nm
    first = (nodes >= COLOUR_BAND_NM[0]) & (nodes <= COLOUR_BAND_NM[1])
    if np.count_nonzero(first) < 2:
        return None
    rgb = camera_colours(nodes[first], sensitivities, max(float(blur_nm), 1.0, 0.5 * grid.step))
    norm2 = np.sum(rgb * rgb, axis=1)
    seen = norm2 >= SEEN_RESPONSE * float(np.max(norm2, initial=0.0))
    if np.count_nonzero(seen) < 2:
        return None
    level = np.sum(profile[first][seen] * rgb[seen], axis=1) / norm2[seen]
    level = np.maximum(np.nan_to_num(level, nan=0.0, posinf=0.0, neginf=0.0), 0.0)
    return lamp_light(np.interp(WAVELENGTHS_NM, nodes[first][seen], level))  # (held beyond what the camera sees)


def solve_tridiagonal(diag: NDArray[np.float64], off: NDArray[np.float64], rhs: NDArray[np.float64]
                      ) -> NDArray[np.float64]:
    """Solve the symmetric positive definite tridiagonal system (main ``diag``, sub/super
    ``off``) for the columns of ``rhs`` (n, m), by cyclic reduction: each level eliminates every
    other unknown in a few whole-array steps, so ~log₂ n numpy passes replace Thomas's n
    sequential Python steps (450 nodes: 0.25 ms instead of 2.7 ms; the pose fit solves one
    system per evaluation, and 3 × parameters columns at once for its Jacobian)."""
    n = diag.size
    rhs = np.asarray(rhs, dtype=np.float64)
    squeeze = rhs.ndim == 1
    rhs2 = rhs[:, None] if squeeze else rhs
    size = 1
    while size - 1 < n:
        size *= 2
    size -= 1  # 2^k − 1 rows: every level keeps the odd ones; padded with identity rows
    b = np.ones(size)
    b[:n] = diag
    a = np.zeros(size)  # a[i] couples row i to i − 1
    a[1:n] = off[: n - 1]
    c = np.zeros(size)  # c[i] couples row i to i + 1
    c[: n - 1] = off[: n - 1]
    d = np.zeros((size, rhs2.shape[1]))
    d[:n] = rhs2
    levels = []
    while b.size > 1:
        alpha = -a[1::2] / b[0:-1:2]
        gamma = -c[1::2] / b[2::2]
        levels.append((a, b, c, d))
        a, b, c, d = (alpha * a[0:-1:2], b[1::2] + alpha * c[0:-1:2] + gamma * a[2::2], gamma * c[2::2],
                      d[1::2] + alpha[:, None] * d[0:-1:2] + gamma[:, None] * d[2::2])
    x = d / b[:, None]
    for a, b, c, d in reversed(levels):
        full = np.empty((b.size, x.shape[1]))
        full[1::2] = x
        even = d[0::2].copy()
        even[1:] -= a[2::2][:, None] * x
        even[:-1] -= c[0:-1:2][:, None] * x
        full[0::2] = even / b[0::2][:, None]
        x = full
    return x[:n, 0] if squeeze else x[:n]


class _Fit:
    """The profile of one pose: the pixels' node weights, the normal equations and their solution."""

    def __init__(self, values: NDArray[np.float64], lambda1_nm: NDArray[np.float64], amplitude: NDArray[np.float64],
                 grid: ProfileGrid):
        t = (lambda1_nm - grid.lo) / grid.step
        k0 = np.floor(t).astype(np.int64)
        inside = (k0 >= 0) & (k0 < grid.size - 1)
        self.inside = inside
        self.k0 = np.where(inside, k0, 0)
        self.f = np.where(inside, t - k0, 0.0)
        a = np.where(inside, amplitude, 0.0)
        # Vanishing amplitudes scaled to peak 1: the profile absorbs the scale (prediction and colour
        # terms are unchanged), and a pose whose lobe is ~1e-155 everywhere no longer underflows the
        # pivots. Only then: scaling every call changes the rounding.
        peak = float(np.max(a)) if a.size else 0.0
        self.divisor = peak if 0.0 < peak < TINY_AMPLITUDE else 1.0
        a = a / self.divisor
        self.a = a
        self.w0, self.w1 = a * (1.0 - self.f), a * self.f
        n = grid.size
        k = self.k0
        self.n = n
        self.diag = np.bincount(k, weights=self.w0 * self.w0, minlength=n) + \
            np.bincount(k + 1, weights=self.w1 * self.w1, minlength=n)
        self.off = np.bincount(k, weights=self.w0 * self.w1, minlength=n)[: n - 1]
        rhs = self.spread(values)
        big = float(np.max(self.diag)) if self.diag.size and np.max(self.diag) > 0 else 1.0
        self.ridge = RIDGE * big
        used = np.flatnonzero(self.diag > 0)
        self.lo, self.hi = (int(used[0]), int(used[-1]) + 1) if used.size else (0, 0)
        self.smooth = SMOOTH * float(np.mean(self.diag[self.lo:self.hi])) if used.size else 0.0
        self.profile = self.solve(rhs)
        self.pred = self.apply(self.profile)

    def spread(self, per_pixel: NDArray[np.float64]) -> NDArray[np.float64]:
        """Wᵀ · (per pixel values, (n_px, m)) → (nodes, m)."""
        m = per_pixel.shape[1]
        idx = self.k0[:, None] * m + np.arange(m)[None, :]
        a = np.bincount(idx.ravel(), weights=(self.w0[:, None] * per_pixel).ravel(), minlength=self.n * m)
        b = np.bincount((idx + m).ravel(), weights=(self.w1[:, None] * per_pixel).ravel(), minlength=(self.n + 1) * m)
        return (a + b[: self.n * m]).reshape(self.n, m)

    def solve(self, rhs: NDArray[np.float64]) -> NDArray[np.float64]:
        """(WᵀW + smoothness + ridge)⁻¹ rhs over the nodes that hold pixels (0 elsewhere)."""
        out = np.zeros_like(rhs)
        if self.hi > self.lo:
            lo, hi = self.lo, self.hi
            diag = self.diag[lo:hi] + self.ridge + 2.0 * self.smooth
            diag[0] -= self.smooth
            diag[-1] -= self.smooth
            out[lo:hi] = solve_tridiagonal(diag, self.off[lo:hi - 1] - self.smooth, rhs[lo:hi])
        return out

    def apply(self, nodes: NDArray[np.float64]) -> NDArray[np.float64]:
        """W · (node values, (nodes, m …)) → per pixel."""
        w0 = self.w0.reshape((-1,) + (1,) * (nodes.ndim - 1))
        w1 = self.w1.reshape((-1,) + (1,) * (nodes.ndim - 1))
        return w0 * nodes[self.k0] + w1 * nodes[self.k0 + 1]


def _colour_rows(fit: _Fit, grid: ProfileGrid) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
    c = grid.colour
    fixed = ~np.isnan(c[:, 0])
    p = fit.profile[fixed]
    cc = c[fixed]
    off_colour = p - np.sum(p * cc, axis=1, keepdims=True) * cc
    return fixed, grid.colour_weight * np.sqrt(fit.diag[fixed])[:, None] * off_colour


def profile_residuals(values: NDArray[np.float64], lambda1_nm: NDArray[np.float64],
                      amplitude: NDArray[np.float64], grid: ProfileGrid) -> NDArray[np.float64]:
    """Residuals of I = amplitude · P(λ₁) with P piecewise linear on ``grid`` and fitted by least
    squares, then the colour residuals of P's nodes. Pixels outside the grid are left
    unexplained (their value is their residual). Flat vector in a fixed order (pixel by pixel,
    then node by node) whatever the pose, as a least-squares Jacobian needs; its squared sum is
    the energy the geometry cannot explain."""
    fit = _Fit(values, lambda1_nm, amplitude, grid)
    out = [(values - fit.pred).ravel()]
    if grid.colour is not None:
        out.append(_colour_rows(fit, grid)[1].ravel())
    return np.concatenate(out)


def _profile_jacobian(values: NDArray[np.float64], fit: _Fit, grid: ProfileGrid, dlam: NDArray[np.float64],
                      damp: NDArray[np.float64]) -> NDArray[np.float64]:
    """∂(profile_residuals)/∂θ given ∂λ₁ and ∂amplitude per pixel ((n, K) each): the exact
    derivative of the variable projection (the profile re-fitted at every pose)."""
    n_px, k = dlam.shape
    s = fit.divisor
    dlam = np.where(fit.inside[:, None], dlam, 0.0)
    damp = np.where(fit.inside[:, None], damp / s, 0.0)
    df = dlam / grid.step
    dw0 = damp * (1.0 - fit.f)[:, None] - fit.a[:, None] * df
    dw1 = damp * fit.f[:, None] + fit.a[:, None] * df
    p0, p1 = fit.profile[fit.k0], fit.profile[fit.k0 + 1]  # (n, 3)
    dwp = dw0[:, None, :] * p0[:, :, None] + dw1[:, None, :] * p1[:, :, None]  # (n, 3, K): ∂W·P
    resid = values - fit.pred
    # ∂P = A⁻¹(∂Wᵀ r − Wᵀ ∂W P)
    m = 3 * k
    rhs = -fit.spread(dwp.reshape(n_px, m))
    idx = fit.k0[:, None] * m + np.arange(m)[None, :]
    r_dw0 = (resid[:, :, None] * dw0[:, None, :]).reshape(n_px, m)
    r_dw1 = (resid[:, :, None] * dw1[:, None, :]).reshape(n_px, m)
    rhs += np.bincount(idx.ravel(), weights=r_dw0.ravel(), minlength=fit.n * m).reshape(fit.n, m)
    rhs += np.bincount((idx + m).ravel(), weights=r_dw1.ravel(),
                       minlength=(fit.n + 1) * m)[: fit.n * m].reshape(fit.n, m)
    dprofile = fit.solve(rhs).reshape(fit.n, 3, k)
    jac_px = -(dwp + fit.apply(dprofile))  # (n, 3, K)
    parts = [jac_px.reshape(n_px * 3, k)]
    if grid.colour is not None:
        fixed, _ = _colour_rows(fit, grid)
        c = grid.colour[fixed]
        p = fit.profile[fixed]
        dp = dprofile[fixed]  # (nf, 3, K)
        kidx = (fit.k0[:, None] * k + np.arange(k)[None, :]).ravel()
        ddiag = (np.bincount(kidx, weights=(2 * fit.w0[:, None] * dw0).ravel(), minlength=fit.n * k)
                 + np.bincount(kidx + k, weights=(2 * fit.w1[:, None] * dw1).ravel(),
                               minlength=(fit.n + 1) * k)[: fit.n * k]).reshape(fit.n, k)[fixed]
        root = np.sqrt(fit.diag[fixed])
        off = p - np.sum(p * c, axis=1, keepdims=True) * c  # (nf, 3)
        doff = dp - np.einsum("fc,fck->fk", c, dp)[:, None, :] * c[:, :, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            droot = np.where(root[:, None] > 0, ddiag / (2.0 * root[:, None]), 0.0)
        jac_c = grid.colour_weight * (droot[:, None, :] * off[:, :, None] + root[:, None, None] * doff)
        parts.append(jac_c.reshape(-1, k))
    return np.concatenate(parts, axis=0)


@dataclass(frozen=True)
class RayGeometry:
    """The kernel's answer for a fixed set of camera rays at one capture's disc and lamp: what
    that capture's glint mask, each lamp size and each stage's residuals share (the lamp's size
    only scales the lobe's visibility). Reused only for the exact same disc and lamp, so a cost
    from it is the cost the kernel would give, bit for bit."""

    centre: NDArray[np.float64]
    normal: NDArray[np.float64]
    lamp: NDArray[np.float64]
    hit: NDArray[np.bool_]  # over the rays
    geo: Diffraction  # over the hits

    @classmethod
    def of(cls, rays: NDArray[np.float64], rel: RelativePose) -> "RayGeometry":
        hit, geo = diffraction_along(rays, np.zeros(3), rel.disc_centre_mm, rel.disc_normal, rel.lamp_mm)
        return cls(np.array(rel.disc_centre_mm, dtype=np.float64), np.array(rel.disc_normal, dtype=np.float64),
                   np.array(rel.lamp_mm, dtype=np.float64), hit, geo)

    def matches(self, rel: RelativePose) -> bool:
        return bool(np.array_equal(self.centre, rel.disc_centre_mm) and np.array_equal(self.normal, rel.disc_normal)
                    and np.array_equal(self.lamp, rel.lamp_mm))

    def take(self, keep: NDArray[np.bool_]) -> "RayGeometry":
        """The same for the rays ``keep`` (a mask over the rays) only."""
        return RayGeometry(self.centre, self.normal, self.lamp, self.hit[keep],
                           self.geo.take(np.flatnonzero(keep[self.hit])))


class SelfConsistency:
    """Residuals (and their Jacobian) of a fixed pixel sample as a function of the pose.

    ``pose_of(x)`` maps parameters to a :class:`~..scene.relative_pose.RelativePose`;
    ``blur_v`` (per pixel, or one for all) widens the lobe for pixels that average a stretch
    Δv of it (a box of width Δv on a Gaussian of width σ is about a Gaussian of width
    √(σ² + Δv²/12) with its peak lowered to keep the area). Residuals are scaled by the
    sample's energy, so their squared sum is the share of it the pose cannot explain."""

    def __init__(self, values: NDArray[np.float64], rays: NDArray[np.float64], disc: Disc, grid: ProfileGrid,
                 pose_of: Callable[[NDArray[np.float64]], RelativePose], edge_mm: float,
                 blur_v: float | NDArray[np.float64] = 0.0,
                 sigma_param: int | None = None, geometry: RayGeometry | None = None,
                 subset: NDArray[np.bool_] | None = None):
        self.values = np.asarray(values, dtype=np.float64)
        self.rays = rays
        self.disc = disc
        self.grid = grid
        self.pose_of = pose_of
        self.edge_mm = max(float(edge_mm), 1e-3)
        self.blur_v2 = np.asarray(blur_v, dtype=np.float64) ** 2 / 12.0
        self.sigma_param = sigma_param
        self.norm = 1.0 / math.sqrt(max(float(np.sum(self.values ** 2)), 1e-300))
        self.evaluations = 0
        # The caller's geometry at one capture, of these rays (or of rays these are the ``subset`` of):
        # taken for these rays the first time that capture is asked for.
        self._geometry, self._subset = geometry, subset

    def _shared(self, rel: RelativePose) -> RayGeometry | None:
        """The caller's geometry for these rays where ``rel`` is its capture exactly."""
        g = self._geometry
        if g is None or not g.matches(rel):
            return None
        if self._subset is not None:
            self._geometry, self._subset = g.take(self._subset), None
        return self._geometry

    def _pixels(self, rel: RelativePose, directions: NDArray[np.float64] | None = None, part: slice = slice(None)):
        """λ₁ and amplitude of the sample's pixels (those in ``part``), and with ``directions``
        what the Jacobian needs of the kernel there."""
        shared = self._shared(rel) if directions is None and part == slice(None) else None
        if shared is not None:
            hit, geo = shared.hit, shared.geo
        else:
            hit, geo = diffraction_along(self.rays[part], np.zeros(3), rel.disc_centre_mm, rel.disc_normal,
                                         rel.lamp_mm, directions=directions)
        disc = self.disc
        sigma2 = rel.lobe_sigma ** 2
        blur_v2 = self.blur_v2[part] if self.blur_v2.ndim else self.blur_v2
        se2 = sigma2 + (blur_v2[hit] if self.blur_v2.ndim else np.full(int(hit.sum()), float(blur_v2)))
        n = hit.size
        lam = np.zeros(n)
        amp = np.zeros(n)
        lam_h = geo.lambda1_nm(disc.pitch_um)
        vis = np.exp(-(geo.v * geo.v) / (2.0 * se2)) * np.sqrt(sigma2 / se2)
        r = geo.radius
        lo_ramp = (r - disc.grating_r_min_mm) / self.edge_mm + 0.5
        hi_ramp = (disc.grating_r_max_mm - r) / self.edge_mm + 0.5
        e_lo, e_hi = np.clip(lo_ramp, 0.0, 1.0), np.clip(hi_ramp, 0.0, 1.0)
        taper = self.grid.taper(lam_h)
        amp_h = vis * geo.gain * e_lo * e_hi * taper
        lam[hit] = lam_h
        amp[hit] = amp_h
        extra = (geo, hit, vis, e_lo, e_hi, lo_ramp, hi_ramp, taper, se2, sigma2) if directions is not None else None
        return lam, amp, extra

    def _derivatives(self, rel: RelativePose, dmap: NDArray[np.float64], part: slice):
        """λ₁, amplitude and their derivatives along ``dmap``'s columns for the pixels in ``part``."""
        lam, amp, extra = self._pixels(rel, dmap[0:9], part)
        geo, hit, vis, e_lo, e_hi, lo_ramp, hi_ramp, taper, se2, sigma2 = extra
        k = dmap.shape[1]
        d = geo.derivatives
        du, dv, dgain, dr = d.u, d.v, d.gain, d.radius
        pitch_nm = self.disc.pitch_um * 1e3
        dlam_h = pitch_nm * np.sign(geo.u)[:, None] * du
        v = geo.v[:, None]
        # visibility: exp(−v²/2σe²)·σ/σe with σe² = σ² + b²
        s2 = se2[:, None]
        dlogvis = -v * dv / s2 + dmap[9][None, :] * ((v * v) * sigma2 / s2 ** 2 + (1.0 - sigma2 / s2))
        de_lo = np.where((lo_ramp > 0) & (lo_ramp < 1), 1.0 / self.edge_mm, 0.0)[:, None] * dr
        de_hi = np.where((hi_ramp > 0) & (hi_ramp < 1), -1.0 / self.edge_mm, 0.0)[:, None] * dr
        dtaper = self.grid.taper_slope(geo.lambda1_nm(self.disc.pitch_um))[:, None] * dlam_h
        base = vis * geo.gain
        damp_h = (base[:, None] * dlogvis + (vis[:, None] * dgain)) * (e_lo * e_hi * taper)[:, None] \
            + base[:, None] * (de_lo * (e_hi * taper)[:, None] + de_hi * (e_lo * taper)[:, None]
                               + dtaper * (e_lo * e_hi)[:, None])
        if hit.all():
            return lam, amp, dlam_h, damp_h
        dlam, damp = np.zeros((hit.size, k)), np.zeros((hit.size, k))
        dlam[hit] = dlam_h
        damp[hit] = damp_h
        return lam, amp, dlam, damp

    def residuals_at(self, rel: RelativePose) -> NDArray[np.float64]:
        """The photo's residuals (no prior) for the capture ``rel``."""
        self.evaluations += 1
        lam, amp, _ = self._pixels(rel)
        return profile_residuals(self.values, lam, amp, self.grid) * self.norm

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return self.residuals_at(self.pose_of(x))

    def profile_at(self, rel: RelativePose) -> NDArray[np.float64]:
        """The fitted λ₁ profile (nodes × RGB, the sample's units) of the capture ``rel``."""
        lam, amp, _ = self._pixels(rel)
        return _Fit(self.values, lam, amp, self.grid).profile

    def jacobian(self, x: NDArray[np.float64], free: NDArray[np.int64], step: float = 1e-6
                 ) -> NDArray[np.float64]:
        """∂residuals/∂x[free], exact in the pixels (kernel derivatives, variable projection);
        the parameter map to (centre, normal, lamp) by central differences of 9 numbers."""
        self.evaluations += 1
        rel = self.pose_of(x)
        k = free.size
        # ∂(P, N, L, log σ)/∂x by central differences of the pose map (tiny vectors)
        dmap = np.zeros((10, k))
        for j, p in enumerate(free):
            dx = np.zeros_like(x)
            dx[p] = step
            a, b = self.pose_of(x + dx), self.pose_of(x - dx)
            dmap[0:3, j] = (a.disc_centre_mm - b.disc_centre_mm) / (2 * step)
            dmap[3:6, j] = (a.disc_normal - b.disc_normal) / (2 * step)
            dmap[6:9, j] = (a.lamp_mm - b.lamp_mm) / (2 * step)
            dmap[9, j] = (math.log(a.lobe_sigma) - math.log(b.lobe_sigma)) / (2 * step)
        n = self.rays.shape[0]
        lam, amp = np.empty(n), np.empty(n)
        dlam, damp = np.zeros((n, k)), np.zeros((n, k))
        for a in range(0, n, DERIVATIVE_CHUNK):  # in passes that stay in the CPU's cache (see the kernel's)
            part = slice(a, a + DERIVATIVE_CHUNK)
            lam[part], amp[part], dlam[part], damp[part] = self._derivatives(rel, dmap, part)
        fit = _Fit(self.values, lam, amp, self.grid)
        return _profile_jacobian(self.values, fit, self.grid, dlam, damp) * self.norm


def footprint_v_span(rows: NDArray[np.float64], cols: NDArray[np.float64], width_px: float, size: tuple[int, int],
                     focal_px: float, rel: RelativePose) -> NDArray[np.float64]:
    """How much of the lobe's v a pixel spans: pixels centred at (rows, cols) and ``width_px``
    wide average the lobe over that stretch (:class:`SelfConsistency`'s ``blur_v``), from v at
    the footprint's edges for the capture ``rel``. A coaxial lamp's lobe barely changes across
    a pixel; a streak's crosses it in a pixel or two."""
    half = width_px / 2.0
    spans = []
    for dr, dc in ((half, 0.0), (0.0, half)):
        vs = []
        for sign in (1.0, -1.0):
            hit, geo = diffraction_along(camera_rays(rows + sign * dr, cols + sign * dc, size, focal_px), np.zeros(3),
                                         rel.disc_centre_mm, rel.disc_normal, rel.lamp_mm)
            v = np.zeros(np.size(rows))
            v[hit] = geo.v
            vs.append(v)
        spans.append(vs[0] - vs[1])
    return np.hypot(spans[0], spans[1])
