"""Side-view diagrams of the shipped capture set-ups: docs/setups/<name>.png.

    python tools/draw_setups.py [--out docs/setups] [NAME...]

Each diagram is the plane through lamp, camera and disc axis, drawn to scale from the preset
and its set-up analysis (core.setups): the disc with its data area, the camera body and lens,
the lamp (and card/housing), distances and angles from the disc axis, the first-order rays
for 400/550/700 nm, and where 400–700 nm land on the disc. A markdown table of the numbers
is printed for the README. Deterministic (same numbers, same picture).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from cd_spectra_addon.core.planning.setups import (  # noqa: E402
    NEAR_AXIS, SetUp, analyse, camera_body_box, load_setup, setup_names)

RAYS_NM = (400.0, 550.0, 700.0)
RAY_COLOURS = {400.0: "#7a3cff", 550.0: "#2fae3a", 700.0: "#e0321e"}


def _wavelength_colour(lam: float) -> tuple[float, float, float]:
    """A rough display colour for a wavelength (for the rainbow strip only)."""
    anchors = [(380, (0.4, 0.0, 0.6)), (440, (0.2, 0.0, 1.0)), (490, (0.0, 0.7, 1.0)), (510, (0.0, 1.0, 0.2)),
               (580, (1.0, 1.0, 0.0)), (645, (1.0, 0.2, 0.0)), (780, (0.5, 0.0, 0.0))]
    for (l0, c0), (l1, c1) in zip(anchors[:-1], anchors[1:]):
        if l0 <= lam <= l1:
            t = (lam - l0) / (l1 - l0)
            return tuple(a + t * (b - a) for a, b in zip(c0, c1))  # type: ignore[return-value]
    return (0.3, 0.3, 0.3)


def _box_outline(box, e: np.ndarray) -> np.ndarray:
    """The box's corners projected onto the diagram plane (s along ê, z up): a convex hull."""
    axes = np.asarray(box.axes, dtype=np.float64)  # rows = box axes
    half = np.asarray(box.size_mm) / 2.0
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    world = np.asarray(box.center_mm) + corners @ axes
    pts = np.stack([world @ e, world[:, 2]], axis=1)
    return _hull(pts)


def _hull(points: np.ndarray) -> np.ndarray:
    pts = sorted(map(tuple, np.round(points, 6)))
    if len(pts) < 3:
        return np.array(pts)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return np.array(lower[:-1] + upper[:-1])


