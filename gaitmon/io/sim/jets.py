"""Values carried with their first two time derivatives (``Jet``), and the curves of the
simulated gait built from them: Fourier series, C1 ramps, the stop bump, the swing window.

Every quantity of ``gaitmon.io.sim.kinematics`` is a jet, so rates and linear accelerations are
analytic, not numerical; a jet of the phase itself (d = 1, dd = 0) gives derivatives w.r.t.
the phase instead.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Jet(NamedTuple):
    """A value with its first and second derivative with respect to time (arrays)."""

    v: np.ndarray
    d: np.ndarray
    dd: np.ndarray

    def __add__(self, o: Jet | float) -> Jet:  # type: ignore[override]
        if isinstance(o, Jet):
            return Jet(self.v + o.v, self.d + o.d, self.dd + o.dd)
        return Jet(self.v + o, self.d, self.dd)

    def __sub__(self, o: Jet | float) -> Jet:
        if isinstance(o, Jet):
            return Jet(self.v - o.v, self.d - o.d, self.dd - o.dd)
        return Jet(self.v - o, self.d, self.dd)

    def __mul__(self, o: Jet | float) -> Jet:  # type: ignore[override]
        if isinstance(o, Jet):
            return Jet(
                self.v * o.v,
                self.d * o.v + self.v * o.d,
                self.dd * o.v + 2.0 * self.d * o.d + self.v * o.dd,
            )
        return Jet(self.v * o, self.d * o, self.dd * o)

    # a method, not ``__rmul__ = __mul__``: NamedTuple bodies may only hold fields and methods
    def __rmul__(self, o: Jet | float) -> Jet:  # type: ignore[override]  # tuple: repeat by int
        return self.__mul__(o)

    def compose(self, f: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> Jet:
        """Chain rule: given f, f', f'' evaluated at self.v, return the jet of f(self)."""
        return Jet(f, f1 * self.d, f2 * self.d**2 + f1 * self.dd)

    def sin(self) -> Jet:
        s, c = np.sin(self.v), np.cos(self.v)
        return self.compose(s, c, -s)

    def cos(self) -> Jet:
        s, c = np.sin(self.v), np.cos(self.v)
        return self.compose(c, -s, -c)


# (a0, (a1 .. an), (b1 .. bn)) of a Fourier series with period 1
FourierCoeffs = tuple[float, tuple[float, ...], tuple[float, ...]]


def fourier_series(
    coeffs: FourierCoeffs, q: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Value and first two derivatives (w.r.t. q) of a Fourier series with period 1."""
    a0, a, b = coeffs
    q = np.asarray(q, dtype=np.float64)
    z1 = np.exp(2j * np.pi * q)
    zk = np.ones_like(z1)
    f = np.full(q.shape, a0, dtype=np.float64)
    f1 = np.zeros(q.shape)
    f2 = np.zeros(q.shape)
    for k, (ak, bk) in enumerate(zip(a, b, strict=True), start=1):
        zk = zk * z1
        c, s = zk.real, zk.imag
        w = 2.0 * np.pi * k
        f += ak * c + bk * s
        f1 += w * (-ak * s + bk * c)
        f2 += -(w**2) * (ak * c + bk * s)
    return f, f1, f2


def _smoothstep(u: np.ndarray, width: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """C1 ramp 0 -> 1 over u in [0, width]: value and derivatives w.r.t. u."""
    x = np.clip(u / width, 0.0, 1.0)
    inside = (u > 0) & (u < width)
    f = x * x * (3.0 - 2.0 * x)
    f1 = np.where(inside, 6.0 * x * (1.0 - x) / width, 0.0)
    f2 = np.where(inside, (6.0 - 12.0 * x) / width**2, 0.0)
    return f, f1, f2


def _ramp_integral(u: np.ndarray, width: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integral of ``_smoothstep`` from 0 to u, and its first two derivatives (the ramp)."""
    x = np.clip(u / width, 0.0, 1.0)
    f = np.where(u >= width, 0.5 * width + (u - width), width * (x**3 - 0.5 * x**4))
    f = np.where(u <= 0, 0.0, f)
    ramp, ramp1, _ = _smoothstep(u, width)
    return f, ramp, ramp1


def _stop_bump(
    u: np.ndarray, width: float
) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """A stop at u = 0 (u: phase from the stop): the walking envelope loses
    1 - smoothstep(|u|) (ramp out before, ramp in after), and the distance walked loses that
    bump's integral from -inf (0 before, width after). Values and derivatives w.r.t. u."""
    a = np.abs(u)
    sign = np.where(u < 0, -1.0, 1.0)
    f, f1, f2 = _smoothstep(a, width)
    r, _, _ = _ramp_integral(a, width)
    bump = (1.0 - f, -f1 * sign, -f2)
    dist = (0.5 * width + u - sign * r, 1.0 - f, -f1 * sign)
    return bump, dist


def _swing_window(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Raised-cosine window over the swing part of the cycle (q in [0.5, 1.0]), peak at 0.75."""
    a, b = 0.5, 1.0
    w = 2.0 * np.pi / (b - a)
    inside = (q >= a) & (q < b)
    x = q - a
    f = np.where(inside, 0.5 * (1.0 - np.cos(w * x)), 0.0)
    f1 = np.where(inside, 0.5 * w * np.sin(w * x), 0.0)
    f2 = np.where(inside, 0.5 * w * w * np.cos(w * x), 0.0)
    return f, f1, f2


def _cos_jet(p: Jet, q: np.ndarray, w: float, q0: float) -> Jet:
    """Jet of cos(w (q - q0)) where q is the cycle phase of the phase jet p."""
    c, s = np.cos(w * (q - q0)), np.sin(w * (q - q0))
    return p.compose(c, -w * s, -w * w * c)
