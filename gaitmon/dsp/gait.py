"""Gait phase and gait events from the heel and toe force sensors, strides, and cycle normalisation.

This module owns everything between the low-passed FSR signals and per-stride figures:

* :class:`GaitEventDetector` - a causal, streaming, vectorised heel/toe contact detector
  (threshold + hysteresis + minimum duration) that also emits heel-strike and toe-off events;
* :class:`Phase` - the four phases that follow from the two contacts;
* :class:`Stride`, :func:`strides_from_events`, :class:`StrideTracker` - heel strike to next heel
  strike of the same foot, with stance/swing split at the toe off;
* :func:`normalise_cycles`, :func:`normalise_strides`, :func:`cycle_mean_sd` - time-normalised
  curves over 0..100 % of the gait cycle;
* :func:`gait_summary` - stride count, stride-time statistics, stance % and derived cadence.

One unit measures one leg, so cadence is *derived* (120 / stride time) and symmetry or double
support cannot be measured here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

__all__ = [
    "GaitBlock",
    "GaitEventDetector",
    "GaitSummary",
    "Phase",
    "Stride",
    "StrideTracker",
    "cycle_mean_sd",
    "gait_summary",
    "normalise_cycles",
    "normalise_strides",
    "phase_from_contacts",
    "strides_from_events",
]


class Phase(IntEnum):
    """Gait phase from the two contacts of one foot."""

    SWING = 0  # neither sensor loaded
    LOADING = 1  # heel only (after heel strike)
    FOOT_FLAT = 2  # heel and toe (mid-stance)
    PUSH_OFF = 3  # toe only (heel off)


# indexed by Phase; LOADING (heel only, from heel strike to foot flat) is named as the
# clinical phase it falls in: a bare "loading" read like a progress message in the readout
PHASE_NAMES = ("swing", "loading response", "foot flat", "push-off")


def phase_from_contacts(heel_loaded: np.ndarray, toe_loaded: np.ndarray) -> np.ndarray:
    """(N,) bool heel, (N,) bool toe -> (N,) int8 :class:`Phase` values."""
    heel = np.asarray(heel_loaded, dtype=bool).view(np.int8)
    toe = np.asarray(toe_loaded, dtype=bool).view(np.int8)
    # heel + toe * (3 - 2 * heel): neither 0, heel 1, both 2, toe 3 (int8 arithmetic is ~10x
    # faster than a fancy-indexed lookup table on long records)
    return heel + toe * (3 - 2 * heel)


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class GaitBlock:
    """The detector's output for one input block (arrays are read-only).

    ``heel_loaded``/``toe_loaded``/``phase`` are the causal, debounced state at each input sample.
    The event arrays hold ABSOLUTE sample indices (counted from construction or ``reset()``) of
    events *confirmed* during this block; because confirmation waits for the minimum duration,
    an index may lie before the first sample of the block.
    """

    heel_loaded: np.ndarray  # (N,) bool
    toe_loaded: np.ndarray  # (N,) bool
    phase: np.ndarray  # (N,) int8 Phase values
    heel_strike_idx: np.ndarray  # (k,) int64, ascending
    toe_off_idx: np.ndarray  # (m,) int64, ascending


@dataclass
class _ContactState:
    """What one sensor's contact detector carries from one block to the next."""

    hyst_on: bool = False  # hysteresis state of the last sample (a fresh detector starts unloaded)
    run_start: int = 0  # absolute index where the current hysteresis run began
    debounced: int = -1  # -1 = not yet confirmed, 0 = unloaded, 1 = loaded


