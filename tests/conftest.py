"""Shared fixtures. Blender-backed tests are marked ``blender``; everything runs in ``make test``."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(1234)
