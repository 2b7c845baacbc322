"""The names of the shipped capture presets, and which one a photo is read as by default.

A module of its own, apart from :mod:`.capture` (which loads and checks the geometry), so that
the add-on's menus get their default at enable without importing the geometry code.
"""

from __future__ import annotations

__all__ = ["NEAR_AXIS_PRESET", "OBLIQUE_PRESET", "DISTANT_LAMP_PRESET", "SETUP_PRESETS", "DEFAULT_PRESET",
           "REFERENCE_PRESET", "FAR_LIGHT_PRESET", "PAPER_PRESET"]

# The shipped presets a person can build (their files carry a "setup" section; designed by
# tools/design_setups.py), and the reference geometries the training renders besides.
NEAR_AXIS_PRESET = "phone-near-axis"
OBLIQUE_PRESET = "tripod-oblique"
DISTANT_LAMP_PRESET = "phone-distant-lamp"
SETUP_PRESETS = (NEAR_AXIS_PRESET, OBLIQUE_PRESET, DISTANT_LAMP_PRESET)
# The capture a photo is read as unless the user picks another preset (the CLI, the add-on, the
# estimate API, the calibration shot, the planner's and measured presets' base, the demo photo):
# a set-up a person can build — the phone over the disc with a pinhole card beside its lens.
DEFAULT_PRESET = NEAR_AXIS_PRESET
# The reference geometry of the evaluation tables (bench/*.md, the model card): camera 210 mm
# above the disc, lamp on the lens axis. It cannot be built (a coaxial lamp needs a beam
# splitter); every evaluation, training, reliability and bench script that means "the tables'
# geometry" names this, so their figures keep their meaning whatever the default is.
REFERENCE_PRESET = "cd-default"
FAR_LIGHT_PRESET = "cd-far-light"
PAPER_PRESET = "paper"
