"""Sliding-window maxima and means in numpy, with scipy.ndimage's windows and boundary modes.

``maximum_filter1d`` and ``uniform_filter1d`` gave these before; scipy's import costs more than
a 1-min record's whole processing, so they are written here with numpy alone, to the same
numbers: a window of n samples on sample i covers i - n // 2 .. i - n // 2 + n - 1 (scipy's
``origin=0``); the maximum is exact; the mean is scipy's running sum, step for step (its first
window summed in order, then each step adding (entering - leaving) / n, accumulated in order by
``np.cumsum``), so it gives scipy's bits (tests/test_windows.py).
"""

from __future__ import annotations

import numpy as np


def _pad(x: np.ndarray, left: int, right: int, mode: str, cval: float) -> np.ndarray:
    """``x`` extended along its last axis: ``mode`` "nearest" (the end samples repeated) or
    "constant" (``cval``)."""
    if mode == "nearest":
        return np.pad(x, [(0, 0)] * (x.ndim - 1) + [(left, right)], mode="edge")
    if mode == "constant":
        return np.pad(x, [(0, 0)] * (x.ndim - 1) + [(left, right)], constant_values=cval)
    raise ValueError(f"mode must be 'nearest' or 'constant', got {mode!r}")


def sliding_max(
    x: np.ndarray, size: int, *, mode: str = "nearest", cval: float = 0.0
) -> np.ndarray:
    """The maximum over a window of ``size`` samples centred on each sample, along the last
    axis (``scipy.ndimage.maximum_filter1d(x, size, mode=mode, cval=cval)``; NaN spreads over
    the windows that hold one)."""
    x = np.asarray(x, dtype=np.float64)
    if size < 1:
        raise ValueError(f"size must be at least 1, got {size}")
    n = x.shape[-1]
    if n == 0 or size == 1:
        return x.copy()
    left = size // 2
    e = _pad(x, left, size - 1 - left, mode, cval)
    # maxima over 1, 2, 4, ... samples by doubling, then two of the largest that fits
    span = 1
    m = e
    while 2 * span <= size:
        m = np.maximum(m[..., :-span], m[..., span:])
        span *= 2
    return np.maximum(m[..., :n], m[..., size - span : size - span + n])


def sliding_mean(
    x: np.ndarray, size: int, *, mode: str = "constant", cval: float = 0.0
) -> np.ndarray:
    """The mean over a window of ``size`` samples centred on each sample, along the last axis
    (``scipy.ndimage.uniform_filter1d(x, size, mode=mode, cval=cval)``, to its bits)."""
    x = np.asarray(x, dtype=np.float64)
    if size < 1:
        raise ValueError(f"size must be at least 1, got {size}")
    n = x.shape[-1]
    if n == 0:
        return x.copy()
    left = size // 2
    e = _pad(x, left, size - 1 - left, mode, cval)
    steps = np.empty(x.shape)
    steps[..., :1] = np.cumsum(e[..., :size], axis=-1)[..., -1:]  # the first window, in order
    steps[..., :1] /= size
    np.subtract(e[..., size:], e[..., : n - 1], out=steps[..., 1:])
    steps[..., 1:] /= size
    return np.cumsum(steps, axis=-1, out=steps)
