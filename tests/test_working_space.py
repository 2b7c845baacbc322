"""Light colours in the file's working colour space (Blender 5: Rec.709, Rec.2020, ACEScg).

Blender 4.x has no working-space setting (always Linear Rec.709); Blender 5 stores one per file
(``bpy.data.colorspace``). A light made in an ACEScg file must, read back through ACEScg's
primaries and white, give the SPD's chromaticity by colour-science.
"""
# ruff: noqa: F811

from __future__ import annotations

import types

import numpy as np
import pytest

from extension_support import (  # noqa: F401  (pytest fixtures)
    Installed,
    addon,
    blackbody_spd,
    fake_estimate,
    installed_addon,
)

import bpy  # noqa: E402
import colour  # noqa: E402

pytestmark = pytest.mark.blender

HAS_WORKING_SPACE = hasattr(bpy.data, "colorspace") and hasattr(bpy.data.colorspace, "working_space")
needs_blender5 = pytest.mark.skipif(not HAS_WORKING_SPACE, reason="Blender 4.x has no per-file working space")

# Blender's working-space name → colour-science's colourspace; Blender's XYZ is D65-referred.
SPACES = {"Linear Rec.709": "ITU-R BT.709", "Linear Rec.2020": "ITU-R BT.2020", "ACEScg": "ACEScg"}
D65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]


def _xy_reference(spd: list[float]) -> np.ndarray:
    wl = np.arange(380.0, 781.0, 5.0)
    shape = colour.SpectralShape(380, 780, 1)
    sd = colour.SpectralDistribution(dict(zip(wl, spd))).interpolate(shape, interpolator=colour.LinearInterpolator)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().trim(shape)
    return colour.XYZ_to_xy(colour.sd_to_XYZ(sd, cmfs=cmfs, method="Integration"))


def _spds() -> dict[str, list[float]]:
    wl = np.arange(380.0, 781.0, 5.0)
    out = {f"blackbody {t:.0f} K": blackbody_spd(t) for t in (2200.0, 4000.0, 9000.0)}
    for name in ("A", "FL11"):
        sd = colour.SDS_ILLUMINANTS[name]
        values = np.interp(wl, sd.wavelengths, sd.values)
        out[f"CIE {name}"] = list(values / values.max())
    return out


@pytest.fixture
def working_space():
    """Set the file's working space for one test and put the default back."""
    def set_space(name: str) -> None:  # the property is read-only: Blender's own operator sets it
        if bpy.data.colorspace.working_space != name:  # setting the current one is CANCELLED
            assert bpy.ops.wm.set_working_color_space(working_space=name, convert_colors=False) == {"FINISHED"}
        assert bpy.data.colorspace.working_space == name

    yield set_space
    if HAS_WORKING_SPACE and bpy.data.colorspace.working_space != "Linear Rec.709":
        bpy.ops.wm.set_working_color_space(working_space="Linear Rec.709", convert_colors=False)


def _state(addon: Installed):
    return addon.sub("cd_spectra_addon.blender.state")


def test_blender4_or_default_file_is_rec709(addon: Installed) -> None:
    assert _state(addon).working_space_and_warning() == ("Linear Rec.709", None)


@needs_blender5
@pytest.mark.parametrize("space", list(SPACES))
@pytest.mark.parametrize("name", list(_spds()))
def test_light_colour_in_the_files_space_matches_colour_science(addon: Installed, working_space, space: str,
                                                                name: str) -> None:
    spd = _spds()[name]
    working_space(space)
    assert _state(addon).working_space() == space
    _state(addon).store_estimate(bpy.context.scene.cd_spectra, fake_estimate(spd))
    assert bpy.ops.cd_spectra.create_light(light_type="POINT") == {"FINISHED"}
    light = bpy.context.object.data
    assert light["cd_spectra_working_space"] == space
    rgb = np.array(light.color, dtype=np.float64)
    assert max(rgb) == pytest.approx(1.0) and min(rgb) >= 0.0
    # Back to D65-referred XYZ through colour-science's space (Bradford from ACES white to D65).
    xyz = colour.RGB_to_XYZ(rgb, SPACES[space], illuminant=D65, chromatic_adaptation_transform="Bradford")
    assert colour.XYZ_to_xy(xyz) == pytest.approx(_xy_reference(spd), abs=2e-4)


@needs_blender5
def test_the_same_lamp_differs_between_spaces(addon: Installed, working_space) -> None:
    """ACEScg's wider primaries give a 2200 K lamp a less saturated triple than Rec.709's."""
    spd = blackbody_spd(2200.0)
    colours = {}
    for space in SPACES:
        working_space(space)
        _state(addon).store_estimate(bpy.context.scene.cd_spectra, fake_estimate(spd))
        bpy.ops.cd_spectra.create_light(light_type="POINT")
        colours[space] = np.array(bpy.context.object.data.color)
    assert colours["ACEScg"][2] > colours["Linear Rec.709"][2]
    assert colours["Linear Rec.2020"][2] > colours["Linear Rec.709"][2]


def test_an_unknown_space_falls_back_to_rec709_with_a_warning(addon: Installed, monkeypatch) -> None:
    """A custom OCIO config: neither the interop id nor the name is known."""
    state = _state(addon)
    custom = types.SimpleNamespace(colorspace=types.SimpleNamespace(working_space="Studio Linear",
                                                                    working_space_interop_id=""))
    monkeypatch.setattr(state, "bpy", types.SimpleNamespace(data=custom))
    space, warning = state.working_space_and_warning()
    assert space == "Linear Rec.709"
    assert warning and "Studio Linear" in warning and "Linear Rec.709" in warning
    reported = []
    op = types.SimpleNamespace(report=lambda kind, text: reported.append((kind, text)))
    assert state.working_space_for(op) == "Linear Rec.709"
    assert reported == [({"WARNING"}, warning)]


def test_the_interop_id_wins_over_a_renamed_display_name(addon: Installed, monkeypatch) -> None:
    state = _state(addon)
    renamed = types.SimpleNamespace(colorspace=types.SimpleNamespace(working_space="ACES CG (studio)",
                                                                     working_space_interop_id="lin_ap1_scene"))
    monkeypatch.setattr(state, "bpy", types.SimpleNamespace(data=renamed))
    assert state.working_space_and_warning() == ("ACEScg", None)
