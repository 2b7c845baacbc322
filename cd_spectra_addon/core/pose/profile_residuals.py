"""The photo's self-consistency as a smooth function of the pose, for a least-squares fit.

``pose_fit.consistency`` bins pixels by λ₁ and explains each bin by one colour: its value only
changes when a pixel hops to the next bin, so in λ it is a staircase, and an optimiser sees
noise where it needs a slope (a Nelder–Mead fit of a tilted disc crawled along the valley and
stopped 1.5 nm off). Here the profile is piecewise linear in λ₁ — each pixel's amplitude is
shared between the two nearest nodes — so every residual moves continuously with the pose and
a Levenberg–Marquardt fit can follow its gradient. The camera's colour enters as residuals too:
a node's colour away from the camera's colour at its λ costs what the bin constraint of
``consistency`` costs (the node's weight × the squared off-colour part).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..spectra.grid import WAVELENGTHS_NM

COLOUR_BAND_NM = (400.0, 750.0)  # λ₁ where only the first order shows (as pose_fit's colour check)
SECOND_ORDER_NM = (800.0, 1140.0)  # λ₁ where only the second order of 400–570 nm shows (the third starts at 1140)
TAPER_NM = 10.0
TINY_AMPLITUDE = 1e-100  # below this the squared weights approach the denormals

__all__ = ["ProfileGrid", "profile_residuals", "solve_tridiagonal"]


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

    @classmethod
    def with_camera(cls, lo_nm: float, hi_nm: float, step_nm: float, sensitivities: NDArray[np.float64] | None,
                    blur_nm: float, colour_weight: float = 1.0) -> "ProfileGrid":
        """A grid whose nodes carry the camera's unit colour at their λ (blurred by the lobe and
        the pixel, Gaussian std ``blur_nm``) within COLOUR_BAND_NM, and at λ/2 where only the
        second order shows (SECOND_ORDER_NM); free elsewhere. Without the second order's colour
        a streak could be explained as second order with any colour (a fit 290 nm off won)."""
        grid = cls(lo_nm, hi_nm, step_nm, colour_weight=colour_weight)
        if sensitivities is not None:
            nodes = grid.nodes_nm
            first = (nodes >= COLOUR_BAND_NM[0]) & (nodes <= COLOUR_BAND_NM[1])
            second = (nodes >= SECOND_ORDER_NM[0]) & (nodes <= SECOND_ORDER_NM[1])
            lam = np.where(second, nodes / 2.0, nodes)
            blur = np.where(second, blur_nm / 2.0, blur_nm)
            s = np.maximum(np.maximum(blur, 1.0), 0.5 * step_nm)[:, None]
            kernel = np.exp(-0.5 * ((lam[:, None] - WAVELENGTHS_NM[None, :]) / s) ** 2)
            rgb = kernel @ np.asarray(sensitivities, dtype=np.float64)
            norm = np.linalg.norm(rgb, axis=1, keepdims=True)
            colour = np.divide(rgb, norm, out=np.full_like(rgb, np.nan), where=norm > 1e-12)
            colour[~(first | second)] = np.nan
            grid.colour = colour
        return grid


def solve_tridiagonal(diag: NDArray[np.float64], off: NDArray[np.float64], rhs: NDArray[np.float64]
                      ) -> NDArray[np.float64]:
    """Solve the symmetric tridiagonal system (main ``diag``, sub/super ``off``) for the three
    columns of ``rhs`` (Thomas algorithm on Python floats: for a few hundred nodes faster than any
    numpy formulation; the pose fit solves one per evaluation)."""
    n = diag.size
    d, o = diag.tolist(), off.tolist()
    r0, r1, r2 = (rhs[:, c].tolist() for c in range(3))
    cp = [0.0] * n
    prev_c = prev0 = prev1 = prev2 = 0.0
    prev_o = 0.0
    for i in range(n):
        denom = d[i] - prev_o * prev_c
        prev0 = (r0[i] - prev_o * prev0) / denom
        prev1 = (r1[i] - prev_o * prev1) / denom
        prev2 = (r2[i] - prev_o * prev2) / denom
        r0[i], r1[i], r2[i] = prev0, prev1, prev2
        if i < n - 1:
            prev_o = o[i]
            prev_c = prev_o / denom
            cp[i] = prev_c
    for i in range(n - 2, -1, -1):
        c = cp[i]
        r0[i] -= c * r0[i + 1]
        r1[i] -= c * r1[i + 1]
        r2[i] -= c * r2[i + 1]
    return np.array([r0, r1, r2]).T


def profile_residuals(values: NDArray[np.float64], lambda1_nm: NDArray[np.float64],
                      amplitude: NDArray[np.float64], grid: ProfileGrid, ridge: float = 1e-9
                      ) -> NDArray[np.float64]:
    """Residuals of I = amplitude · P(λ₁) with P piecewise linear on ``grid`` and fitted by least
    squares, then the colour residuals of P's nodes. Pixels outside the grid are left
    unexplained (their value is their residual). Flat vector in a fixed order (pixel by pixel,
    then node by node) whatever the pose, as a least-squares Jacobian needs; its squared sum is
    the energy the geometry cannot explain."""
    t = (lambda1_nm - grid.lo) / grid.step
    k0 = np.floor(t).astype(np.int64)
    inside = (k0 >= 0) & (k0 < grid.size - 1)
    k0i = np.where(inside, k0, 0)
    f = np.where(inside, t - k0, 0.0)
    a = np.where(inside, amplitude, 0.0)
    # Vanishing amplitudes scaled to peak 1: the profile absorbs the scale (prediction and colour
    # terms are unchanged), and a pose whose lobe is ~1e-155 everywhere no longer underflows the
    # pivots (the evaluation once died of a division by zero there). Only then: scaling every call
    # changes the rounding, and that alone flips an oblique test photo's fit to another start on
    # Python 3.13's numpy (disc normal 1.9° off) — the fit is on a knife's edge there.
    peak = float(np.max(a)) if a.size else 0.0
    if 0.0 < peak < TINY_AMPLITUDE:
        a = a / peak
    w0, w1 = a * (1.0 - f), a * f
    n = grid.size
    v = values
    diag = np.bincount(k0i, weights=w0 * w0, minlength=n) + np.bincount(k0i + 1, weights=w1 * w1, minlength=n)
    off = np.bincount(k0i, weights=w0 * w1, minlength=n)[: n - 1]
    rhs = np.stack([np.bincount(k0i, weights=w0 * v[:, c], minlength=n)
                    + np.bincount(k0i + 1, weights=w1 * v[:, c], minlength=n) for c in range(3)], axis=1)
    scale = float(np.max(diag)) if diag.size and np.max(diag) > 0 else 1.0
    profile = np.zeros((n, 3))
    used = np.flatnonzero(diag > 0)
    if used.size:  # nodes outside the used range hold nothing: P = 0 there, and the solve is shorter
        lo, hi = int(used[0]), int(used[-1]) + 1
        profile[lo:hi] = solve_tridiagonal(diag[lo:hi] + ridge * scale, off[lo:hi - 1], rhs[lo:hi])
    pred = w0[:, None] * profile[k0i] + w1[:, None] * profile[k0i + 1]
    out = [(v - pred).ravel()]
    if grid.colour is not None:
        c = grid.colour
        fixed = ~np.isnan(c[:, 0])
        p = profile[fixed]
        cc = c[fixed]
        off_colour = p - np.sum(p * cc, axis=1, keepdims=True) * cc
        out.append((grid.colour_weight * np.sqrt(diag[fixed])[:, None] * off_colour).ravel())
    return np.concatenate(out)
