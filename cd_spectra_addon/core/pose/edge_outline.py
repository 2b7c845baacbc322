"""A dark disc's outline on a lit surround, from edges: what the moments of a bright mask
(:mod:`.rim_ellipse`) cannot see.

In the one public series of real CD photos (Kim 2023) the disc is dark on a lit optical
breadboard: holes, objects and a light pool's edge around it, and a surround that turns dark on
the far side, where the disc is brighter than it — so no threshold separates disc from surround
and no mask is elliptic. An outline is still there, in pieces: edges that run along one ellipse.

So: edges of the log luminance (thin, with their direction; none next to a coloured pixel, the
rainbow's), linked into smooth segments (neighbours whose edge directions agree) and cut into
pieces where they turn by 45° (a rim arc running into a table's edge through a rounded corner);
an ellipse through each long piece and each pair (Halir & Flusser's ellipse-specific least
squares), kept where the ring just outside it is clearly brighter than the band just inside
along a quarter of the rim (a dark disc on a lit surround; where the surround is dark the disc
may be the brighter one, as in Kim's frames); each scored by the share of its perimeter that
pieces lying mostly on it support (not the clutter that crosses it). The best are refitted to
their supporting edges and accepted where those cover a third of the perimeter in arcs that pin
the ellipse down — one long arc, or two with no gap over half the rim between them: one arc and
a stray piece (a hub's ring, a table's edge) fit many ellipses, and gave wrong ones on Kim's dim
frames before that rule. Of those, the outline most candidates were refined to.

Two rainbow streaks on black hold no ellipse with a lit ring around a dark inside; a lit table
with holes and no disc holds none with a dark inside. On Kim's ``cd1.gif`` the outline is found
in the clearly lit frames 29, 30, 32 and 33 (the same ellipse within 1–2 %) and refused in the
rest; the thresholds were chosen on those frames and on rendered tables (tests/test_disc_outline.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["EdgeEllipse", "dark_disc_outline", "fit_ellipse", "conic_ellipse"]

EDGE_MIN = 0.06  # log-luminance step per work pixel (after smoothing) that counts as an edge
LINK_DEG = 22.5  # neighbouring edge pixels whose directions differ less belong to one segment
MIN_SEGMENT = 12  # edge pixels
LONGEST = 60  # segments paired with each other
ON_PX = 1.0  # an edge point this close to an ellipse (work pixels) ...
ON_DEG = 15.0  # ... with its direction this close to the normal supports it
BINS = 120  # perimeter coverage is counted in this many sectors
MIN_COVERAGE = 0.33  # of the perimeter supported by edges (Kim: clear outlines 0.35–0.45, chance ones ≤ 0.3)
MIN_MINOR = 0.08  # of the image's short side
MIN_AREA = 0.08  # of the image the disc must cover (a smaller disc is read through a window that it fills)
MIN_RATIO = 0.3  # minor / major: the disc turned by at most ~72°
DARK_RATIO = 1.6  # the ring around the disc at least this much brighter than the disc inside the rim ...
MIN_DARK_RIM = 0.25  # ... along this share of the rim
COLOUR_CHROMA = 0.5  # (max − min) / max of a pixel's channels: coloured
COLOUR_PAD = 3  # work pixels around coloured ones whose edges are left out
PIECE_DEG = 45.0  # segments are cut into pieces whose edge directions span at most this much
REFINED = 64  # best-supported candidates refitted to all their edge points
SAME = 0.04  # of the major semi-axis: candidates this close (centre, semi-axes) agree
PIECE_ON = 0.6  # a piece supports an ellipse where this share of its points lie on it
ARC_GAP = 3  # sectors: a supported arc may skip this many
ARC_MIN = 0.08  # of the perimeter (~29°): an arc that counts
ARC_ALONE = 0.6  # of the perimeter: an arc that pins the ellipse down alone
REFITS = 3


@dataclass(frozen=True)
class EdgeEllipse:
    centre: tuple[float, float]  # (row, col), work pixels
    major: float
    minor: float
    angle: float  # of the major axis, radians from +x (columns) towards −y (up)
    coverage: float  # share of the perimeter supported by edges


def _smooth(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Binomial [1 4 6 4 1]/16 along both axes (edges repeated)."""
    k = (1.0, 4.0, 6.0, 4.0, 1.0)
    p = np.pad(a, ((2, 2), (0, 0)), mode="edge")
    a = sum(w * p[i: i + a.shape[0]] for i, w in enumerate(k)) / 16.0
    p = np.pad(a, ((0, 0), (2, 2)), mode="edge")
    return sum(w * p[:, i: i + a.shape[1]] for i, w in enumerate(k)) / 16.0


