"""The one check for numbers read from files and forms (presets, set-ups, the planner, model metadata)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cd_spectra_addon.core.errors import ModelError
from cd_spectra_addon.core.validation import check_number, check_numbers, is_number


@pytest.mark.parametrize("value", [0, -3, 2.5, np.float64(1.0), 1e300])
def test_finite_ints_and_floats_are_numbers(value):
    assert is_number(value) and check_number("x", value) == float(value)


@pytest.mark.parametrize("value", [True, False, None, "1", [1], math.nan, math.inf, -math.inf])
def test_bools_strings_and_non_finite_values_are_not(value):
    assert not is_number(value)
    with pytest.raises(ValueError, match=r"^x must be a finite number, not "):
        check_number("x", value)


@pytest.mark.parametrize("kwargs,value,message", [
    ({"above": 0.0}, 0, "disc.pitch_um must be a number > 0, not 0"),
    ({"at_least": 1.0}, 0.5, "disc.pitch_um must be a number ≥ 1, not 0.5"),
    ({"at_least": 0.0, "integer": True}, 1.5, "disc.pitch_um must be a whole number ≥ 0, not 1.5"),
    ({"at_least": -80.0, "at_most": 80.0, "unit": " degrees"}, 81, "disc.pitch_um must be a number between -80 and 80 "
                                                                    "degrees, not 81"),
    ({"above": 0.0}, "big", "disc.pitch_um must be a number > 0, not 'big'"),
])
def test_the_message_names_the_field_the_bounds_and_what_was_found(kwargs, value, message):
    with pytest.raises(ValueError) as info:
        check_number("disc.pitch_um", value, **kwargs)
    assert str(info.value) == message


def test_bounds_are_inclusive_or_exclusive_as_asked():
    assert check_number("x", 0, at_least=0.0) == 0.0
    assert check_number("x", 80, at_least=-80.0, at_most=80.0) == 80.0
    assert check_number("x", 3, integer=True) == 3.0 and check_number("x", 3.0, integer=True) == 3.0


def test_lists_need_their_length_and_name_the_bad_element():
    assert check_numbers("p", [1, 2.5, -3], 3) == (1.0, 2.5, -3.0)
    with pytest.raises(ValueError, match=r"^p needs 3 numbers \[x, y, z\], not \[0, 0\]$"):
        check_numbers("p", [0, 0], 3, names="[x, y, z]")
    with pytest.raises(ValueError, match=r"^p needs 2 numbers, not 'ab'$"):
        check_numbers("p", "ab", 2)
    with pytest.raises(ValueError, match=r"^p\[1\] must be a number > 0, not -1$"):
        check_numbers("p", (1, -1), 2, above=0.0)


def test_the_caller_picks_the_error_and_may_add_context():
    with pytest.raises(ModelError, match="^fusion.floor must be a number ≥ 0, not -1 — rebuild$"):
        check_number("fusion.floor", -1, at_least=0.0, error=lambda m: ModelError(f"{m} — rebuild"))
