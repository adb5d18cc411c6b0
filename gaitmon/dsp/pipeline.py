"""The PC-side signal pipeline of paper 000: raw ADC counts in, every derived series out.

Per block, in the paper's order:

1. counts -> physical units through the channel table (m/s^2, rad/s, FSR counts);
2. 2nd-order 4 Hz Butterworth on the accelerometer and FSR channels;
3. gyro rate minus the calibrated bias (the Kalman filter still tracks what is left);
4. accelerometer tilt atan2(a_z, a_x) per segment;
5. gyro-integrated tilt, passed through the same Butterworth to put it in phase (paper Fig. 4);
6. the tilt filter per segment: the causal stage of the method ``PipelineConfig.tilt_method``
   names in the registry (gaitmon.dsp.methods), fed a :class:`TiltInput` (raw and low-passed
   accelerometer, gyro): ``"gait-aware"`` (the default, gaitmon.dsp.motion_kalman: the
   measurement trusted by the segment's motion, read on the raw accelerometer) or ``"paper"``
   ("Kalman (paper, seed 000)", gaitmon.dsp.kalman, on the low-passed accelerometer tilt
   exactly as published). The output series keep the name ``tilt_kalman_rad`` /
   ``joint_kalman_rad`` whichever filter made them;
7. standing offsets removed, tilts wrapped to (-pi, pi], joint angles with clinical signs;
8. heel/toe contacts, gait phase and heel-strike/toe-off events from the FSRs (strides are
   made from these events by their readers: live ``gaitmon.engine.live_gait.GaitEvents``, a
   file's ``gaitmon.analysis``, with ``gaitmon.dsp.gait.strides_from_events``);
9. with ``fsr_check`` (default): heel strike and toe off from the foot gyro as well
   (gaitmon.dsp.gyro_events, ~0.75 s behind), each FSR checked against the gyro's strides
   (gaitmon.dsp.fsr_check). Once a sensor is flagged, the events come from the gyro
   from the flag's ``decided_idx`` on (``event_source`` says which), and the flag is reported.
   Both are event sources of the registry (gaitmon.dsp.events: ``PRIMARY`` "fsr", ``FALLBACK``
   "foot gyro"), fed a typed :class:`EventInput` per block.

Why gait-aware is the default: on the simulator's truth its joint angles are 3-6x closer than the
paper's filter (``gaitmon lab accuracy``, README).

Event timing. The 4 Hz low-pass delays the FSR signals by its group delay (5.7 samples at 100 Hz,
the paper's "7-8 samples" by eye), so raw threshold crossings come ~55 ms after the real contact.
With ``compensate_event_delay`` (default) event indices are moved back by the filter's DC group
delay, rounded to whole samples; the per-sample contact and phase arrays stay causal (they lag).

Gaps. ``process(adc, lost_before)`` is told how many frames were lost just before each row
(the recording's gap table says the same). Losses of up to ``BRIDGE_MAX_S`` (5 frames at 100 Hz)
are bridged, and lost frames are time: the stateful stages (low-pass filters, gyro integration,
tilt filter, contact detector, event sources) are fed the lost frames filled in,
linear (in physical units) between the row before the loss (kept across blocks) and the row
after it, so they all see the unit's uniform time base. Outputs are given for the rows only, and
every index the pipeline reports (events, gyro events, faults, restarts) is a row: an
event on a filled-in frame is on the row after it (strides are timed on the rows' ``t_s``,
which counts the lost frames, live and in a file). With
2 % random single-frame loss the live joint RMSE stays within 1.04x of the loss-free run; taking
each row as the next frame, it was 4.5x (benchmarks/loss_accuracy.py). After a longer loss the
pipeline *restarts*: the low-pass
filters and the gyro integration start again from the first sample after the gap, the Kalman
filter takes its angle from the measurements again (keeping the gyro bias it had learnt; the
gait-aware filter's exact start-up gain, gaitmon.dsp.motion_kalman), and the contact detector
forgets the contacts, so no event spans the outage. The ``SETTLE_S`` after a restart (and
after the start) are flagged ``settling``: strides overlapping them are left out of the statistics
(:func:`settling_ranges` gives the same ranges from a file's gap table).

Zeroing (``set_calibration``) also restarts the gyro integration from the zeroed pose, so its
drift (kept: the paper shows it as a finding) is counted from the standing calibration.

The same object serves live use (10 ms ticks) and offline reprocessing of whole recordings; any
chunking of the input gives exactly the same output.
"""