def _edges(ll: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.float64],
                                             NDArray[np.float64]]:
    """Thin edges (non-maximum suppression across them): rows, cols and the unit direction of
    increasing brightness (gx along columns, gy along rows)."""
    gy, gx = np.gradient(ll)
    mag = np.hypot(gx, gy)
    q = (np.round(np.arctan2(gy, gx) / (math.pi / 4)) % 4).astype(np.intp)
    dr, dc = np.array([0, 1, 1, 1]), np.array([1, 1, 0, -1])
    height, width = ll.shape
    r, c = np.mgrid[0:height, 0:width]
    padded = np.pad(mag, 1)
    ahead = padded[r + 1 + dr[q], c + 1 + dc[q]]
    behind = padded[r + 1 - dr[q], c + 1 - dc[q]]
    keep = (mag >= ahead) & (mag >= behind) & (mag > EDGE_MIN)
    keep[:2] = keep[-2:] = False
    keep[:, :2] = keep[:, -2:] = False
    rows, cols = np.nonzero(keep)
    return rows, cols, gx[keep] / mag[keep], gy[keep] / mag[keep]


def _segments(rows: NDArray[np.intp], cols: NDArray[np.intp], nx: NDArray[np.float64], ny: NDArray[np.float64],
              shape: tuple[int, int]) -> list[NDArray[np.intp]]:
    """Edge points linked into smooth segments (8-neighbours whose directions agree), longest first."""
    index = np.full(shape, -1, np.intp)
    index[rows, cols] = np.arange(rows.size)
    cos_link = math.cos(math.radians(LINK_DEG))
    label = np.full(rows.size, -1, np.intp)
    out: list[NDArray[np.intp]] = []
    height, width = shape
    for seed in range(rows.size):
        if label[seed] >= 0:
            continue
        label[seed] = seed
        stack, members = [seed], []
        while stack:
            k = stack.pop()
            members.append(k)
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = rows[k] + dr, cols[k] + dc
                    if (dr or dc) and 0 <= rr < height and 0 <= cc < width:
                        j = index[rr, cc]
                        if j >= 0 and label[j] < 0 and nx[j] * nx[k] + ny[j] * ny[k] > cos_link:
                            label[j] = seed
                            stack.append(j)
        if len(members) >= MIN_SEGMENT:
            out.append(np.asarray(members, np.intp))
    out.sort(key=len, reverse=True)
    return out


