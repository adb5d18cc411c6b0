"""Force-sensor faults, found by checking each FSR against the strides the foot gyro sees.

Force sensors break (never load), saturate or short (never unload) and drift (load at the wrong
time). The foot gyro's strides (gaitmon.dsp.gyro_events) give an independent clock: for each gyro
stride k (heel strike HS_k, the following toe off TO_k, next heel strike HS_k+1), each sensor is
checked on its debounced loaded state:

* "never loads": not one loaded sample between HS_k and TO_k (stance);
* "never unloads": loaded for more than 90 % of the swing, TO_k .. HS_k+1;
* "disagrees with the foot gyro": the heel is not loaded anywhere within ``tolerance_s`` before
  to 2 x ``tolerance_s`` after HS_k, or the toe is not loaded anywhere within 2 x ``tolerance_s``
  before to ``tolerance_s`` after TO_k.

A sensor that fails the same check in ``strides_to_flag`` (3) consecutive gyro strides is flagged
as faulty; the flag stays for the rest of the record. The flag's ``decided_idx`` is the gyro
stride's closing heel strike plus ``decision_delay`` samples (the gyro detector's latency): a
deterministic sample index, so a pipeline that switches its event source there behaves the same in
any chunking.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SENSORS = ("heel", "toe")


@dataclass(frozen=True)
class FsrFault:
    sensor: str  # heel | toe
    reason: str  # never loads | never unloads | disagrees with the foot gyro
    stride_start_idx: int  # gyro heel strike of the first of the failing strides
    decided_idx: int  # sample index from which the fault is known

    def message(self) -> str:
        return f"{self.sensor} force sensor {self.reason}: gait events from the foot gyro"


class FsrMonitor:
    """Streaming FSR check (module doc): feed loaded flags and gyro events, get new faults."""

    def __init__(
        self, fs_hz: float = 100.0, strides_to_flag: int = 3, tolerance_s: float = 0.15,
        decision_delay: int = 0,
    ) -> None:  # fmt: skip
        if strides_to_flag < 1:
            raise ValueError(f"strides_to_flag must be >= 1, got {strides_to_flag}")
        self.fs_hz = float(fs_hz)
        self.strides_to_flag = int(strides_to_flag)
        self.tol = max(1, round(tolerance_s * fs_hz))
        self.decision_delay = int(decision_delay)
        self.reset()

    def reset(self) -> None:
        self._loaded = np.zeros((0, 2), dtype=bool)  # from absolute index self._start
        self._start = 0
        self._seen = 0
        self._hs = np.empty(0, dtype=np.int64)  # the gyro's heel strikes and toe offs to come
        self._to = np.empty(0, dtype=np.int64)
        self._runs = {(s, r): 0 for s in SENSORS for r in _REASONS}
        self.faults: list[FsrFault] = []
        self._first_fail: dict[tuple[str, str], int] = {}

    @property
    def faulty(self) -> tuple[str, ...]:
        return tuple(f.sensor for f in self.faults)

    def process(
        self, heel_loaded: np.ndarray, toe_loaded: np.ndarray,
        gyro_hs_idx: np.ndarray, gyro_to_idx: np.ndarray,
    ) -> list[FsrFault]:  # fmt: skip
        """New faults found with this block (their ``decided_idx`` may lie in a later block)."""
        block = np.stack([np.asarray(heel_loaded, bool), np.asarray(toe_loaded, bool)], axis=1)
        self._loaded = np.concatenate([self._loaded, block.reshape(-1, 2)])
        self._seen += len(block)
        self._hs = np.concatenate([self._hs, np.asarray(gyro_hs_idx, dtype=np.int64)])
        self._to = np.concatenate([self._to, np.asarray(gyro_to_idx, dtype=np.int64)])
        if np.any(self._to[1:] < self._to[:-1]):
            self._to = np.sort(self._to)  # (the detector gives them in time order)
        # a stride HS_k .. HS_k+1 is checked once the loaded flags reach its closing heel strike
        # (the first k in order); its toe-off: the first after HS_k (the toe-offs passed so far
        # never counted again), if before HS_k+1
        hs = self._hs
        waiting = hs[1:] + 2 * self.tol > self._seen
        k = int(np.argmax(waiting)) if waiting.any() else len(waiting)
        t = np.maximum.accumulate(np.searchsorted(self._to, hs[:k], side="right"))
        has = t < len(self._to)
        to = self._to[np.minimum(t, len(self._to) - 1)] if len(self._to) else t
        found = has & (to < hs[1 : k + 1])
        strides = np.stack([hs[:k][found], to[found], hs[1 : k + 1][found]], axis=1)
        passed = int(t[-1]) if k else 0  # the toe-offs up to the last stride's first heel strike
        self._hs, self._to = hs[k:], self._to[passed:]
        new = self._check(strides) if len(strides) else []
        keep = max(self._start, (int(self._hs[0]) if len(self._hs) else self._seen) - 3 * self.tol)
        self._loaded = self._loaded[keep - self._start :]
        self._start = keep
        return new

    def _counts(self, cs: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, ...]:
        """(loaded samples, samples) in [a, b) per row, from the prefix sums of one column."""
        lo = np.clip(a - self._start, 0, len(cs) - 1)
        hi = np.clip(b - self._start, 0, len(cs) - 1)
        hi = np.maximum(hi, lo)
        return cs[hi] - cs[lo], hi - lo

    def _check(self, st: np.ndarray) -> list[FsrFault]:
        """Check strides (rows hs0, to, hs1) in order; vectorised counts, then the run logic."""
        found: list[FsrFault] = []
        tol = self.tol
        hs0, to, hs1 = st[:, 0], st[:, 1], st[:, 2]
        fails: dict[str, dict[str, np.ndarray]] = {}
        for col, sensor in enumerate(SENSORS):
            cs = np.concatenate([[0], np.cumsum(self._loaded[:, col], dtype=np.int64)])
            stance, _ = self._counts(cs, hs0, to)
            swing, swing_n = self._counts(cs, to, hs1)
            if sensor == "heel":
                near, _ = self._counts(cs, hs0 - tol, hs0 + 2 * tol)
            else:
                near, _ = self._counts(cs, to - 2 * tol, to + tol)
            fails[sensor] = {
                "never loads": stance == 0,
                "never unloads": (swing_n > 0) & (swing > 0.9 * swing_n),
                "disagrees with the foot gyro": near == 0,
            }
        faulty = set(self.faulty)
        checked = [sensor for sensor in SENSORS if sensor not in faulty]
        if not any(fails[sensor][reason].any() for sensor in checked for reason in _REASONS):
            for sensor in checked:  # every stride passed: what the loop below ends with
                for reason in _REASONS:
                    self._runs[sensor, reason] = 0
            return found
        for k in range(len(st)):
            for sensor in SENSORS:
                if sensor in faulty:
                    continue
                for reason in _REASONS:
                    key = (sensor, reason)
                    if fails[sensor][reason][k]:
                        if self._runs[key] == 0:
                            self._first_fail[key] = int(hs0[k])
                        self._runs[key] += 1
                    else:
                        self._runs[key] = 0
                for reason in _REASONS:  # the most specific reason first
                    key = (sensor, reason)
                    if self._runs[key] >= self.strides_to_flag:
                        fault = FsrFault(
                            sensor, reason, self._first_fail[key],
                            int(hs1[k]) + self.decision_delay,
                        )  # fmt: skip
                        self.faults.append(fault)
                        found.append(fault)
                        faulty.add(sensor)
                        break
        return found


_REASONS = ("never loads", "never unloads", "disagrees with the foot gyro")
