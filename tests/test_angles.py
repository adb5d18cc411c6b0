"""``wrap_angle`` against its closed form: x - 2 pi ceil((x - pi) / (2 pi)) lies in (-pi, pi]."""

from __future__ import annotations

import numpy as np

from gaitmon.dsp.angles import TWO_PI, wrap_angle


def _closed_form(x: np.ndarray) -> np.ndarray:
    return x - TWO_PI * np.ceil((x - np.pi) / TWO_PI)


def test_wrap_angle_is_the_closed_form_on_arrays_and_boundaries() -> None:
    rng = np.random.default_rng(3)
    x = np.concatenate([
        rng.uniform(-50.0, 50.0, 5000),
        np.pi * np.arange(-9, 10),  # every odd multiple of pi is a boundary
        [0.0, -0.0, 1e-300],
    ])  # fmt: skip
    before = x.copy()
    got = wrap_angle(x)
    np.testing.assert_array_equal(x, before)  # the input is not changed
    assert np.all((got > -np.pi) & (got <= np.pi))
    np.testing.assert_allclose(got, _closed_form(x), rtol=0, atol=1e-12)
    assert got[np.flatnonzero(np.isclose(x, -np.pi))[0]] == np.pi  # -pi maps to +pi
    inside = np.array([np.nextafter(np.pi, 0.0), np.nextafter(-np.pi, 0.0), np.pi])
    np.testing.assert_array_equal(wrap_angle(inside), inside)  # already in range: unchanged
    grid = wrap_angle(x.reshape(-1, 1) * np.ones((1, 3)))  # any shape, row by row the same
    np.testing.assert_array_equal(grid, np.repeat(got[:, None], 3, axis=1))


def test_wrap_angle_of_a_scalar_is_a_scalar_in_range() -> None:
    assert float(wrap_angle(3 * np.pi)) == np.pi
    assert float(wrap_angle(-np.pi)) == np.pi
    assert abs(float(wrap_angle(7.0)) - (7.0 - TWO_PI)) < 1e-15
    assert np.ndim(wrap_angle(1.0)) == 0