from __future__ import annotations

import bisect
import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from gaitmon.dsp import kernels
from gaitmon.dsp.angles import accel_tilt
from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.channel_table import N_FSR, N_JOINTS, N_SEGMENTS
from gaitmon.dsp.channels import (
    ACC_X_IDX,
    ACC_Z_IDX,
    DEFAULT_TABLE,
    FSR_IDX,
    GYRO_IDX,
    N_CHANNELS,
    ChannelTable,
)
from gaitmon.dsp.events import FALLBACK, PRIMARY, EventInput, EventStage, get_event_source
from gaitmon.dsp.filters import Butterworth, GyroIntegrator
from gaitmon.dsp.fsr_check import FsrFault, FsrMonitor
from gaitmon.dsp.gait import GaitEventDetector
from gaitmon.dsp.lost_frames import SETTLE_S as SETTLE_S
from gaitmon.dsp.lost_frames import bridged_fill, fill_lost, restart_rows
from gaitmon.dsp.lost_frames import settling_ranges as settling_ranges
from gaitmon.dsp.methods import TiltInput, TiltMethod, TiltStage
from gaitmon.dsp.pipeline_config import PipelineConfig as PipelineConfig
from gaitmon.dsp.pipeline_config import butterworth_dc_delay_samples as butterworth_dc_delay_samples

# SETTLE_S (the settling after a restart) and settling_ranges live with the losses, so that
# gaitmon.analysis reads them without the filters; they are named here too, where restarts are made

# long inputs are worked through in sub-blocks that stay in cache (same output, about 2x faster)
_SUB_BLOCK = 16384

def warm_up(config: PipelineConfig, table: ChannelTable = DEFAULT_TABLE) -> None:
    """Run a throwaway pipeline of ``config`` over two still rows, so that its filters' tables
    (gain schedules, coefficients) are built now, not on the first block a unit streams. (Its
    loops run interpreted for such blocks: nothing is compiled, gaitmon.dsp.kernels.)"""
    rows = np.rint(np.tile(table.zero_counts, (2, 1))).astype(np.uint16)
    Pipeline(config, table=table).process(rows)


@dataclass(frozen=True)
class PipelineBlock:
    """Everything the pipeline derived for one block of N samples (angles in rad)."""

    start_idx: int  # absolute index (since reset) of the first sample
    acc_ms2: np.ndarray  # (N, 4, 2) low-passed accelerometer x, z per segment
    gyro_rad_s: np.ndarray  # (N, 4) bias-corrected gyro rate
    fsr_counts: np.ndarray  # (N, 2) low-passed heel, toe
    tilt_acc_rad: np.ndarray  # (N, 4) body, thigh, shank, foot
    tilt_gyro_rad: np.ndarray
    tilt_kalman_rad: np.ndarray
    joint_acc_rad: np.ndarray  # (N, 3) hip flexion, knee flexion, ankle dorsiflexion
    joint_gyro_rad: np.ndarray
    joint_kalman_rad: np.ndarray
    heel_loaded: np.ndarray  # (N,) bool
    toe_loaded: np.ndarray
    phase: np.ndarray  # (N,) int8 gaitmon.dsp.gait.Phase
    heel_strike_idx: np.ndarray  # absolute indices confirmed in this block
    toe_off_idx: np.ndarray
    kalman_bias_rad_s: np.ndarray = field(default_factory=lambda: np.zeros(N_SEGMENTS))  # after
    # (N,) bool: the filters are settling (the SETTLE_S after the start or a restart)
    settling: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    # absolute indices of the rows where the pipeline restarted after a long gap, this block
    restart_idx: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    # foot-gyro events decided in this block (absolute indices; ~0.75 s behind the samples)
    gyro_heel_strike_idx: tuple[int, ...] = ()
    gyro_toe_off_idx: tuple[int, ...] = ()
    fsr_faults: tuple[FsrFault, ...] = ()  # sensors flagged in this block
    event_source: str = "fsr"  # where heel_strike_idx / toe_off_idx come from: fsr | foot gyro
    # (N, 4) the tilt filter's own angle (rad): continuous (not wrapped), before the standing
    # offsets; with the gait-aware filter it is the offline smoother's first pass
    # (gaitmon.dsp.smoother.CausalFirstPass), which `gaitmon process` takes from here
    tilt_kalman_continuous_rad: np.ndarray = field(
        default_factory=lambda: np.zeros((0, N_SEGMENTS))
    )

    @property
    def n(self) -> int:
        return int(self.tilt_acc_rad.shape[0])


