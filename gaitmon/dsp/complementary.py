"""Paper 003's complementary tilt filter, with a fixed or an adaptive (FFT-chosen) cut-off.

Paper 003 (LAPAN, "complementary filter dengan variabel adaptif cut-off frequency"), eq. 2-1/2-2:

    theta_k = alpha (theta_{k-1} + omega_k dt) + (1 - alpha) theta_acc,k
    alpha = tau / (tau + dt),  tau = 1 / (2 pi fc)

gaitmon writes it with the prediction theta_pred = theta_{k-1} + omega_k dt and the error term
wrapped to (-pi, pi], because the accelerometer tilt atan2(...) jumps by 2 pi (SPEC section 2):

    theta_k = theta_pred + (1 - alpha) wrap(theta_acc,k - theta_pred)

which is the paper's equation whenever |theta_acc - theta_pred| < pi. The state theta is continuous
(not wrapped), like gaitmon.dsp.kalman.TiltKalman's; wrap it for display. theta_{-1} is the first
accelerometer tilt (the standing initialisation of paper 000).

Adaptive cut-off. The paper picks fc from the spectrum of the motion ("frekuensi sekitar 3 Hz ...
digunakan sebagai cutoff") and says an on-board version would refresh it every few seconds. Rule
used here (:class:`AdaptiveCutoff`), per channel:

* every ``update_s`` seconds (at sample indices that are multiples of the update period, counted
  from reset, so any chunking refreshes at the same samples), take the last ``window_s`` seconds of
  the gyro rate (the motion; it carries no gravity DC), remove its mean, apply a Hann window;
* fc = the frequency of the largest FFT magnitude at or above ``min_hz`` (refined by a parabola
  through the peak bin and its neighbours), clipped to [min_hz, max_hz];
* if the window's RMS rate is below ``rest_rms_rad_s`` there is no motion to measure and fc keeps
  its previous value; before the first full window fc is the configured ``cutoff_hz``.

A new fc applies from the refresh sample on. Note what the paper's rule implies: faster motion
gives a higher fc, i.e. a smaller alpha, i.e. *more* trust in the accelerometer.

Speed: with a fixed alpha the recursion is linear wherever the wrap does nothing, so blocks run
through a first-order :class:`gaitmon.dsp.iir.LinearFilter` (numpy alone) on the accelerometer
tilt unwrapped to stay within pi of the prediction; any sample whose error term would actually
need the wrap is taken by an exact step. Both paths give the same numbers to rounding (~1e-15
rad). The linear filter of a segment runs on from call to call (its blocks counted from where it
started: after the reset, an exact step or a new cut-off), so any chunking gives the same output.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gaitmon.dsp.angles import TWO_PI, wrap_angle
from gaitmon.dsp.filters import as_2d_pair
from gaitmon.dsp.iir import LinearFilter

# error terms this close to +-pi go through the exact (wrapped) step, not the linear path
_WRAP_MARGIN_RAD = 1e-9
# after a wrapped error term, this many exact steps before the linear path is tried again
_EXACT_STEPS = 32
# the linear path works through long inputs in pieces (bounds the work redone after a wrap)
_LINEAR_BLOCK = 16384


def complementary_alpha(cutoff_hz: float | np.ndarray, dt_s: float) -> np.ndarray:
    """alpha = tau / (tau + dt) with tau = 1 / (2 pi fc) (paper 003 eq. 2-2)."""
    fc = np.asarray(cutoff_hz, dtype=np.float64)
    if not (np.isfinite(dt_s) and dt_s > 0):
        raise ValueError(f"dt_s must be positive, got {dt_s}")
    if np.any(~np.isfinite(fc)) or np.any(fc <= 0):
        raise ValueError(f"cut-off must be positive, got {cutoff_hz} Hz")
    tau = 1.0 / (2.0 * np.pi * fc)
    return tau / (tau + dt_s)


@dataclass(frozen=True)
class AdaptiveCutoff:
    """How the adaptive cut-off is picked from the spectrum (see the module doc)."""

    window_s: float = 4.0
    update_s: float = 2.0
    min_hz: float = 0.2
    max_hz: float = 10.0
    rest_rms_rad_s: float = 0.05

    def __post_init__(self) -> None:
        if not (self.window_s > 0 and self.update_s > 0):
            raise ValueError("window_s and update_s must be positive")
        if not 0 < self.min_hz < self.max_hz:
            raise ValueError(f"need 0 < min_hz < max_hz, got {self.min_hz}, {self.max_hz}")
        if self.rest_rms_rad_s < 0:
            raise ValueError("rest_rms_rad_s must be >= 0")

    def pick(self, rate_rad_s: np.ndarray, fs_hz: float) -> np.ndarray:
        """(W, C) rate window -> (C,) cut-off in Hz, NaN where the segment is at rest."""
        x = np.asarray(rate_rad_s, dtype=np.float64)
        x = x - x.mean(axis=0)
        n = x.shape[0]
        rms = np.sqrt(np.mean(x * x, axis=0))
        spec = np.abs(np.fft.rfft(x * np.hanning(n)[:, None], axis=0))
        freqs = np.fft.rfftfreq(n, 1.0 / fs_hz)
        spec[freqs < self.min_hz] = -1.0
        k = np.argmax(spec, axis=0)
        fc = np.empty(x.shape[1])
        df = freqs[1] - freqs[0]
        for ch, kk in enumerate(k):
            shift = 0.0
            if 0 < kk < len(freqs) - 1 and spec[kk - 1, ch] >= 0:
                a, b, c = spec[kk - 1, ch], spec[kk, ch], spec[kk + 1, ch]
                den = a - 2.0 * b + c
                if den < 0:
                    shift = float(np.clip(0.5 * (a - c) / den, -0.5, 0.5))
            fc[ch] = freqs[kk] + shift * df
        hi = min(self.max_hz, 0.45 * fs_hz)
        fc = np.clip(fc, self.min_hz, hi)
        fc[rms < self.rest_rms_rad_s] = np.nan
        return fc


class ComplementaryFilter:
    """Complementary tilt filter for one or several segments (see the module doc).

    ``process(acc_tilt_rad, gyro_rad_s) -> tilt_rad``; (N,) or (N, segments). With ``adaptive``
    set, each segment's cut-off follows its own motion spectrum, starting at ``cutoff_hz``.
    """

    def __init__(
        self,
        dt_s: float = 0.01,
        cutoff_hz: float = 3.0,
        adaptive: AdaptiveCutoff | None = None,
    ) -> None:
        complementary_alpha(cutoff_hz, dt_s)  # validates both
        self.dt_s = float(dt_s)
        self.initial_cutoff_hz = float(cutoff_hz)
        self.adaptive = adaptive
        if adaptive is not None:
            self._window_n = max(8, round(adaptive.window_s / self.dt_s))
            self._update_n = max(1, round(adaptive.update_s / self.dt_s))
        self.reset()

    def reset(self) -> None:
        self._theta: np.ndarray | None = None
        self._fc: np.ndarray | None = None
        self._alpha: np.ndarray | None = None
        self._step = 0
        self._hist: np.ndarray | None = None
        # per segment, the linear path's filter while it runs on (None: start from theta)
        self._linear: list[LinearFilter | None] = []
        self.cutoff_history: list[tuple[int, np.ndarray]] = []  # (sample index, fc per segment)

    @property
    def cutoff_hz(self) -> np.ndarray | None:
        """The cut-off in use now, per segment (None before the first sample)."""
        return None if self._fc is None else self._fc.copy()

    def process(self, acc_tilt_rad: np.ndarray, gyro_rad_s: np.ndarray) -> np.ndarray:
        z, w, was_1d = as_2d_pair(acc_tilt_rad, gyro_rad_s)
        n, c = z.shape
        out = np.empty((n, c))
        if n == 0:
            return out[:, 0] if was_1d else out
        if self._theta is None:
            self._theta = z[0].copy()
            self._fc = np.full(c, self.initial_cutoff_hz)
            self._alpha = complementary_alpha(self._fc, self.dt_s)
            self._hist = np.empty((0, c))
            self._linear = [None] * c
            self.cutoff_history.append((0, self._fc.copy()))
        elif self._theta.shape[0] != c:
            raise ValueError(f"this filter carries state for {self._theta.shape[0]} segments")
        i = 0
        while i < n:
            stop = n
            if self.adaptive is not None:
                self._maybe_refresh()
                to_next = self._update_n - self._step % self._update_n
                stop = min(n, i + to_next)
                self._push_history(w[i:stop])
            for ch in range(c):
                out[i:stop, ch] = self._run_channel(ch, z[i:stop, ch], w[i:stop, ch])
            self._step += stop - i
            i = stop
        return out[:, 0] if was_1d else out

    # ------------------------------------------------------------------ adaptive cut-off
    def _push_history(self, w: np.ndarray) -> None:
        assert self._hist is not None
        self._hist = np.concatenate([self._hist, w])[-self._window_n :]

    def _maybe_refresh(self) -> None:
        assert self.adaptive is not None and self._fc is not None and self._hist is not None
        k = self._step
        # process() calls this once per update period, always at a new step
        if k % self._update_n or k < self._window_n:
            return
        fc = self.adaptive.pick(self._hist, 1.0 / self.dt_s)
        new = np.where(np.isnan(fc), self._fc, fc)
        if not np.array_equal(new, self._fc):
            changed = np.flatnonzero(new != self._fc)
            self._fc = new
            self._alpha = complementary_alpha(new, self.dt_s)
            for ch in changed:  # a new alpha: that segment's linear path starts again
                self._linear[ch] = None
            self.cutoff_history.append((k, new.copy()))

    # ------------------------------------------------------------------ one segment
    def _run_channel(self, ch: int, z: np.ndarray, w: np.ndarray) -> np.ndarray:
        assert self._theta is not None and self._alpha is not None
        alpha = float(self._alpha[ch])
        dt = self.dt_s
        out = np.empty(z.shape[0])
        theta = float(self._theta[ch])
        i, n = 0, z.shape[0]
        while i < n:
            # linear path: unwrap z by continuity, anchored within pi of the first prediction
            zc, wc = z[i : i + _LINEAR_BLOCK], w[i : i + _LINEAR_BLOCK]
            pred0 = theta + wc[0] * dt
            turns = np.empty(zc.shape[0])
            turns[0] = np.rint((pred0 - zc[0]) / TWO_PI)
            turns[1:] = -np.rint(np.diff(zc) / TWO_PI)
            z_unw = zc + TWO_PI * np.cumsum(turns)
            u = alpha * dt * wc + (1.0 - alpha) * z_unw
            lin = self._linear[ch]
            if lin is None:  # lfilter([1], [1, -alpha]) from theta: its state is alpha * theta
                lin = LinearFilter([1.0], [1.0, -alpha], 1, [[alpha * theta]])
            th = lin.process(u[:, None])[:, 0]
            self._linear[ch] = lin
            prev = np.concatenate([[theta], th[:-1]])
            err = z_unw - (prev + wc * dt)
            bad = np.flatnonzero(np.abs(err) >= np.pi - _WRAP_MARGIN_RAD)
            good = zc.shape[0] if bad.size == 0 else int(bad[0])
            out[i : i + good] = th[:good]
            if good:
                theta = float(th[good - 1])
            i += good
            if good < zc.shape[0]:  # an error term needs the real wrap: exact steps for a while
                self._linear[ch] = None  # (it ran past the wrap; it starts again from theta)
                for j in range(i, min(n, i + _EXACT_STEPS)):
                    pred = theta + w[j] * dt
                    theta = pred + (1.0 - alpha) * float(wrap_angle(z[j] - pred))
                    out[j] = theta
                i = min(n, i + _EXACT_STEPS)
        self._theta[ch] = theta
        return out
