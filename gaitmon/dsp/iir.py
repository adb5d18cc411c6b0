"""Linear recursive filters in numpy alone: what the live and ``process`` paths used scipy for.

Importing scipy.signal costs ~0.8 s of CPU and scipy.linalg ~0.2 s, more than filtering a
1-min record, so the pipeline designs and runs its filters here (scipy stays the reference the
tests compare against, and the lab may keep using it):

* :func:`butter_lowpass` -- the digital Butterworth low-pass of ``scipy.signal.butter``: the
  bilinear transform of the analog prototype with the cut-off prewarped, in closed form for
  orders 1 and 2 and from the analog poles for higher orders;
* :func:`lfilter`, :func:`lfilter_zi` -- scipy's semantics (direct form II transposed, the state
  ``zi``/``zf`` scipy's, coefficients normalised by ``a[0]``);
* :class:`LinearFilter` -- the streaming form every stateful stage uses (below);
* :func:`ss2tf` -- a state-space model's transfer function, as scipy.signal.ss2tf;
* :func:`solve_discrete_are` -- the discrete algebraic Riccati equation, as scipy.linalg's.

How a long record is filtered fast without a per-sample Python loop. Time is cut into blocks of
``BLOCK`` samples counted from the filter's start. Within a block the output is the block's own
forced response (the difference equation run from a zero state, one step per sample position
for *all* blocks and channels at once) plus the free response of the state at the block's start
(``C A^j z``, a table). The start states follow block to block, ``z' = A^BLOCK z + forced end
state``: the same scheme one level up (:class:`_Chain`, groups of ``CHAIN`` blocks), so even a
long record takes a few hundred numpy operations. Every step is an element-by-element numpy
operation in a fixed order (no BLAS, whose rounding may depend on the shapes) and blocks and
groups are counted from the start, so a sample's output does not depend on how the record was
cut into calls or on how many channels share the call: any chunking gives bit-for-bit the same
output, and a channel filtered alone gives what it gives among others. The numbers differ from
scipy's sample-by-sample recursion by rounding only (~1e-15 of the signal's scale for the 4-Hz
low-pass, ~1e-13 for a 0.25-Hz one, ~1e-12 where numpy lacks extended precision for the tables;
tests). A running sum (``a = [1, -1]``, gyro integration) is
a cumulative sum, scipy's own additions exactly. Cost (CPU, this machine): 6000 x 14 values in
~3.5 ms, 65536 x 8 in ~10 ms (scipy ~3 ms, but its import costs ~0.8 s).

Compiled. Where :mod:`gaitmon.dsp.kernels` says numba's compiled loops serve this process (long
batch work; never a live block nor a short record, which import no numba), a
:class:`LinearFilter` runs scipy's own recursion instead, compiled
(:func:`gaitmon.dsp.loops.lfilter`: direct form II transposed, the channels side by side, the
state carried as scipy's ``zi``): scipy's numbers (bit for bit, tests), the same in any chunking,
~4x faster than the block form (360 000 x 8 values in ~11 ms; scipy ~21 ms). The two forms
differ by the block form's rounding above; a filter that goes over from one form to the other
hands scipy's state across (the block form then counts its blocks from there).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, overload

import numpy as np

if TYPE_CHECKING:  # annotations only: numpy.typing costs ~0.6 ms to import
    from numpy.typing import ArrayLike


# samples per block (see the module doc): long enough that the block-to-block step is rare,
# short enough that the per-position loop stays short
BLOCK = 128
# block start states stepped side by side in groups of this many blocks (see _Chain)
CHAIN = 16
# values (samples x channels) filtered side by side in one pass of the per-position loop
_GROUP_VALUES = 1 << 19
# values the free response is added to at a time (bounded temporaries)
_FREE_VALUES = 1 << 15


# --------------------------------------------------------------------------- design
def butter_lowpass(order: int, cutoff_hz: float, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) of the order-n digital Butterworth low-pass, a[0] = 1 (``signal.butter``'s).

    K = tan(pi fc / fs) is the prewarped cut-off. Order 1: b = K/(1+K) [1, 1],
    a = [1, (K-1)/(K+1)]. Order 2: with d = 1 + sqrt(2) K + K^2, b = K^2/d [1, 2, 1],
    a = [1, 2 (K^2-1)/d, (1 - sqrt(2) K + K^2)/d]. Higher orders: the analog poles
    K exp(i pi (2k + n + 1) / 2n) mapped by z = (1 + s)/(1 - s), n zeros at z = -1, gain 1 at DC.
    """
    n = int(order)
    if n != order or n < 1:
        raise ValueError(f"filter order must be a whole number of at least 1, got {order}")
    if not (fs_hz > 0 and 0 < cutoff_hz < fs_hz / 2):
        raise ValueError(
            f"cut-off {cutoff_hz} Hz must be above 0 and below the Nyquist frequency "
            f"{fs_hz / 2} Hz"
        )
    k = math.tan(math.pi * cutoff_hz / fs_hz)
    if n == 1:
        g = k / (1.0 + k)
        return np.array([g, g]), np.array([1.0, (k - 1.0) / (k + 1.0)])
    if n == 2:
        k2, r2k = k * k, math.sqrt(2.0) * k
        d = 1.0 + r2k + k2
        g = k2 / d
        a = np.array([1.0, 2.0 * (k2 - 1.0) / d, (1.0 - r2k + k2) / d])
        return np.array([g, 2.0 * g, g]), a
    s = k * np.exp(1j * np.pi * (2 * np.arange(n) + n + 1) / (2 * n))  # analog poles, left half
    a = np.poly((1.0 + s) / (1.0 - s)).real
    # the DC gain K^n / prod(1 - s) over (1 + z^-1)^n (not from the sums of the coefficients,
    # which cancel to nothing at high orders and low cut-offs)
    gain = k**n / float(np.prod(1.0 - s).real)
    return gain * np.poly(-np.ones(n)).real, a