def draw(setup: SetUp, path: Path) -> dict[str, object]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon

    report = analyse(setup, report_nm=tuple(np.arange(400.0, 701.0, 10.0)))
    e = np.asarray(report.line_direction)
    preset = setup.preset
    disc = preset.disc
    lamp = np.asarray(preset.light.position_mm)
    cam = np.asarray(preset.camera.nominal_position_mm)
    lamp2 = np.array([lamp @ e, lamp[2]])
    cam2 = np.array([cam @ e, cam[2]])

    far_lamp = np.linalg.norm(lamp) > 3.0 * max(np.linalg.norm(cam), 250.0)
    fig, ax = plt.subplots(figsize=(8.0, 6.0), dpi=110)
    # disc: hub, data area, rim
    ax.plot([-disc.rim_radius_mm, disc.rim_radius_mm], [0, 0], color="0.55", lw=3, solid_capstyle="butt")
    for sgn in (1, -1):
        ax.plot([sgn * disc.grating_r_min_mm, sgn * disc.grating_r_max_mm], [0, 0], color="0.25", lw=5,
                solid_capstyle="butt")
    ax.plot([-disc.hole_radius_mm, disc.hole_radius_mm], [0, 0], color="white", lw=5, solid_capstyle="butt")
    # rainbow strip where 400–700 nm land (unblocked, on the data area)
    for lam, where in report.positions_mm.items():
        for s in where:
            if disc.grating_r_min_mm <= abs(s) <= disc.grating_r_max_mm:
                ax.plot([s], [-4.0], marker="s", ms=4, color=_wavelength_colour(lam), mec="none")
    # camera body and other objects
    hull_top = 0.0
    for box in (camera_body_box(setup), *setup.bodies):
        hull = _box_outline(box, e)
        if not far_lamp or box.name == "camera body":
            hull_top = max(hull_top, float(hull[:, 1].max()))
        ax.add_patch(Polygon(hull, closed=True, fc="0.85" if box.name == "camera body" else "#f3e2b3",
                             ec="0.3", lw=1.0, zorder=3))
        centre = hull.mean(axis=0)
        if (not far_lamp or box.name == "camera body") and min(box.size_mm) > 20.0:
            ax.annotate(box.name, centre, fontsize=6, ha="center", va="center", zorder=4)
    ax.plot(*cam2, marker="o", color="k", ms=5, zorder=5)
    # rays: lamp → disc point → camera for 400/550/700
    shown_lamp = lamp2 if not far_lamp else _towards(lamp2, 0.0, cam2)
    xs_left = min(cam2[0], shown_lamp[0]) + 70.0
    for k, lam in enumerate(RAYS_NM):
        where = [s for s in report.positions_mm.get(lam, [])
                 if disc.grating_r_min_mm <= abs(s) <= disc.grating_r_max_mm and s * _reading_side(report) > 0]
        if not where:
            continue
        p = np.array([where[0], 0.0])
        # incoming ray along the true direction to the lamp (parallel-looking for a far lamp)
        to_lamp = (lamp2 - p) / np.linalg.norm(lamp2 - p)
        start = lamp2 if not far_lamp else p + to_lamp * (shown_lamp[1] / to_lamp[1])
        ax.plot([start[0], p[0], cam2[0]], [start[1], p[1], cam2[1]], color=RAY_COLOURS[lam], lw=0.8,
                alpha=0.9, zorder=2)
        ax.annotate(f"{lam:.0f} nm at r = {abs(p[0]):.0f} mm", (-130.0 + min(xs_left, 0.0), -8.0 - 7.0 * k),
                    fontsize=7, ha="left", va="top", color=RAY_COLOURS[lam])
    ax.plot(*shown_lamp, marker="*", color="#f0a000", ms=14, mec="k", zorder=6)
    # axis and angles
    top = max(cam2[1] * 1.08, shown_lamp[1] * 1.08, hull_top + 5.0)
    ax.plot([0, 0], [0, top], color="0.6", lw=0.8, ls="--")
    cam_angle = math.degrees(math.atan2(abs(cam2[0]), cam2[1]))
    lamp_angle = math.degrees(math.atan2(abs(lamp2[0]), lamp2[1]))
    ax.annotate(f"camera\n{np.linalg.norm(cam):.0f} mm, {cam_angle:.1f}° from axis", cam2, xytext=(8, 10),
                textcoords="offset points", fontsize=8)
    lamp_text = (f"lamp {np.linalg.norm(lamp):.0f} mm, {lamp_angle:.1f}° from axis"
                 + ("\n(direction shown; not to scale)" if far_lamp else "")
                 + f"\nsource {setup.source_size_mm:g} mm")
    ax.annotate(lamp_text, shown_lamp, xytext=(8, -26), textcoords="offset points", fontsize=8)
    ax.plot([0, cam2[0]], [0, cam2[1]], color="0.3", lw=0.6, ls=":")
    if setup.kind == NEAR_AXIS:
        ax.annotate(f"source {abs(lamp2[0] - cam2[0]):.0f} mm beside the lens", (lamp2[0], lamp2[1]),
                    xytext=(-10, 18), textcoords="offset points", fontsize=8, ha="right")
    worst = max(report.resolution_nm.values())
    covered = report.covered_nm
    ax.set_title(f"{preset.name}: {setup.kind}, first order {covered[0]:.0f}–{covered[1]:.0f} nm on the data area, "
                 f"blur ≤ {worst:.0f} nm FWHM" if covered else preset.name, fontsize=9)
    ax.set_xlabel("mm along the line through lamp, camera and disc centre")
    ax.set_ylabel("mm above the disc")
    ax.set_aspect("equal")
    xs = [cam2[0], shown_lamp[0], -70, 70]
    ax.set_xlim(min(min(xs) - 60, -135.0 + min(xs_left, 0.0)), max(xs) + 90)
    ax.set_ylim(-35, top + 30)
    ax.grid(True, lw=0.3, alpha=0.5)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, metadata={"Software": None})
    plt.close(fig)
    return {"report": report, "camera_angle": cam_angle, "lamp_angle": lamp_angle}


def _reading_side(report) -> int:
    """The half of the line that shows all of 400–700 nm (+1 when the range is split)."""
    return report.read_side or 1


def _towards(target: np.ndarray, _unused: float, cam2: np.ndarray) -> np.ndarray:
    """A far lamp drawn on its true direction from the disc centre, at 1.3× the camera's height."""
    d = target / np.linalg.norm(target)
    return d * max(cam2[1], 150.0) * 1.3 / max(d[1], 0.2)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "setups")
    parser.add_argument("names", nargs="*", help="set-up presets (default: all)")
    args = parser.parse_args(argv)
    print("| set-up | camera | lamp | 400 / 550 / 700 nm at r (mm) | on the data area | blur FWHM |")
    print("|---|---|---|---|---|---|")
    for name in args.names or setup_names():
        setup = load_setup(name)
        info = draw(setup, args.out / f"{name}.png")
        rep = info["report"]
        side = _reading_side(rep)
        at = " / ".join(f"{abs(next((s for s in rep.positions_mm[lam] if 23 <= abs(s) <= 58.5 and s * side > 0), float('nan'))):.1f}"
                        for lam in RAYS_NM)
        cam = setup.preset.camera
        print(f"| {name} | {cam.distance_mm:.0f} mm, {info['camera_angle']:.1f}° | "
              f"{np.linalg.norm(setup.preset.light.position_mm):.0f} mm, {info['lamp_angle']:.1f}°, "
              f"{setup.source_size_mm:g} mm | {at} | {rep.covered_nm[0]:.0f}–{rep.covered_nm[1]:.0f} nm | "
              f"{max(rep.resolution_nm.values()):.1f} nm |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