def _design(x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.stack([x * x, x * y, y * y, x, y, np.ones_like(x)], axis=-1)


def fit_ellipse(scatter: NDArray[np.float64]) -> NDArray[np.float64]:
    """Conics (a, b, c, d, e, f) of a x² + b xy + c y² + d x + e y + f = 0 fitted to points by
    Halir & Flusser's ellipse-specific least squares, from their scatter matrices DᵀD (…, 6, 6)
    of rows [x², xy, y², x, y, 1]; NaN where no ellipse fits. Batched: many fits at once."""
    s1, s2, s3 = scatter[..., :3, :3], scatter[..., :3, 3:], scatter[..., 3:, 3:]
    with np.errstate(all="ignore"):
        t = -np.linalg.solve(s3 + 1e-12 * np.eye(3), np.swapaxes(s2, -1, -2))
        m = s1 + s2 @ t
        m = np.stack([m[..., 2, :] / 2.0, -m[..., 1, :], m[..., 0, :] / 2.0], axis=-2)  # C1⁻¹ M
        _, vecs = np.linalg.eig(m)
    vecs = np.real(vecs)
    cond = 4.0 * vecs[..., 0, :] * vecs[..., 2, :] - vecs[..., 1, :] ** 2
    pick = np.argmax(np.where(np.isfinite(cond), cond, -np.inf), axis=-1)
    a1 = np.take_along_axis(vecs, pick[..., None, None].repeat(3, axis=-2), axis=-1)[..., 0]
    ok = np.take_along_axis(cond, pick[..., None], axis=-1)[..., 0] > 0
    conic = np.concatenate([a1, (t @ a1[..., None])[..., 0]], axis=-1)
    conic[~ok] = np.nan
    return conic


def conic_ellipse(conic: NDArray[np.float64]) -> tuple[float, float, float, float, float] | None:
    """(x0, y0, major, minor, angle of the major axis from +x) of an ellipse conic, else None."""
    a, b, c, d, e, f = (float(v) for v in conic)
    det = 4.0 * a * c - b * b
    if not det > 0:
        return None
    x0, y0 = (b * e - 2.0 * c * d) / det, (b * d - 2.0 * a * e) / det
    f0 = a * x0 * x0 + b * x0 * y0 + c * y0 * y0 + d * x0 + e * y0 + f
    evals, evecs = np.linalg.eigh(np.array([[a, b / 2.0], [b / 2.0, c]]))
    if not (f0 * evals[0] < 0 and f0 * evals[1] < 0):
        return None
    semi = np.sqrt(-f0 / evals)
    major = int(np.argmax(semi))
    return x0, y0, float(semi[major]), float(semi[1 - major]), math.atan2(evecs[1, major], evecs[0, major])


def _support(conics: NDArray[np.float64], x: NDArray[np.float64], y: NDArray[np.float64], nx: NDArray[np.float64],
             ny: NDArray[np.float64], scale: float) -> NDArray[np.bool_]:
    """(hypotheses, points): which edge points lie on each conic with their direction along its normal."""
    a, b, c, d, e, f = (conics[:, k, None] for k in range(6))
    value = a * x * x + b * x * y + c * y * y + d * x + e * y + f
    gx, gy = 2.0 * a * x + b * y + d, b * x + 2.0 * c * y + e
    norm = np.maximum(np.hypot(gx, gy), 1e-300)
    on = np.abs(value) / norm * scale < ON_PX
    return on & (np.abs(gx * nx + gy * ny) / norm > math.cos(math.radians(ON_DEG)))


def _sectors(on: NDArray[np.bool_], x: NDArray[np.float64], y: NDArray[np.float64],
             params: NDArray[np.float64]) -> NDArray[np.bool_]:
    """(hypotheses, BINS): which sectors of each ellipse's perimeter hold a supporting edge
    point. Sectors are equal steps of the ellipse's parameter (nearly equal lengths of its
    perimeter, where equal angles round its centre would crowd at the ends of the major axis)."""
    x0, y0, major, minor, tilt = (params[:, k, None] for k in range(5))
    dx, dy = x[None, :] - x0, y[None, :] - y0
    u = (dx * np.cos(tilt) + dy * np.sin(tilt)) / major
    v = (-dx * np.sin(tilt) + dy * np.cos(tilt)) / minor
    sector = ((np.arctan2(v, u) + math.pi) / (2.0 * math.pi) * BINS).astype(np.intp) % BINS
    hit = np.zeros((on.shape[0], BINS), bool)
    h, p = np.nonzero(on)
    hit[h, sector[h, p]] = True
    return hit


def _coverage(on: NDArray[np.bool_], x: NDArray[np.float64], y: NDArray[np.float64],
              params: NDArray[np.float64]) -> NDArray[np.float64]:
    """Share of the perimeter's sectors that hold a supporting edge point."""
    return _sectors(on, x, y, params).mean(axis=1)


def _surrounds(hit: NDArray[np.bool_]) -> bool:
    """Whether the supported sectors pin an ellipse down: arcs (runs with gaps of at most
    ARC_GAP sectors) of at least ARC_MIN of the perimeter, two of them with no gap between
    them over half of it, unless one alone covers ARC_ALONE. One arc and a stray piece (a hub's
    ring, a table's edge) fit many ellipses."""
    if hit.all():
        return True
    if not hit.any():
        return False
    seq = np.roll(hit, -int(np.argmin(hit))).astype(np.int8)  # starts empty: no run wraps round
    bounds = np.flatnonzero(np.diff(np.concatenate([[0], seq, [0]])))
    arcs: list[list[int]] = []
    for s0, e0 in zip(bounds[0::2], bounds[1::2]):
        if arcs and s0 - arcs[-1][1] <= ARC_GAP:
            arcs[-1][1] = int(e0)
        else:
            arcs.append([int(s0), int(e0)])
    if len(arcs) > 1 and BINS - arcs[-1][1] + arcs[0][0] <= ARC_GAP:  # the last arc runs on into the first
        first = arcs.pop(0)
        arcs[-1][1] = BINS + first[1]
    long = [a for a in arcs if a[1] - a[0] >= ARC_MIN * BINS]
    if any(a[1] - a[0] >= ARC_ALONE * BINS for a in long):
        return True
    if len(long) < 2:
        return False
    gaps = [b[0] - a[1] for a, b in zip(long, long[1:])] + [BINS + long[0][0] - long[-1][1]]
    return max(gaps) <= BINS // 2


_ANGLES = np.linspace(0.0, 2.0 * math.pi, 48, endpoint=False)
_BAND = [(r, t) for r in (0.8, 0.9) for t in _ANGLES]  # just inside the rim, angle by angle
_RING = [(r, t) for r in (1.1, 1.2) for t in _ANGLES]  # just outside it


def _sample(ll: NDArray[np.float64], params: NDArray[np.float64], where: list[tuple[float, float]], scale: float,
            centre: tuple[float, float]) -> NDArray[np.float64]:
    """ll at points (radius × semi-axes, parameter angle) of each ellipse (x0, y0, major, minor,
    angle rows, normalised); NaN off the image."""
    r = np.array([p[0] for p in where])
    t = np.array([p[1] for p in where])
    u, v = r * np.cos(t), r * np.sin(t)
    x0, y0, major, minor, angle = (params[:, k, None] for k in range(5))
    x = x0 + major * u * np.cos(angle) - minor * v * np.sin(angle)
    y = y0 + major * u * np.sin(angle) + minor * v * np.cos(angle)
    col = np.rint(x * scale + centre[1]).astype(np.intp)
    row = np.rint(y * scale + centre[0]).astype(np.intp)
    height, width = ll.shape
    inside = (row >= 0) & (row < height) & (col >= 0) & (col < width)
    out = np.full(row.shape, np.nan)
    out[inside] = ll[row[inside], col[inside]]
    return out


def _darker_than_ring(ll: NDArray[np.float64], params: NDArray[np.float64], scale: float,
                      centre: tuple[float, float]) -> NDArray[np.float64]:
    """Share of the rim (of 48 directions) where the ring just outside each ellipse is at least
    DARK_RATIO× brighter than the band just inside it: a dark disc on a lit surround. Where the
    surround is dark the disc may be the brighter one (Kim's frames); no such direction counts."""
    n = len(_ANGLES)
    band = _sample(ll, params, _BAND, scale, centre).reshape(len(params), len(_BAND) // n, n)
    ring = _sample(ll, params, _RING, scale, centre).reshape(len(params), len(_RING) // n, n)
    with np.errstate(invalid="ignore"):
        step = ring.mean(axis=1) - band.mean(axis=1)  # NaN off the image: not lit
        return np.mean(step > math.log(DARK_RATIO), axis=1)


def _coloured(rgb: NDArray[np.float64], lum: NDArray[np.float64], floor: float) -> NDArray[np.bool_]:
    """Pixels within COLOUR_PAD of a strongly coloured one (a rainbow): a disc's outline
    between a grey table and a grey disc is neutral."""
    top = np.max(rgb, axis=-1)
    chroma = (top - np.min(rgb, axis=-1)) / (top + floor / 3.0)
    near = chroma > COLOUR_CHROMA
    for _ in range(COLOUR_PAD):
        grown = near.copy()
        grown[1:] |= near[:-1]
        grown[:-1] |= near[1:]
        grown[:, 1:] |= near[:, :-1]
        grown[:, :-1] |= near[:, 1:]
        near = grown
    return near


def _pieces(segments: list[NDArray[np.intp]], nx: NDArray[np.float64], ny: NDArray[np.float64]
            ) -> list[NDArray[np.intp]]:
    """Segments cut where their edge direction has turned by PIECE_DEG: a rim arc that runs into
    a table's edge through a rounded corner becomes pieces of the arc and pieces of the edge."""
    out = []
    for seg in segments:
        angle = np.arctan2(ny[seg], nx[seg])
        turn = (angle - angle[0] + math.pi) % (2.0 * math.pi) - math.pi  # one segment turns < 180° here
        window = np.floor((turn - turn.min()) / math.radians(PIECE_DEG)).astype(np.intp)
        out += [seg[window == w] for w in np.unique(window) if np.count_nonzero(window == w) >= MIN_SEGMENT]
    out.sort(key=len, reverse=True)
    return out


def dark_disc_outline(rgb: NDArray[np.float64]) -> EdgeEllipse | None:
    """The outline of a disc darker than its (partly) lit surround in a linear RGB image (about
    256 px; saturated pixels already filled in), or None (see the module doc)."""
    rgb = np.maximum(np.asarray(rgb, dtype=np.float64), 0.0)
    lum = rgb[..., 0] + rgb[..., 1] + rgb[..., 2]
    height, width = lum.shape
    floor = 0.25 * float(np.median(lum)) + 1e-6 * max(float(np.max(lum)), 1e-12)
    ll = _smooth(_smooth(np.log(lum + floor)))
    rows, cols, nx, ny = _edges(ll)
    grey = ~_coloured(rgb, lum, floor)[rows, cols]  # a rainbow's edges are no outline
    rows, cols, nx, ny = rows[grey], cols[grey], nx[grey], ny[grey]
    pieces = _pieces(_segments(rows, cols, nx, ny, (height, width)), nx, ny)[:LONGEST]
    if not pieces:
        return None
    image = _Image(ll, rows, cols, nx, ny, pieces)
    scatters = np.stack([image.design[p].T @ image.design[p] for p in pieces])
    i, j = np.triu_indices(len(pieces))
    conics = fit_ellipse(scatters[i] + np.where((i != j)[:, None, None], scatters[j], 0.0))
    candidates = image.ranked(conics[np.isfinite(conics).all(axis=1)])[:REFINED]
    found = [image.refined(k) for k in candidates]
    found = [f for f in found if f is not None and f.coverage >= MIN_COVERAGE]
    return _agreed(found)


def _agreed(found: list[EdgeEllipse]) -> EdgeEllipse | None:
    """The outline most candidates were refined to, its best-supported member: a disc's rim is
    reached from many pairs of its arcs, an ellipse that clutter happens to support from few."""
    groups: list[list[EdgeEllipse]] = []
    for e in sorted(found, key=_arc_length, reverse=True):
        for group in groups:
            if _same(group[0], e):
                group.append(e)
                break
        else:
            groups.append([e])
    return max(groups, key=lambda g: (len(g), _arc_length(g[0])))[0] if groups else None


def _same(a: EdgeEllipse, b: EdgeEllipse) -> bool:
    tol = SAME * a.major
    return (math.hypot(a.centre[0] - b.centre[0], a.centre[1] - b.centre[1]) < tol
            and abs(a.major - b.major) < tol and abs(a.minor - b.minor) < tol)


def _arc_length(e: EdgeEllipse) -> float:
    """The supported length of an outline (Ramanujan's perimeter × coverage): a disc's rim seen
    in part outweighs its hub's rings seen whole."""
    a, b = e.major, e.minor
    return e.coverage * math.pi * (3.0 * (a + b) - math.sqrt((3.0 * a + b) * (a + 3.0 * b)))


class _Image:
    """Edge points of one image in normalised coordinates (centre 0, half the long side 1, y
    down like rows), and the tests every candidate ellipse passes."""

    def __init__(self, ll: NDArray[np.float64], rows: NDArray[np.intp], cols: NDArray[np.intp],
                 nx: NDArray[np.float64], ny: NDArray[np.float64], pieces: list[NDArray[np.intp]]) -> None:
        self.ll, self.nx, self.ny = ll, nx, ny
        # which piece each edge point belongs to (one-hot), for support by whole pieces
        self.member = np.zeros((rows.size, len(pieces)), np.float64)
        for k, piece in enumerate(pieces):
            self.member[piece, k] = 1.0
        self.piece_size = self.member.sum(axis=0)
        self.shape = ll.shape
        self.centre = ((ll.shape[0] - 1) / 2.0, (ll.shape[1] - 1) / 2.0)
        self.scale = max(ll.shape) / 2.0  # work pixels per normalised unit
        self.x, self.y = (cols - self.centre[1]) / self.scale, (rows - self.centre[0]) / self.scale
        self.design = _design(self.x, self.y)

    def _params(self, conics: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        shapes = [conic_ellipse(k) for k in conics]
        keep = [i for i, s in enumerate(shapes) if s is not None]
        return conics[keep], np.array([shapes[i] for i in keep]).reshape(-1, 5)

    def _accepted(self, params: NDArray[np.float64]) -> NDArray[np.bool_]:
        ok = _plausible(params, self.scale, self.centre, self.shape)
        ok[ok] = _darker_than_ring(self.ll, params[ok], self.scale, self.centre) >= MIN_DARK_RIM
        return ok

    def supported(self, conics: NDArray[np.float64]) -> NDArray[np.bool_]:
        """(conics, points): edge points on each conic whose piece lies mostly on it — a rim's
        arcs, not the clutter that crosses it."""
        on = _support(conics, self.x, self.y, self.nx, self.ny, self.scale)
        along = (on.astype(np.float64) @ self.member) >= PIECE_ON * self.piece_size
        return on & ((along.astype(np.float64) @ self.member.T) > 0)

    def coverage(self, conics: NDArray[np.float64], params: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.concatenate([
            _coverage(self.supported(conics[k: k + 128]), self.x, self.y, params[k: k + 128])
            for k in range(0, len(conics), 128)] or [np.zeros(0)])

    def ranked(self, conics: NDArray[np.float64]) -> list[NDArray[np.float64]]:
        """Acceptable conics, the best supported first."""
        conics, params = self._params(conics)
        ok = self._accepted(params)
        conics, params = conics[ok], params[ok]
        order = np.argsort(-self.coverage(conics, params), kind="stable")
        return [conics[k] for k in order]

    def refined(self, conic: NDArray[np.float64]) -> EdgeEllipse | None:
        """``conic`` refitted to every edge point that supports it, if it still passes."""
        for _ in range(REFITS):
            on = _support(conic[None], self.x, self.y, self.nx, self.ny, self.scale)[0]
            if np.count_nonzero(on) < MIN_SEGMENT:
                return None
            conic = fit_ellipse((self.design[on].T @ self.design[on])[None])[0]
            if not np.isfinite(conic).all():
                return None
        conics, params = self._params(conic[None])
        if not len(params) or not self._accepted(params)[0]:
            return None
        if not _surrounds(_sectors(self.supported(conics), self.x, self.y, params)[0]):
            return None
        x0, y0, major, minor, angle = params[0]
        s, (r0, c0) = self.scale, self.centre
        # y runs down here; Ellipse angles turn towards −y (up)
        return EdgeEllipse((y0 * s + r0, x0 * s + c0), major * s, minor * s, -angle % math.pi,
                           float(self.coverage(conics, params)[0]))


def _plausible(params: NDArray[np.float64], scale: float, centre: tuple[float, float],
               shape: tuple[int, int]) -> NDArray[np.bool_]:
    height, width = shape
    col, row = params[:, 0] * scale + centre[1], params[:, 1] * scale + centre[0]
    major, minor = params[:, 2] * scale, params[:, 3] * scale
    return ((minor >= MIN_MINOR * min(height, width)) & (minor >= MIN_RATIO * major) & (major <= max(height, width))
            & (math.pi * major * minor >= MIN_AREA * height * width)
            & (row >= 0) & (row < height) & (col >= 0) & (col < width))
