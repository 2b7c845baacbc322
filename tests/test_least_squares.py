"""The core's one least-squares solver and its valley step, on problems with known minima."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.numerics.least_squares import levenberg_marquardt, valley_step


def _rosenbrock(scale: float):
    """Residuals of Rosenbrock's banana, (1 − x, scale·(y − x²)): minimum 0 at (1, 1) at the end
    of a long, curved, flat-bottomed valley — the shape a pose fit's camera/lamp trade makes."""
    def residuals(p):
        return np.array([1.0 - p[0], scale * (p[1] - p[0] ** 2)])

    def jacobian(p):
        return np.array([[-1.0, 0.0], [-2.0 * scale * p[0], scale]])

    return residuals, jacobian


def test_levenberg_marquardt_reaches_the_minimum_of_a_linear_problem():
    a = np.array([[2.0, 0.0], [1.0, 3.0], [0.0, 1.0]])
    b = np.array([1.0, 2.0, 3.0])
    x, cost, _ = levenberg_marquardt(lambda x: a @ x - b, np.zeros(2), jacobian=lambda x: a, tol=1e-12)
    np.testing.assert_allclose(x, np.linalg.lstsq(a, b, rcond=None)[0], atol=1e-8)


def test_a_valley_step_moves_an_early_stopped_fit_down_the_valley():
    """On a steep banana LM creeps along the valley with small relative gains and its tolerance
    stops it far from the minimum (as a pose fit's stage stopped in the camera/lamp trade); the
    valley step and LM again reach a lower cost than LM run again from where it stopped."""
    residuals, jacobian = _rosenbrock(30.0)
    x, cost, _ = levenberg_marquardt(residuals, np.array([-1.2, 1.0]), jacobian=jacobian, tol=0.1)
    assert cost > 1.0  # stopped in the valley, far from its bottom
    y = valley_step(lambda p: float(residuals(p) @ residuals(p)), x, cost, jacobian(x), 0.25, 4.0, 1e-3)
    assert y is not None
    assert float(residuals(y) @ residuals(y)) < cost
    x2, cost2, _ = levenberg_marquardt(residuals, y, jacobian=jacobian, tol=0.1)
    _, alone, _ = levenberg_marquardt(residuals, x, jacobian=jacobian, tol=0.1)
    assert cost2 < 0.9 * alone and np.hypot(*(x2 - 1.0)) < np.hypot(*(x - 1.0))


def test_no_valley_step_at_a_minimum():
    residuals, jacobian = _rosenbrock(10.0)
    x = np.array([1.0, 1.0])
    assert valley_step(lambda p: float(residuals(p) @ residuals(p)), x, 0.0, jacobian(x), 0.5, 4.0, 1e-3) is None


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1e3, 1e3), min_size=6, max_size=6), st.floats(1e-3, 10.0))
def test_a_valley_step_never_returns_a_point_that_is_not_lower(values, step):
    """Any Jacobian (singular, zero, huge): a step is either None or strictly lower than the fit."""
    jac = np.array(values).reshape(3, 2)
    target = np.array([0.3, -0.7])
    cost = lambda p: float(np.sum((p - target) ** 2))  # noqa: E731
    x = np.zeros(2)
    y = valley_step(cost, x, cost(x), jac, step, 4.0, 1e-3)
    assert y is None or (np.all(np.isfinite(y)) and cost(y) < cost(x))