# --------------------------------------------------------------------------- coefficients
def _normalised(b: ArrayLike, a: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """(b, a) as float arrays of one length with a[0] = 1 (scipy's normalisation)."""
    bn = np.atleast_1d(np.asarray(b, dtype=np.float64))
    an = np.atleast_1d(np.asarray(a, dtype=np.float64))
    if bn.ndim != 1 or an.ndim != 1:
        raise ValueError("the coefficients b and a must be 1-D")
    if bn.size == 0 or an.size == 0 or an[0] == 0.0:
        raise ValueError("the filter needs a nonzero a[0] and at least one b coefficient")
    if an[0] != 1.0:
        bn, an = bn / an[0], an / an[0]
    n = max(an.size, bn.size)
    return np.pad(bn, (0, n - bn.size)), np.pad(an, (0, n - an.size))


def lfilter_zi(b: ArrayLike, a: ArrayLike) -> np.ndarray:
    """The state for which the filter's output to a constant 1 is its steady state (scipy's)."""
    bn, an = _normalised(b, a)
    p = bn.size - 1
    i_minus_a = np.eye(p)
    i_minus_a[:, 0] += an[1:]  # I - companion(a)^T: companion's first row is -a[1:]
    i_minus_a[np.arange(p - 1), np.arange(1, p)] -= 1.0
    return np.linalg.solve(i_minus_a, bn[1:] - an[1:] * bn[0])


def ss2tf(
    A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike, input: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """(num (outputs, n+1), den (n+1,)) of the input ``input`` of x' = A x + B u, y = C x + D u.

    scipy.signal.ss2tf's formula: den = det(zI - A), num_k = det(zI - A + B C_k) + (D_k - 1) den.
    """
    a = np.atleast_2d(np.asarray(A, dtype=np.float64))
    b = np.atleast_2d(np.asarray(B, dtype=np.float64))
    c = np.atleast_2d(np.asarray(C, dtype=np.float64))
    d = np.atleast_2d(np.asarray(D, dtype=np.float64))
    n = a.shape[0]
    if a.shape != (n, n) or b.shape[0] != n or c.shape[1] != n or d.shape != (len(c), b.shape[1]):
        raise ValueError(f"inconsistent state-space shapes {a.shape} {b.shape} {c.shape} {d.shape}")
    if not 0 <= input < b.shape[1]:
        raise ValueError("the system does not have the input specified")
    bi, di = b[:, input : input + 1], d[:, input]
    den = np.poly(a)
    num = np.empty((c.shape[0], n + 1))
    for k in range(c.shape[0]):
        num[k] = np.poly(a - np.dot(bi, c[k : k + 1])) + (di[k] - 1.0) * den
    return num, den


# --------------------------------------------------------------------------- Riccati
def solve_discrete_are(
    a: ArrayLike, b: ArrayLike, q: ArrayLike, r: ArrayLike, *, tol: float = 1e-14,
    max_iter: int = 100,
) -> np.ndarray:
    """X with A^T X A - X - A^T X B (R + B^T X B)^-1 B^T X A + Q = 0 (scipy.linalg's DARE).

    Structure-preserving doubling (Chu, Fan & Lin 2005): with G = B R^-1 B^T, A_0 = A,
    G_0 = G, H_0 = Q, W = I + G_k H_k,

        A_k+1 = A_k W^-1 A_k,  G_k+1 = G_k + A_k W^-1 G_k A_k^T,  H_k+1 = H_k + A_k^T H_k W^-1 A_k,

    H_k -> X quadratically; stopped when a step changes H by <= ``tol`` relative to its size.
    Raises ValueError on bad shapes or a singular R (as scipy), ``np.linalg.LinAlgError`` when
    there is no stabilising solution (no convergence in ``max_iter`` doublings, a singular W,
    or closed-loop poles on or outside the unit circle).
    """
    am, bm, qm, rm = (np.atleast_2d(np.asarray(v, dtype=np.float64)) for v in (a, b, q, r))
    for name, m in (("a", am), ("q", qm), ("r", rm)):
        if m.shape[0] != m.shape[1]:
            raise ValueError(f"matrix {name} should be square")
    n = am.shape[0]
    if bm.shape[0] != n:
        raise ValueError("matrix a and b should have the same number of rows")
    if qm.shape != am.shape:
        raise ValueError("matrix a and q should have the same shape")
    if bm.shape[1] != rm.shape[0]:
        raise ValueError("matrix b and r should have the same number of cols")
    eps = np.finfo(float).eps
    for name, m in (("q", qm), ("r", rm)):
        if not np.allclose(m, m.T, rtol=0.0, atol=100 * eps * max(1.0, np.abs(m).max())):
            raise ValueError(f"matrix {name} should be symmetric")
    if np.linalg.cond(rm) > 1.0 / eps:
        raise ValueError("matrix r is numerically singular")
    eye = np.eye(n)
    ak, gk, hk = am.copy(), bm @ np.linalg.solve(rm, bm.T), qm.copy()
    for _ in range(max_iter):
        w = eye + gk @ hk
        w_a = np.linalg.solve(w, ak)  # W^-1 A_k
        w_g = np.linalg.solve(w, gk)  # W^-1 G_k
        h_new = hk + ak.T @ hk @ w_a
        gk = gk + ak @ w_g @ ak.T
        ak = ak @ w_a
        h_new = 0.5 * (h_new + h_new.T)
        gk = 0.5 * (gk + gk.T)
        if not np.all(np.isfinite(h_new)):
            raise np.linalg.LinAlgError("the Riccati iteration diverged: no finite solution")
        done = np.abs(h_new - hk).max() <= tol * max(1.0, np.abs(h_new).max())
        hk = h_new
        if done:
            break
    else:
        raise np.linalg.LinAlgError(
            f"the Riccati doubling did not converge in {max_iter} steps: no stabilising solution"
        )
    s = rm + bm.T @ hk @ bm
    closed = am - bm @ np.linalg.solve(s, bm.T @ hk @ am)
    if np.max(np.abs(np.linalg.eigvals(closed))) >= 1.0:
        raise np.linalg.LinAlgError("the Riccati solution found does not stabilise the system")
    return hk


# --------------------------------------------------------------------------- filtering
def running_sum(x: np.ndarray, start: np.ndarray) -> np.ndarray:
    """y_k = y_k-1 + x_k along axis 0 with y_-1 = ``start``: lfilter([1], [1, -1], x, zi=start)
    with scipy's additions in scipy's order (bit-for-bit), as one cumulative sum."""
    x = np.asarray(x, dtype=np.float64)
    start = np.asarray(start, dtype=np.float64)
    return np.cumsum(np.concatenate([start.reshape((1, *x.shape[1:])), x]), axis=0)[1:]

def _powers(m: np.ndarray, count: int) -> np.ndarray:
    """m^0 .. m^count (count + 1, p, p) in extended precision (round to float64 to use)."""
    ml = np.asarray(m, dtype=np.longdouble)
    out = np.empty((count + 1, *m.shape), dtype=np.longdouble)
    out[0] = np.eye(m.shape[0])
    for j in range(count):
        out[j + 1] = out[j] @ ml
    return out


def _mat_vec(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    """sum_k m[..., :, k] v[k], summed in k order, element by element (no BLAS, whose
    rounding may depend on the shapes): m (..., p, p) broadcast against v (p, ...)."""
    p = m.shape[-1]
    shape = (*m.shape[:-1], *(1,) * (v.ndim - 1))
    out = m[..., 0].reshape(shape) * v[0]
    for k in range(1, p):
        out += m[..., k].reshape(shape) * v[k]
    return out


class _Chain:
    """s_k+1 = F s_k + u_k over (p, C) states, emitting s_k before each input: the block start
    states of :class:`LinearFilter`. It is the filter's own scheme one level up: groups of
    ``CHAIN`` inputs counted from the start, each group's forced states stepped for all groups at
    once, the group start states carried from group to group; the same operations per element
    however the inputs arrive."""

    def __init__(self, f: np.ndarray, start: np.ndarray) -> None:
        """``f`` (p, p), in extended precision where it was computed so."""
        self._p = _powers(f, CHAIN).astype(np.float64)  # F^q, q = 0..CHAIN
        self._f = self._p[1]
        self._start = start.copy()  # the state at the current group's start
        self._forced = np.zeros_like(start)  # the forced state at the current position in it
        self._phase = 0

    def peek(self) -> np.ndarray:
        """The state now (what ``run`` emits next)."""
        out = _mat_vec(self._p[self._phase], self._start)
        out += self._forced
        return out

    def _step_one(self, u: np.ndarray) -> np.ndarray:
        s = self.peek()
        forced = _mat_vec(self._f, self._forced)
        forced += u
        self._forced = forced
        self._phase += 1
        if self._phase == CHAIN:
            start = _mat_vec(self._p[CHAIN], self._start)
            start += self._forced
            self._start = start
            self._forced = np.zeros_like(start)
            self._phase = 0
        return s

    def run(self, u: np.ndarray) -> np.ndarray:
        """Inputs (n, p, C) -> the states before each (n, p, C); the chain moves on n steps."""
        n = u.shape[0]
        out = np.empty_like(u)
        i = 0
        while i < n and self._phase:
            out[i] = self._step_one(u[i])
            i += 1
        m = (n - i) // CHAIN
        if m:
            # (q, p, groups, C): position q of every group side by side
            ug = np.ascontiguousarray(u[i : i + m * CHAIN].reshape(m, CHAIN, *u.shape[1:])
                                      .transpose(1, 2, 0, 3))  # fmt: skip
            forced = np.empty_like(ug)
            w = np.zeros(ug.shape[1:])
            for q in range(CHAIN):
                forced[q] = w
                w = _mat_vec(self._f, w)
                w += ug[q]
            starts = np.empty_like(w)  # (p, groups, C)
            start = self._start
            for k in range(m):
                starts[:, k] = start
                start = _mat_vec(self._p[CHAIN], start)
                start += w[:, k]
            self._start = start
            states = _mat_vec(self._p[:CHAIN], starts)  # (q, p, groups, C)
            states += forced
            out[i : i + m * CHAIN] = states.transpose(2, 0, 1, 3).reshape(m * CHAIN, *u.shape[1:])
            i += m * CHAIN
        while i < n:
            out[i] = self._step_one(u[i])
            i += 1
        return out


# the highest order the block form serves (module doc): its tables hold to 2e-13 of scale at
# order 2 down to 0.25 Hz / 100 Hz, but order 3 loses 4 digits there and order 4 all but three
BLOCK_FORM_MAX_ORDER = 2


class LinearFilter:
    """``lfilter(b, a)`` over (N, channels) blocks with its state carried from call to call.

    ``zi`` (p, channels) is scipy's state before the first sample (default zero). Any cut of
    the record into calls gives bit-for-bit the output of one call (module doc); ``state`` is
    scipy's ``zf`` after the last sample.
    """

    def __init__(self, b: ArrayLike, a: ArrayLike, channels: int, zi: ArrayLike | None = None):
        self.b, self.a = _normalised(b, a)
        p = self.b.size - 1
        self.order = p
        self.channels = int(channels)
        z0 = np.zeros((p, self.channels))
        if zi is not None:
            z0[...] = np.asarray(zi, dtype=np.float64).reshape(p, self.channels)
        self._running_sum = p == 1 and self.a[1] == -1.0 and self.b[1] == 0.0
        if p == 0 or self._running_sum:
            self._z = z0  # scipy's state itself (a running sum keeps its last output)
            return
        # the block form's tables, made on its first call (the compiled loop needs none)
        self._powers: np.ndarray | None = None
        # scipy's state (p, channels) where the block form does not hold it: before the first
        # call, and while the compiled loop runs (module doc, "Compiled")
        self._direct: np.ndarray | None = np.ascontiguousarray(z0)

    def _block_form(self, z: np.ndarray) -> None:
        """Hand the state ``z`` (scipy's) to the block form, as at the filter's start: blocks
        counted from here."""
        p = self.order
        if self._powers is None:
            # x_k+1 = A x_k + B u_k, y_k = x_k[0] + b0 u_k: the companion form scipy's state
            # follows
            comp = np.zeros((p, p))
            comp[:, 0] = -self.a[1:]
            comp[np.arange(p - 1), np.arange(1, p)] = 1.0
            powers_x = _powers(comp, BLOCK)
            self._powers = powers_x.astype(np.float64)  # A^j, j = 0..BLOCK
            self._free = np.ascontiguousarray(self._powers[:BLOCK, 0, :])  # (BLOCK, p): C A^j
            self._step_x = powers_x[BLOCK]  # A^BLOCK in extended precision
        # the block start states: s_b+1 = A^BLOCK s_b + the block's forced end state
        self._chain = _Chain(self._step_x, z)
        self._start = z  # the state at the current block's start (the chain's next output)
        self._forced = np.zeros((p, self.channels))  # the forced state within it
        self._phase = 0  # samples of the current block already filtered
        self._direct = None

    @property
    def state(self) -> np.ndarray:
        """scipy's state (p, channels) after the last sample filtered."""
        if self.order == 0 or self._running_sum:
            return self._z.copy()
        if self._direct is not None:
            return self._direct.copy()
        assert self._powers is not None
        free = np.einsum("ij,jc->ic", self._powers[self._phase], self._start)
        return free + self._forced

    def direct_state(self) -> np.ndarray:
        """scipy's state (p, channels), held by the filter from here on as its compiled form
        holds it: a compiled loop that runs scipy's recursion (:func:`gaitmon.dsp.loops.
        gravity_average`) carries it in place (orders >= 1, not a running sum)."""
        z = self.state if self._direct is None else self._direct
        self._direct = np.ascontiguousarray(z)
        return self._direct

    # ---------------------------------------------------------------- the block arithmetic
    def _forced_run(self, x: np.ndarray, y: np.ndarray, z: np.ndarray) -> None:
        """Difference equation along axis 0 of x from the forced state ``z`` (p, ...; updated
        in place), writing y, with scipy's operations in its order: y = z0 + b0 x,
        z_i = (z_i+1 + b_i+1 x) - a_i+1 y (z_p = 0). The p state rows are updated together."""
        p = self.order
        shape = (p, *(1,) * (x.ndim - 1))
        b0 = self.b[0]
        bs = self.b[1:].reshape(shape)
        as_ = self.a[1:].reshape(shape)
        bx = np.empty_like(x[0])
        t = np.empty_like(z)
        u = np.empty_like(z)
        for j in range(x.shape[0]):
            xj, yj = x[j], y[j]
            np.multiply(xj, b0, out=bx)
            np.add(z[0], bx, out=yj)
            np.multiply(bs, xj, out=t)
            np.add(t[:-1], z[1:], out=t[:-1])
            np.multiply(as_, yj, out=u)
            np.subtract(t, u, out=z)

    def _add_free(self, y: np.ndarray, rows: np.ndarray, start: np.ndarray) -> None:
        """y += sum_i rows[:, i] start[i] (C A^j z, summed in index order), in place.

        y (J, ..., C), rows (J, p), start (p, ..., C): the same operations per element whether
        J is one or many and whatever the middle axes hold; a few positions at a time, so the
        temporaries stay small."""
        shape = (-1,) + (1,) * (y.ndim - 1)
        step = max(1, _FREE_VALUES // max(1, start[0].size))
        free = np.empty((min(step, y.shape[0]), *y.shape[1:]))
        tmp = np.empty_like(free)
        for j in range(0, y.shape[0], step):
            yj = y[j : j + step]
            rj = rows[j : j + step]
            fj, tj = free[: yj.shape[0]], tmp[: yj.shape[0]]
            np.multiply(rj[:, 0].reshape(shape), start[0], out=fj)
            for i in range(1, self.order):
                np.multiply(rj[:, i].reshape(shape), start[i], out=tj)
                np.add(fj, tj, out=fj)
            np.add(yj, fj, out=yj)

    def _partial(self, x: np.ndarray, y: np.ndarray) -> None:
        """Samples within the current block (fewer than what is left of it)."""
        n = x.shape[0]
        self._forced_run(x, y, self._forced)
        self._add_free(y, self._free[self._phase : self._phase + n], self._start)
        self._phase += n
        if self._phase == BLOCK:
            self._chain.run(self._forced[None])
            self._start = self._chain.peek()
            self._forced[...] = 0.0
            self._phase = 0

    def _blocks(self, xb: np.ndarray, y: np.ndarray) -> None:
        """Whole blocks from the current block start on: xb (BLOCK, m, C), y (m, BLOCK, C)."""
        p, m, c = self.order, xb.shape[1], xb.shape[2]
        xt = np.ascontiguousarray(xb)
        yb = np.empty(xb.shape)
        forced = np.zeros((p, m, c))
        self._forced_run(xt, yb, forced)
        starts = self._chain.run(forced.transpose(1, 0, 2))  # (m, p, C)
        self._start = self._chain.peek()
        self._add_free(yb, self._free, starts.transpose(1, 0, 2))
        y[...] = yb.swapaxes(0, 1)

    def process(self, x: np.ndarray) -> np.ndarray:
        """Filter (N, channels) along axis 0; returns (N, channels)."""
        x = np.asarray(x, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.channels:
            raise ValueError(
                f"this filter carries state for {self.channels} channels, got {x.shape}"
            )
        n = x.shape[0]
        if self.order == 0:
            return x * self.b[0]
        if self._running_sum:
            y = running_sum(x * self.b[0], self._z[0])
            if n:
                self._z = y[-1:].copy()
            return y
        from gaitmon.dsp import kernels  # lazy: a command that only reads files needs none

        module = kernels.compiled_for(n, count=False)
        if module is not None:  # the compiled loop (module doc, "Compiled")
            z = self.state if self._direct is None else self._direct
            self._direct = np.ascontiguousarray(z)
            y = np.empty((n, self.channels))
            xc = np.ascontiguousarray(x)
            if not xc.flags.writeable:  # (numba compiles read-only arrays apart: not cached)
                xc = xc.copy()
            module.lfilter(self.b, self.a, xc, self._direct, y)
            return y
        if self.order > BLOCK_FORM_MAX_ORDER:
            # the companion matrix's powers of a higher order with poles near 1 (a low cut-off)
            # lose every digit (order 6 at 0.25 Hz / 100 Hz: 1e91 off scipy): scipy's
            # recursion itself, sample by sample, the channels side by side
            if self._direct is None:
                self._direct = np.ascontiguousarray(self.state)
            y = np.empty_like(x)
            if n:
                self._forced_run(x, y, self._direct)
            return y
        if self._direct is not None:
            self._block_form(self._direct)
        y = np.empty_like(x)
        i = 0
        if self._phase and n:
            i = min(n, BLOCK - self._phase)
            self._partial(x[:i], y[:i])
        c = self.channels
        # whole blocks, side by side (position j of every block is one contiguous row), a group
        # of blocks at a time so the working arrays stay in cache
        group = max(1, _GROUP_VALUES // (BLOCK * c))
        while n - i >= BLOCK:
            m = min(group, (n - i) // BLOCK)
            span = slice(i, i + m * BLOCK)
            self._blocks(x[span].reshape(m, BLOCK, c).swapaxes(0, 1), y[span].reshape(m, BLOCK, c))
            i += m * BLOCK
        if i < n:
            self._partial(x[i:], y[i:])
        return y


@overload
def lfilter(
    b: ArrayLike, a: ArrayLike, x: ArrayLike, axis: int = -1, zi: None = None
) -> np.ndarray: ...
@overload
def lfilter(
    b: ArrayLike, a: ArrayLike, x: ArrayLike, axis: int = -1, *, zi: ArrayLike
) -> tuple[np.ndarray, np.ndarray]: ...
def lfilter(
    b: ArrayLike, a: ArrayLike, x: ArrayLike, axis: int = -1, zi: ArrayLike | None = None
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """scipy.signal.lfilter for real input: y, or (y, zf) when ``zi`` is given.

    ``zi`` has the shape of x with the axis of time replaced by max(len(a), len(b)) - 1.
    """
    xa = np.asarray(x, dtype=np.float64)
    bn, _an = _normalised(b, a)
    p = bn.size - 1
    ax = axis % xa.ndim
    xt = np.moveaxis(xa, ax, 0)
    rest = xt.shape[1:]
    c = math.prod(rest)
    z0 = None
    if zi is not None:
        zia = np.asarray(zi, dtype=np.float64)
        want = (*xa.shape[:ax], p, *xa.shape[ax + 1 :])
        if zia.shape != want:
            raise ValueError(f"zi must have the shape {want}, got {zia.shape}")
        z0 = np.moveaxis(zia, ax, 0).reshape(p, c)
    f = LinearFilter(b, a, c, z0)
    y = np.moveaxis(f.process(xt.reshape(xt.shape[0], c)).reshape(xt.shape), 0, ax)
    if zi is None:
        return y
    zf = np.moveaxis(f.state.reshape((p, *rest)), 0, ax)
    return y, zf
