"""The strides' strapdown pass as a loop (:func:`stride_pass`): part of
:mod:`gaitmon.dsp.loops` (which re-exports it, and whose rules it keeps: plain Python that numba
compiles and the interpreter runs on ``memoryview`` s; ``math`` and the builtins only; no numpy
or numba imported), in a file of its own so that neither grows past its size.

It does, one stride at a time in one sweep over its samples, the operations
:class:`gaitmon.dsp.stride_integrate._Batch` does with numpy a batch of strides at a time, each
in numpy's order (the trapezoids' running sums added in order as ``np.cumsum`` adds them, the
sines and cosines the C library's, as numpy calls them), so that it gives numpy's numbers:
where numpy gathers a batch's samples into padded 2-D arrays and makes ~40 passes over them,
each with its own loop and memory traffic, this reads each stride's samples where they lie,
once (issue 28: ~3x less CPU for the stride measures' integration).
"""

from __future__ import annotations

import math
from typing import Any

Array = Any  # a numpy array (compiled) or a memoryview of one (interpreted)


def stride_pass(
    ax: Array, az: Array, gy: Array, start: Array, d: Array, c: Array, p0: Array, p1: Array,
    bias: Array, bias_c: Array, g: Array, v0: Array, v1: Array, dt: float, full: bool,
    out: Array, buf: Array,
) -> None:  # fmt: skip
    """Steps 2-4 of :mod:`gaitmon.dsp.stride_length`'s method for S strides: stride k runs
    from sample ``start[k]`` (its first anchor) of the foot board's acc x ``ax``, acc z ``az``
    and gyro ``gy`` (N,) ``d[k]`` (S,) samples to its second; per stride (S,): the mounting
    cosine ``c``, the pitch at the two anchors ``p0``, ``p1`` (at that cosine), the gyro bias
    ``bias`` (the two foot-flats' mean) and it over the cosine ``bias_c``, the local gravity
    ``g``, the forward velocity at the two anchors ``v0``, ``v1``. Writes ``out[k]`` = (forward
    displacement, clearance, pitch misfit, forward velocity misfit, upward velocity misfit);
    with ``full`` False only the last (the yaw bisection's). ``buf`` (4, max(d) + 1):
    scratch."""
    for k in range(start.shape[0]):
        a = start[k]
        n = d[k]
        fn = float(n)
        ck = c[k]
        bk = bias[k]
        # the pitch: p0 + the gyro's running trapezoids (over the cosine)
        prev = (gy[a] - bk) / ck
        run = 0.0
        buf[0, 0] = p0[k] + 0.0
        for i in range(1, n + 1):
            r = (gy[a + i] - bk) / ck
            t = 0.5 * (r + prev)
            run = t if i == 1 else run + t
            buf[0, i] = p0[k] + run * dt
            prev = r
        end = buf[0, n]
        out[k, 2] = end + bias_c[k] * fn * dt - p1[k]
        corr = end - p1[k]
        # its misfit at the second anchor spread linearly; the specific force in the world; the
        # velocities from v0 and 0
        gk = g[k]
        fprev = 0.0
        uprev = 0.0
        frun = 0.0
        urun = 0.0
        for i in range(n + 1):
            p = buf[0, i] - corr * (float(i) / fn)
            s = math.sin(p)
            co = math.cos(p)
            zc = az[a + i] / ck
            xi = ax[a + i]
            up = xi * co + zc * s - gk
            if i == 0:
                buf[1, 0] = v0[k] + 0.0
                buf[2, 0] = 0.0 + 0.0
            else:
                t = 0.5 * (up + uprev)
                urun = t if i == 1 else urun + t
                buf[2, i] = 0.0 + urun * dt
            uprev = up
            if full:
                fw = zc * co - xi * s
                if i > 0:
                    t = 0.5 * (fw + fprev)
                    frun = t if i == 1 else frun + t
                    buf[1, i] = v0[k] + frun * dt
                fprev = fw
        mu = buf[2, n] - 0.0
        out[k, 4] = mu
        if not full:
            continue
        mf = buf[1, n] - v1[k]
        out[k, 3] = mf
        # the velocities' misfits removed linearly; the displacement and the height
        fsum = 0.0
        hsum = 0.0
        vf_prev = buf[1, 0] - mf * 0.0
        vu_prev = buf[2, 0] - mu * 0.0
        buf[3, 0] = 0.0
        for i in range(1, n + 1):
            u = float(i) / fn
            vf = buf[1, i] - mf * u
            vu = buf[2, i] - mu * u
            t = 0.5 * (vf + vf_prev)
            fsum = t if i == 1 else fsum + t
            t = 0.5 * (vu + vu_prev)
            hsum = t if i == 1 else hsum + t
            buf[3, i] = hsum * dt
            vf_prev = vf
            vu_prev = vu
        out[k, 0] = fsum * dt
        # the clearance: the highest point with the height at the second anchor removed
        # linearly (NaN if any is, as np.max)
        hn = buf[3, n]
        top = -math.inf
        for i in range(n + 1):
            h = buf[3, i] - hn * (float(i) / fn)
            if top == top and (h != h or h > top):
                top = h
        out[k, 1] = top