_PER_SAMPLE = (
    ("acc_ms2", (N_SEGMENTS, 2), np.float64),
    ("gyro_rad_s", (N_SEGMENTS,), np.float64),
    ("fsr_counts", (N_FSR,), np.float64),
    ("tilt_acc_rad", (N_SEGMENTS,), np.float64),
    ("tilt_gyro_rad", (N_SEGMENTS,), np.float64),
    ("tilt_kalman_rad", (N_SEGMENTS,), np.float64),
    ("tilt_kalman_continuous_rad", (N_SEGMENTS,), np.float64),
    ("joint_acc_rad", (N_JOINTS,), np.float64),
    ("joint_gyro_rad", (N_JOINTS,), np.float64),
    ("joint_kalman_rad", (N_JOINTS,), np.float64),
    ("heel_loaded", (), np.bool_),
    ("toe_loaded", (), np.bool_),
    ("phase", (), np.int8),
)


class Pipeline:
    """Raw ADC blocks (N, 14) in, :class:`PipelineBlock` out. Stateful; see the module doc."""

    def __init__(
        self,
        config: PipelineConfig | None = None,
        calibration: Calibration | None = None,
        table: ChannelTable = DEFAULT_TABLE,
        *,
        joints: bool = True,
    ) -> None:
        """``joints=False``: the blocks' joint angles are not computed (each ``joint_*_rad`` is
        (N, 0)), for a caller that stores none (``gaitmon process`` of a format-2 file)."""
        self.config = config or PipelineConfig()
        self.calibration = calibration or Calibration.identity()
        self.table = table
        self.joints = joints
        self.reset()

    def reset(self) -> None:
        """Back to the just-constructed state (the calibration is kept)."""
        cfg = self.config
        # (the two accelerometer axes apart: each block's axes arrive as arrays of their own)
        self._acc_x_lp = Butterworth(cfg.cutoff_hz, cfg.fs_hz, cfg.filter_order)
        self._acc_z_lp = Butterworth(cfg.cutoff_hz, cfg.fs_hz, cfg.filter_order)
        self._fsr_lp = Butterworth(cfg.cutoff_hz, cfg.fs_hz, cfg.filter_order)
        self._gyro_tilt_lp = Butterworth(cfg.cutoff_hz, cfg.fs_hz, cfg.filter_order)
        self._integrator = GyroIntegrator(1.0 / cfg.fs_hz)
        self._method = cfg.method
        self._kalman: TiltStage = self._method.causal_stage(cfg)
        self._detector = GaitEventDetector(
            cfg.fsr_threshold, cfg.fsr_hysteresis, cfg.min_contact_s, cfg.fs_hz
        )
        self._n_seen = 0  # rows (the index space of everything the pipeline reports)
        self._n_fed = 0  # samples the stateful stages have seen: rows + bridged lost frames
        # the bridged losses (see "Gaps" in the module doc): per gap, its row, the sample index
        # of that row and the lost frames filled in up to and including it (the row <-> sample
        # map of the event indices, kept for the whole record: a few MB in 8 h at 2 % loss)
        self._gap_rows: list[int] = []
        self._gap_samples: list[int] = []
        self._gap_filled: list[int] = []
        # the last row of each channel group (_GROUPS), physical units (interpolation)
        self._last_phys: list[np.ndarray] | None = None
        self._settle_n = round(SETTLE_S * self.config.fs_hz)
        self._settle_until = 0  # the start-up is the first stride's exclusion (gaitmon.analysis)
        # the event sources (gaitmon.dsp.events): the force sensors, and the foot gyro that
        # checks them and takes over once one is flagged
        self._fsr_events: EventStage = get_event_source(PRIMARY).stage(cfg)
        self._gyro_events: EventStage = get_event_source(FALLBACK).stage(cfg)
        tol = round(0.15 * self.config.fs_hz)
        # the gyro's closing heel strike is decided at most this long after it (module doc)
        delay = self._gyro_events.latency_samples + tol
        self._fsr_monitor = FsrMonitor(self.config.fs_hz, tolerance_s=0.15, decision_delay=delay)
        self._decision_delay = delay
        self._switch_idx: int | None = None  # events from the gyro from this row on
        self._faults: list[FsrFault] = []  # the monitor's faults, in rows

    def successor(self, config: PipelineConfig) -> Pipeline:
        """A fresh pipeline for new settings from the next sample on (index 0 = that sample),
        with this one's calibration and channel table. Force sensors this one flagged stay
        flagged (events from the foot gyro at once) when the new settings read the FSRs the
        same way; new FSR settings (threshold, hysteresis, low-pass, minimum contact) are
        checked from scratch, since they may be what made a sensor look faulty."""
        new = Pipeline(config, self.calibration, self.table, joints=self.joints)
        if config.reads_fsrs_as(self.config):
            new.flag_fsr_faults([(f.sensor, f.reason) for f in self.fsr_faults])
        return new

    def flag_fsr_faults(self, flagged: Sequence[tuple[str, str]]) -> None:
        """Force sensors (sensor, reason) known to be faulty before this pipeline's first
        sample (flagged by the pipeline before it, or when the recording started): gait events
        from the foot gyro from the first sample on. Nothing without the FSR check."""
        if flagged and self.config.fsr_check and self._n_seen == 0:
            self._fsr_monitor.faults = [FsrFault(s, r, 0, 0) for s, r in flagged]
            self._faults = list(self._fsr_monitor.faults)
            self._switch_idx = 0

    def _restart(self, at: int) -> None:
        """A long gap ends at absolute index ``at``: see the module doc."""
        for stage in (self._acc_x_lp, self._acc_z_lp, self._fsr_lp, self._gyro_tilt_lp,
                      self._integrator):  # fmt: skip
            stage.reset()
        self._kalman.restart()
        self._detector.restart()
        self._settle_until = at + self._settle_n
        self._fsr_events.restart(self._n_fed)  # the event stages count samples
        self._gyro_events.restart(self._n_fed)

    @property
    def event_source(self) -> str:
        """The registered event source (gaitmon.dsp.events) the events come from now."""
        return FALLBACK if self._switch_idx is not None else PRIMARY

    @property
    def fsr_faults(self) -> tuple[FsrFault, ...]:
        """The force sensors flagged so far (indices in rows, as every index it reports)."""
        return tuple(self._faults)

    def set_calibration(self, calibration: Calibration) -> None:
        """Use new standing offsets and gyro bias from the next sample on.

        The Kalman filter's bias state moves by the same amount as the subtracted bias, so a
        filter that had already learnt the bias does not have to unlearn it (no transient).
        """
        delta = calibration.gyro_bias_rad_s - self.calibration.gyro_bias_rad_s
        self._kalman.shift_bias(-delta)
        self.calibration = calibration
        # the gyro integration starts again from the zeroed pose (its drift counts from here)
        self._integrator.reset()
        self._gyro_tilt_lp.reset()

    @property
    def samples_seen(self) -> int:
        return self._n_seen

    @property
    def method(self) -> TiltMethod:
        """The tilt method in use (``config.tilt_method``)."""
        return self._method

    @property
    def tilt_stage(self) -> TiltStage:
        """The tilt method's causal stage this pipeline runs."""
        return self._kalman

    def process(
        self, adc_counts: np.ndarray, lost_before: np.ndarray | None = None
    ) -> PipelineBlock:
        """``lost_before[i]``: frames lost just before row ``i`` (None: none lost)."""
        adc = np.asarray(adc_counts)
        if adc.ndim != 2 or adc.shape[1] != N_CHANNELS:
            raise ValueError(f"expected raw ADC counts of shape (N, {N_CHANNELS}), got {adc.shape}")
        n = adc.shape[0]
        start = self._n_seen
        restarts = np.empty(0, dtype=np.int64)
        fill = np.zeros(n, dtype=np.int64)  # lost frames filled in before each row (bridged)
        if lost_before is not None:
            lost = np.asarray(lost_before)
            if lost.shape != (n,):
                raise ValueError(f"lost_before must have shape ({n},), got {lost.shape}")
            lost = lost.astype(np.int64)
            restarts = restart_rows(lost, self.config.fs_hz)
            if start == 0:
                restarts = restarts[restarts > 0]  # what was lost before the start is no gap
            # (a later block's first row is bridged from the block before)
            fill = bridged_fill(np.r_[0, lost], self.config.fs_hz)[1:]
            if start == 0 and n:
                fill[0] = 0  # nothing to interpolate from
        out = {name: np.empty((n, *(shape if self.joints or not name.startswith("joint_")
                                    else (0,))), dtype=dt)
               for name, shape, dt in _PER_SAMPLE}  # fmt: skip
        settling = np.empty(n, dtype=bool)
        ev = _BlockEvents()
        cuts = sorted({*range(0, n, _SUB_BLOCK), *restarts.tolist(), n})
        restart_set = set(restarts.tolist())
        for a, b in itertools.pairwise(cuts):
            if a in restart_set:
                self._restart(start + a)
            sl = slice(a, b)
            phys, pick = self._samples(adc[sl], fill[sl], start + a)
            self._process_into(phys, pick, out, sl, ev)
            settling[sl] = np.arange(start + a, start + b) < self._settle_until
        self._n_seen = start + n
        empty = np.empty(0, dtype=np.int64)
        bias = self._kalman.bias_rad_s
        return PipelineBlock(
            start_idx=start,
            heel_strike_idx=np.concatenate(ev.hs) if ev.hs else empty,
            toe_off_idx=np.concatenate(ev.to) if ev.to else empty,
            kalman_bias_rad_s=np.zeros(4) if bias is None else bias,
            settling=settling,
            restart_idx=restarts + start,
            gyro_heel_strike_idx=tuple(ev.gyro_hs),
            gyro_toe_off_idx=tuple(ev.gyro_to),
            fsr_faults=tuple(ev.faults),
            event_source=self.event_source,
            **out,
        )

    def _samples(
        self, adc: np.ndarray, fill: np.ndarray, first_row: int
    ) -> tuple[_Samples, np.ndarray | None]:
        """The rows in physical units with the bridged lost frames filled in (module doc,
        "Gaps"), a C-contiguous array per channel group (the stages take them without a copy),
        and where the rows are among those samples (None: no frame filled in). Records the row
        <-> sample map of the filled frames."""
        groups = []
        pos = None
        last: Sequence[np.ndarray | None] = (
            [None] * len(_GROUPS) if self._last_phys is None else self._last_phys
        )
        for cols, prev in zip(_GROUPS, last, strict=True):
            ext, pos = fill_lost(kernels.to_physical(self.table, adc, cols), fill, prev)
            groups.append(ext)
        if pos is not None:
            filled = self._gap_filled[-1] if self._gap_filled else 0
            for i in np.flatnonzero(fill):
                filled += int(fill[i])
                self._gap_rows.append(first_row + int(i))
                self._gap_samples.append(first_row + int(i) + filled)
                self._gap_filled.append(filled)
        if len(adc):  # (a row's samples end with the row itself)
            self._last_phys = [x[-1].copy() for x in groups]
        self._n_fed += len(groups[0])
        return _Samples(*groups), pos

    def _row_of(self, sample: int) -> int:
        """The row of a sample index: a filled-in frame maps to the row after it."""
        k = bisect.bisect_right(self._gap_samples, sample) - 1
        row = sample - (self._gap_filled[k] if k >= 0 else 0)
        if k + 1 < len(self._gap_rows):
            row = min(row, self._gap_rows[k + 1])
        return row

    def _rows_of(self, samples: np.ndarray) -> np.ndarray:
        """:meth:`_row_of` for each (int64 array; the same array when nothing was filled)."""
        if not self._gap_rows or not len(samples):
            return np.asarray(samples, dtype=np.int64)
        return np.fromiter((self._row_of(int(x)) for x in samples), np.int64, len(samples))

    def _fault_in_rows(self, f: FsrFault) -> FsrFault:
        """A fault with its indices in rows. Its decision sample may not have been fed yet: it
        is dated the decision delay after the row of the closing heel strike it was decided on,
        which any split of the rows into blocks dates alike."""
        d = self._decision_delay
        return replace(f, stride_start_idx=self._row_of(f.stride_start_idx),
                       decided_idx=self._row_of(f.decided_idx - d) + d)  # fmt: skip

    def _process_into(
        self,
        phys: _Samples,
        pick: np.ndarray | None,
        out: dict[str, np.ndarray],
        sl: slice,
        ev: _BlockEvents,
    ) -> None:
        """Run the stages over ``phys`` (samples) and write the rows ``pick`` of them (all when
        None) into ``out[sl]``; the events found, in rows, into ``ev``."""
        cal = self.calibration
        ax = self._acc_x_lp.process(phys.acc_x)
        az = self._acc_z_lp.process(phys.acc_z)
        fsr = self._fsr_lp.process(phys.fsr)
        gyro = cal.apply_gyro(phys.gyro)
        tilt_acc = accel_tilt(ax, az)
        tilt_gyro = self._gyro_tilt_lp.process(
            self._integrator.process(gyro, initial_rad=tilt_acc[0])
        )
        tilt_kalman = self._kalman.process(
            TiltInput(phys.acc_x, phys.acc_z, tilt_acc, gyro)
        )
        gait = self._detector.process(fsr)
        rows = slice(None) if pick is None else pick
        o = out
        o["acc_ms2"][sl, :, 0] = ax[rows]
        o["acc_ms2"][sl, :, 1] = az[rows]
        o["gyro_rad_s"][sl] = gyro[rows]
        o["fsr_counts"][sl] = fsr[rows]
        o["tilt_kalman_continuous_rad"][sl] = tilt_kalman[rows]
        for name, tilt in (
            ("acc", tilt_acc),
            ("gyro", tilt_gyro),
            ("kalman", tilt_kalman),
        ):  # cal.apply_tilt and joint_angles, into the block's rows
            kernels.zeroed_tilts(tilt if pick is None else tilt[pick], cal.tilt_offset_rad,
                                 o[f"tilt_{name}_rad"][sl],
                                 o[f"joint_{name}_rad"][sl] if self.joints else None)  # fmt: skip
        o["heel_loaded"][sl] = gait.heel_loaded[rows]
        o["toe_loaded"][sl] = gait.toe_loaded[rows]
        o["phase"][sl] = gait.phase[rows]
        ev_in = EventInput(gait, gyro)
        fsr_ev = self._fsr_events.process(ev_in)
        hs_idx, to_idx = fsr_ev.heel_strike_idx, fsr_ev.toe_off_idx
        if self.config.fsr_check:
            hs_idx, to_idx = self._cross_check(ev_in, hs_idx, to_idx, ev)
        ev.hs.append(self._rows_of(hs_idx))
        ev.to.append(self._rows_of(to_idx))

    def _cross_check(
        self, ev_in: EventInput, hs_idx: np.ndarray, to_idx: np.ndarray, ev: _BlockEvents
    ) -> tuple[np.ndarray, np.ndarray]:
        """Foot-gyro events, the FSR check, and the events reported (sample indices in and
        out; the switch to the gyro's events is at a row)."""
        g = self._gyro_events.process(ev_in)
        g_hs, g_to = g.heel_strike_idx, g.toe_off_idx
        heel_loaded, toe_loaded = ev_in.contacts.heel_loaded, ev_in.contacts.toe_loaded
        ev.gyro_hs.extend(int(i) for i in self._rows_of(g_hs))
        ev.gyro_to.extend(int(i) for i in self._rows_of(g_to))
        faults = [self._fault_in_rows(f) for f in
                  self._fsr_monitor.process(heel_loaded, toe_loaded, g_hs, g_to)]  # fmt: skip
        ev.faults.extend(faults)
        self._faults.extend(faults)
        if faults and self._switch_idx is None:
            self._switch_idx = faults[0].decided_idx
        if self._switch_idx is None:
            return hs_idx, to_idx
        # FSR events before the switch (already delivered), gyro events from it on
        k = self._switch_idx
        return (
            np.concatenate([hs_idx[self._rows_of(hs_idx) < k], g_hs[self._rows_of(g_hs) >= k]]),
            np.concatenate([to_idx[self._rows_of(to_idx) < k], g_to[self._rows_of(g_to) >= k]]),
        )


# the channel groups the stages take, each as an array of its own
_GROUPS = (ACC_X_IDX, ACC_Z_IDX, GYRO_IDX, FSR_IDX)


class _Samples(NamedTuple):
    """A block's samples in physical units, per channel group (C-contiguous (N, k) each)."""

    acc_x: np.ndarray
    acc_z: np.ndarray
    gyro: np.ndarray
    fsr: np.ndarray


@dataclass
class _BlockEvents:
    """What one :meth:`Pipeline.process` call found, in rows."""

    hs: list[np.ndarray] = field(default_factory=list)
    to: list[np.ndarray] = field(default_factory=list)
    gyro_hs: list[int] = field(default_factory=list)
    gyro_to: list[int] = field(default_factory=list)
    faults: list[FsrFault] = field(default_factory=list)