class GaitEventDetector:
    """Causal streaming heel/toe contact detector with hysteresis and a minimum duration.

    Exact rule, applied independently to the heel (column 0) and toe (column 1) of ``fsr``:

    1. **Hysteresis.** A sample with ``x > threshold`` sets the raw state to loaded; a sample with
       ``x < threshold - hysteresis`` sets it to unloaded; any other sample (inside the band, or
       NaN) keeps the previous raw state. A fresh detector's raw state is unloaded.
    2. **Minimum duration.** Let ``D = max(1, round(min_duration_s * fs_hz))``. The debounced
       (reported) state takes the raw state's value at the sample where the raw state has held
       that value for ``D`` consecutive samples, counting the sample where it changed; otherwise it
       keeps its previous value. A raw excursion shorter than ``D`` samples therefore never
       reaches the output, so noise chattering around the threshold cannot produce events.
    3. **Events.** A heel strike is a debounced heel change unloaded -> loaded; a toe off is a
       debounced toe change loaded -> unloaded. The reported index is the *crossing sample*: the
       first sample of the raw run that was confirmed (the first sample ``> threshold`` for a heel
       strike, the first sample ``< threshold - hysteresis`` for a toe off), i.e. the confirmation
       sample minus ``D - 1``. An event is reported in the block that contains its confirmation
       sample. The first confirmed state after construction/``reset()`` only initialises the
       output and is not an event (a subject standing at power-on has not made a heel strike).
       Until then both contacts read unloaded.

    The ``*_loaded`` and ``phase`` outputs are the causal debounced state, so they lag the event
    indices by ``D - 1`` samples. Because heel and toe use the same ``D``, events are confirmed in
    the order of their indices, which :class:`StrideTracker` relies on.

    Implementation is vectorised numpy working on crossing points (no per-sample Python loop);
    chunked processing equals one-shot processing exactly.
    """

    def __init__(
        self,
        threshold: float = 1000.0,
        hysteresis: float = 50.0,
        min_duration_s: float = 0.03,
        fs_hz: float = 100.0,
    ) -> None:
        if not np.isfinite(threshold):
            raise ValueError(f"threshold must be finite, got {threshold!r}")
        if not (np.isfinite(hysteresis) and hysteresis >= 0.0):
            raise ValueError(f"hysteresis must be >= 0, got {hysteresis!r}")
        if not (np.isfinite(min_duration_s) and min_duration_s >= 0.0):
            raise ValueError(f"min_duration_s must be >= 0, got {min_duration_s!r}")
        if not (np.isfinite(fs_hz) and fs_hz > 0.0):
            raise ValueError(f"fs_hz must be > 0, got {fs_hz!r}")
        self.threshold = float(threshold)
        self.hysteresis = float(hysteresis)
        self.min_duration_s = float(min_duration_s)
        self.fs_hz = float(fs_hz)
        self.min_duration_samples = max(1, round(min_duration_s * fs_hz))
        self.reset()

    def reset(self) -> None:
        """Forget all history: unloaded, unconfirmed, sample counter back to 0."""
        self._state = [_ContactState(), _ContactState()]
        self._n_seen = 0

    def restart(self) -> None:
        """Forget the contacts but keep counting samples (after a link outage): the next
        confirmed state only initialises the output again, so no event spans the outage."""
        self._state = [_ContactState(run_start=self._n_seen), _ContactState(run_start=self._n_seen)]

    @property
    def samples_seen(self) -> int:
        """Number of samples processed since construction or ``reset()``."""
        return self._n_seen

    def process(self, fsr: np.ndarray) -> GaitBlock:
        """(N, 2) low-passed heel, toe (ADC counts) -> :class:`GaitBlock` for these N samples."""
        x = np.asarray(fsr, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != 2:
            raise ValueError(f"fsr must have shape (N, 2) (heel, toe), got {x.shape}")
        n = x.shape[0]
        heel, hs_idx, _ = self._contact(x[:, 0], self._state[0])
        toe, _, to_idx = self._contact(x[:, 1], self._state[1])
        self._n_seen += n
        return GaitBlock(
            heel_loaded=_readonly(heel),
            toe_loaded=_readonly(toe),
            phase=_readonly(phase_from_contacts(heel, toe)),
            heel_strike_idx=_readonly(hs_idx),
            toe_off_idx=_readonly(to_idx),
        )

    def _contact(
        self, x: np.ndarray, st: _ContactState
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One sensor: -> (loaded (N,) bool, rise idx (k,) int64, fall idx (m,) int64).

        Works on change points rather than samples: only the O(N) comparisons, two
        ``flatnonzero`` and the final fill touch every sample; everything else is per crossing.
        """
        n = x.shape[0]
        base = self._n_seen
        if n == 0:
            empty = np.empty(0, dtype=np.int64)
            return np.zeros(0, dtype=bool), empty, empty.copy()

        # 1. hysteresis. The raw state can only change at the first sample of a run of
        # "set" (x > thr) or "clear" (x < thr - hyst) samples, and does so exactly when that
        # run's kind differs from the previous run's kind (band/NaN samples hold the state).
        # A run that seems to start at sample 0 only because the block starts there has the
        # same kind as the carried state, so it is correctly not a change.
        set_ = x > self.threshold
        clr = x < self.threshold - self.hysteresis
        set_start = _run_starts(set_)
        clr_start = _run_starts(clr)
        start_local = np.concatenate((set_start, clr_start))
        kind = np.concatenate(
            (np.ones(set_start.size, dtype=np.int8), np.zeros(clr_start.size, dtype=np.int8))
        )
        order = np.argsort(start_local, kind="stable")  # set and clear never share a sample
        start_local, kind = start_local[order], kind[order]
        prev_kind = np.empty_like(kind)
        if kind.size:
            prev_kind[0] = st.hyst_on
            prev_kind[1:] = kind[:-1]
        changed = kind != prev_kind

        # raw runs in effect during this block: the carried one, then one per raw change.
        run_start = np.concatenate(([st.run_start], start_local[changed] + base))
        run_val = np.concatenate(([np.int8(st.hyst_on)], kind[changed]))
        run_end = np.append(run_start[1:], base + n)  # exclusive; provisional for the last

        # 2. minimum duration: a run is confirmed at its D-th sample. The carried run may have
        # been confirmed in an earlier block already; then it is not confirmed again.
        d = self.min_duration_samples
        confirm_at = run_start + (d - 1)
        ok = ((run_end - run_start) >= d) & (confirm_at >= base)
        c_val = run_val[ok].astype(np.int8)
        c_start = run_start[ok]
        c_at = confirm_at[ok]
        prev_val = np.empty_like(c_val)
        if c_val.size:
            prev_val[0] = st.debounced
            prev_val[1:] = c_val[:-1]
        flip = c_val != prev_val  # debounced output changes (including the first -1 -> 0/1)

        # 3. events, dated at the first sample of the confirmed run.
        event = flip & (prev_val >= 0)
        rise_idx = c_start[event & (c_val == 1)]
        fall_idx = c_start[event & (c_val == 0)]

        # per-sample debounced output, filled segment by segment
        seg_val = np.concatenate(([st.debounced == 1], c_val[flip] == 1))
        edges = np.concatenate(([0], c_at[flip] - base, [n]))
        loaded = np.repeat(seg_val, np.diff(edges))

        st.hyst_on = bool(run_val[-1])
        st.run_start = int(run_start[-1])
        if c_val.size:
            st.debounced = int(c_val[-1])
        return loaded, rise_idx, fall_idx


def _run_starts(mask: np.ndarray) -> np.ndarray:
    """Local indices where a run of True starts (index 0 counts if mask[0] is True)."""
    starts = np.flatnonzero(mask[1:] & ~mask[:-1]) + 1
    if mask[0]:
        starts = np.concatenate((np.array([0]), starts))
    return starts.astype(np.int64, copy=False)


# --------------------------------------------------------------------------------------------
# strides

# Anything slower is treated as a pause (standing, turning with a shuffle), not a stride. Slow
# pathological gait (e.g. after stroke, ~0.2-0.4 m/s) has stride times of about 2-3 s, so 4 s
# keeps those while rejecting the stand-still-then-walk "stride" that would wreck the statistics.
DEFAULT_MAX_STRIDE_TIME_S = 4.0


@dataclass(frozen=True)
class Stride:
    """One stride of one foot: heel strike to the next heel strike, split at the toe off."""

    start_idx: int  # heel strike (absolute sample index)
    end_idx: int  # next heel strike of the same foot
    toe_off_idx: int  # the single toe off strictly between them
    stride_time_s: float
    stance_time_s: float  # start -> toe off
    swing_time_s: float  # toe off -> end
    stance_pct: float  # 100 * stance / stride
    swing_pct: float  # 100 * swing / stride

    @property
    def cadence_derived_steps_per_min(self) -> float:
        """120 / stride time: DERIVED, assuming two equal steps per stride (one unit = one leg)."""
        return 120.0 / self.stride_time_s


def _as_index_array(a: np.ndarray | Sequence[int], name: str) -> np.ndarray:
    arr = np.asarray(a)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be 1-D, got shape {arr.shape}")
    if arr.size and not np.issubdtype(arr.dtype, np.integer):
        raise ValueError(f"{name} must hold integer sample indices, got dtype {arr.dtype}")
    return arr.astype(np.int64, copy=False)


def _check_increasing(a: np.ndarray, name: str) -> None:
    if a.size > 1 and np.any(np.diff(a) <= 0):
        raise ValueError(f"{name} must be strictly increasing")


def _strides_core(
    hs: np.ndarray, to: np.ndarray, fs_hz: float, max_stride_time_s: float | None
) -> list[Stride]:
    """Strides between consecutive heel strikes ``hs`` with exactly one ``to`` strictly inside."""
    if hs.size < 2:
        return []
    start, end = hs[:-1], hs[1:]
    # number of toe offs t with start < t < end
    lo = np.searchsorted(to, start, side="right")
    hi = np.searchsorted(to, end, side="left")
    ok = (hi - lo) == 1
    if max_stride_time_s is not None:
        ok &= (end - start) <= max_stride_time_s * fs_hz
    out: list[Stride] = []
    for s, e, t in zip(start[ok].tolist(), end[ok].tolist(), to[lo[ok]].tolist(), strict=True):
        stride_n = e - s
        stance_n = t - s
        out.append(
            Stride(
                start_idx=s,
                end_idx=e,
                toe_off_idx=t,
                stride_time_s=stride_n / fs_hz,
                stance_time_s=stance_n / fs_hz,
                swing_time_s=(e - t) / fs_hz,
                stance_pct=100.0 * stance_n / stride_n,
                swing_pct=100.0 * (e - t) / stride_n,
            )
        )
    return out


def strides_from_events(
    heel_strike_idx: np.ndarray | Sequence[int],
    toe_off_idx: np.ndarray | Sequence[int],
    fs_hz: float,
    *,
    max_stride_time_s: float | None = DEFAULT_MAX_STRIDE_TIME_S,
) -> list[Stride]:
    """Strides from whole-record event indices (both strictly increasing).

    Each pair of consecutive heel strikes ``(s, e)`` is a stride when exactly one toe off ``t``
    satisfies ``s < t < e`` (none means a missed toe off, two a missed heel strike) and, unless
    ``max_stride_time_s`` is None, ``e - s <= max_stride_time_s * fs_hz`` (longer is a pause).
    """
    if not (np.isfinite(fs_hz) and fs_hz > 0):
        raise ValueError(f"fs_hz must be > 0, got {fs_hz!r}")
    hs = _as_index_array(heel_strike_idx, "heel_strike_idx")
    to = _as_index_array(toe_off_idx, "toe_off_idx")
    _check_increasing(hs, "heel_strike_idx")
    _check_increasing(to, "toe_off_idx")
    return _strides_core(hs, to, float(fs_hz), max_stride_time_s)


class StrideTracker:
    """Streaming :func:`strides_from_events`: feed events as they are confirmed, get strides.

    Contract: events arrive in time order, as :class:`GaitEventDetector` confirms them - an event
    delivered in a later call never has a smaller index than one delivered earlier (equal
    indices are allowed). Under that contract, feeding a record's events in any chunks
    returns exactly the strides of one call, and each stride is returned in the call that
    delivers its closing heel strike. Out-of-order events raise ``ValueError``.
    """

    def __init__(
        self,
        fs_hz: float = 100.0,
        *,
        max_stride_time_s: float | None = DEFAULT_MAX_STRIDE_TIME_S,
    ) -> None:
        if not (np.isfinite(fs_hz) and fs_hz > 0):
            raise ValueError(f"fs_hz must be > 0, got {fs_hz!r}")
        self.fs_hz = float(fs_hz)
        self.max_stride_time_s = max_stride_time_s
        self.reset()

    def reset(self) -> None:
        self._open_hs: int | None = None  # heel strike that opened the current stride
        self._pending_to = np.empty(0, dtype=np.int64)  # toe offs after _open_hs
        self._last_to: int | None = None

    def process(
        self,
        heel_strike_idx: np.ndarray | Sequence[int],
        toe_off_idx: np.ndarray | Sequence[int],
    ) -> list[Stride]:
        hs = _as_index_array(heel_strike_idx, "heel_strike_idx")
        to = _as_index_array(toe_off_idx, "toe_off_idx")
        _check_increasing(hs, "heel_strike_idx")
        _check_increasing(to, "toe_off_idx")
        if self._open_hs is not None and hs.size and hs[0] <= self._open_hs:
            raise ValueError(
                f"heel strike {int(hs[0])} is not after the previous one ({self._open_hs})"
            )
        if self._last_to is not None and to.size and to[0] <= self._last_to:
            raise ValueError(
                f"toe off {int(to[0])} is not after the previous one ({self._last_to})"
            )
        if self._open_hs is not None and to.size and to[0] < self._open_hs:
            raise ValueError(
                f"toe off {int(to[0])} arrived after heel strike {self._open_hs}: events must be "
                "fed in the order they are confirmed"
            )
        if self._last_to is not None and hs.size and hs[0] < self._last_to:
            raise ValueError(
                f"heel strike {int(hs[0])} arrived after toe off {self._last_to}: events must be "
                "fed in the order they are confirmed"
            )
        if to.size:
            self._last_to = int(to[-1])
        all_hs = hs if self._open_hs is None else np.concatenate((np.array([self._open_hs]), hs))
        all_to = np.concatenate((self._pending_to, to))
        strides = _strides_core(all_hs, all_to, self.fs_hz, self.max_stride_time_s)
        if all_hs.size:
            self._open_hs = int(all_hs[-1])
            # toe offs at or before the open heel strike can never count again (strict s < t),
            # and two are already enough to reject the open stride: keeping at most two bounds
            # the memory when the heel sensor fails during a long recording.
            self._pending_to = all_to[all_to > self._open_hs][:2]
        else:
            # no heel strike yet: a stride starts at a later heel strike, after these toe offs
            self._pending_to = np.empty(0, dtype=np.int64)
        return strides


# --------------------------------------------------------------------------------------------
# cycle normalisation


NORMALISE_BLOCK_STRIDES = 2048  # strides resampled at a time (their temporaries: ~15 MB)


def _normalise_between(
    angles: np.ndarray, start: np.ndarray, end: np.ndarray, n_points: int
) -> np.ndarray:
    # float32 angles (as a session reads them) are not copied whole to float64: the samples
    # each block of strides needs are, exactly, so the result is the same to the last bit
    a = np.asarray(angles)
    if a.dtype.kind != "f":
        a = a.astype(np.float64)
    squeeze = a.ndim == 1
    if squeeze:
        a = a[:, None]
    if a.ndim != 2:
        raise ValueError(f"angles must have shape (N,) or (N, k), got {np.shape(angles)}")
    if n_points < 2:
        raise ValueError(f"n_points must be >= 2, got {n_points}")
    n = a.shape[0]
    keep = (start >= 0) & (end <= n - 1) & (end > start)
    start, end = start[keep], end[keep]
    frac_cycle = np.linspace(0.0, 1.0, n_points)
    out = np.empty((len(start), n_points, a.shape[1]))  # (n_strides, n_points, k)
    # a block of strides at a time: the temporaries stay small whatever the session's length
    for b0 in range(0, len(start), NORMALISE_BLOCK_STRIDES):
        s, e = start[b0 : b0 + NORMALISE_BLOCK_STRIDES], end[b0 : b0 + NORMALISE_BLOCK_STRIDES]
        pos = s[:, None] + (e - s)[:, None] * frac_cycle[None, :]  # (strides, n_points)
        i0 = np.minimum(np.floor(pos).astype(np.int64), (e - 1)[:, None])
        w = (pos - i0)[..., None]
        out[b0 : b0 + len(s)] = (a[i0].astype(np.float64) * (1.0 - w)
                                 + a[i0 + 1].astype(np.float64) * w)  # fmt: skip
    return out[..., 0] if squeeze else out


def normalise_cycles(
    angles: np.ndarray, heel_strike_idx: np.ndarray | Sequence[int], n_points: int = 101
) -> np.ndarray:
    """Resample every heel-strike-to-heel-strike cycle linearly onto ``n_points`` (0..100 %).

    ``angles`` is (N, k) or (N,), indexed like ``heel_strike_idx`` (index 0 = first row). Point j
    of a cycle ``(s, e)`` is the linear interpolation of ``angles`` at sample
    ``s + (e - s) * j / (n_points - 1)``, so 0 % is the heel strike and 100 % the next one.
    Cycles that do not lie entirely inside ``angles`` are dropped. Returns
    (n_cycles, n_points, k), or (n_cycles, n_points) for 1-D input.
    """
    hs = _as_index_array(heel_strike_idx, "heel_strike_idx")
    _check_increasing(hs, "heel_strike_idx")
    return _normalise_between(angles, hs[:-1], hs[1:], n_points)


def normalise_strides(
    angles: np.ndarray, strides: Sequence[Stride], n_points: int = 101, index_offset: int = 0
) -> np.ndarray:
    """Like :func:`normalise_cycles` but over validated strides only.

    ``angles[0]`` is absolute sample ``index_offset`` (strides carry absolute indices).
    """
    start = np.array([s.start_idx for s in strides], dtype=np.int64) - index_offset
    end = np.array([s.end_idx for s in strides], dtype=np.int64) - index_offset
    return _normalise_between(angles, start, end, n_points)


def cycle_mean_sd(cycles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and sample SD (ddof=1) across cycles (axis 0).

    With no cycles both are NaN; with one cycle the SD is NaN (undefined), without warnings.
    """
    c = np.asarray(cycles, dtype=np.float64)
    if c.ndim < 2:
        raise ValueError(f"cycles must have shape (n_cycles, n_points[, k]), got {c.shape}")
    n = c.shape[0]
    if n == 0:
        nan = np.full(c.shape[1:], np.nan)
        return nan, nan.copy()
    mean = c.mean(axis=0)
    sd = c.std(axis=0, ddof=1) if n > 1 else np.full(c.shape[1:], np.nan)
    return mean, sd


def mean_sd(values: Sequence[float] | np.ndarray) -> tuple[float, float, int]:
    """(mean, sample SD (ddof=1), n) of the finite values: every per-stride "mean ± SD" in
    gaitmon (info, review, report, compare, exports) is taken here. NaN mean with none, NaN SD
    with one, without warnings."""
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    v = v[np.isfinite(v)]
    n = len(v)
    return (float(v.mean()) if n else float("nan"), float(v.std(ddof=1)) if n > 1 else float("nan"),
            n)  # fmt: skip


# --------------------------------------------------------------------------------------------
# summary


@dataclass(frozen=True)
class GaitSummary:
    """Figures over a set of strides of one foot. NaN where undefined (too few strides)."""

    n_strides: int
    stride_time_mean_s: float
    stride_time_sd_s: float  # sample SD (ddof=1)
    stride_time_cv_pct: float  # 100 * SD / mean
    stance_pct_mean: float
    swing_pct_mean: float
    cadence_derived_steps_per_min: float  # 120 / mean stride time; DERIVED (one leg measured)


def gait_summary(strides: Sequence[Stride]) -> GaitSummary:
    """Summarise strides: count, mean/SD/CV of stride time, mean stance/swing %, cadence."""
    n = len(strides)
    if n == 0:
        nan = float("nan")
        return GaitSummary(0, nan, nan, nan, nan, nan, nan)
    mean_t, sd_t, _ = mean_sd([s.stride_time_s for s in strides])
    return GaitSummary(
        n_strides=n,
        stride_time_mean_s=mean_t,
        stride_time_sd_s=sd_t,
        stride_time_cv_pct=100.0 * sd_t / mean_t,
        stance_pct_mean=float(np.mean([s.stance_pct for s in strides])),
        swing_pct_mean=float(np.mean([s.swing_pct for s in strides])),
        cadence_derived_steps_per_min=120.0 / mean_t,
    )


class ContactEdges:
    """Events from contact states the unit reports (JOINT frames): heel strikes = rising
    edges of the heel contact, toe offs = falling edges of the toe contact. Streaming; no
    event at the very first sample (its past is unknown)."""

    def __init__(self) -> None:
        self._heel: bool | None = None
        self._toe: bool | None = None

    def process(
        self, heel: np.ndarray, toe: np.ndarray, start_row: int
    ) -> tuple[np.ndarray, np.ndarray]:
        h = np.asarray(heel, dtype=bool)
        t = np.asarray(toe, dtype=bool)
        if len(h) == 0:
            return np.empty(0, np.int64), np.empty(0, np.int64)
        h_prev = np.concatenate([[h[0] if self._heel is None else self._heel], h[:-1]])
        t_prev = np.concatenate([[t[0] if self._toe is None else self._toe], t[:-1]])
        self._heel, self._toe = bool(h[-1]), bool(t[-1])
        hs = np.flatnonzero(h & ~h_prev).astype(np.int64) + start_row
        to = np.flatnonzero(~t & t_prev).astype(np.int64) + start_row
        return hs, to
