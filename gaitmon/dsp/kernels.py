"""Compiled inner loops (numba): the recursions that no vectorised numpy form computes well.

Only what is strictly sequential lives here: the scheduled Kalman update of the gait-aware filter
is a two-state recursion whose wrap rule depends on the state before each sample. Everything that
can be computed for a whole block at once (motion windows, gains, the gravity reference) stays in
numpy. Each kernel is compiled on its first call and cached on disk beside this module (or in the
user's cache directory where that is not writable), so later runs start at once.

numba is the dependency for this because the alternatives were measured and were slower: the same
recursion as one banded triangular system per block (BLAS ``dtbsv``) with the wrap rule applied
by predicted re-solves cost 0.09 s per recorded hour for 4 segments; this loop costs ~0.01 s.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_TWO_PI = 2.0 * math.pi


@njit(cache=True, nogil=True)
def scheduled_update(
    theta0: np.ndarray, bias0: np.ndarray, k0: np.ndarray, k1: np.ndarray, z: np.ndarray,
    w: np.ndarray, h: np.ndarray, dt_s: float, wrap: bool, theta: np.ndarray, bias: np.ndarray,
) -> None:  # fmt: skip
    """The scheduled update of S independent segments, in time order; writes ``theta``, ``bias``.

    All arrays are (N, S) float64 but ``theta0``, ``bias0`` (S,), the state before row 0. Per
    sample (paper 000's prediction and update, with the measurement z = theta + h b):

        pred = theta + (w - b) dt ;  e = z - pred - h b ;  theta = pred + K0 e ;  b = b + K1 e

    With ``wrap`` an innovation beyond +-pi is taken modulo 2 pi into [-pi, pi) (paper 000's
    wrap(z - theta-)): the accelerometer tilt jumps by a turn where the segment does not.
    """
    n, s = z.shape
    for c in range(s):
        th = theta0[c]
        b = bias0[c]
        for k in range(n):
            pred = th + (w[k, c] - b) * dt_s
            e = z[k, c] - pred - h[k, c] * b
            if wrap and abs(e) > math.pi:
                e -= _TWO_PI * math.floor(e / _TWO_PI + 0.5)
            th = pred + k0[k, c] * e
            b = b + k1[k, c] * e
            theta[k, c] = th
            bias[k, c] = b
