"""The simulated unit's log of every data frame it produced (delivered or not): frame number,
sample index and kind. The ground truth maps a recording's rows back to the samples the unit
generated through it (``io/sim/truth.py``).

Kept as runs: frames whose numbers and samples both step by one, of one kind, are one run
(first frame, first sample, length, kind; 25 bytes). The unit numbers its frames in order and
sends its samples in order, so a recording has a run per non-data frame or fault, not a row
per frame: the log of an 8-hour recording held 17 bytes a frame (49 MB, growing ~6 MB an hour
in the recording process, issue 28); its runs take kilobytes."""

from __future__ import annotations

from array import array

import numpy as np


class FrameLog:
    def __init__(self) -> None:
        self._frame0 = array("q")  # each run's first frame number
        self._sample0 = array("q")  # its first sample index
        self._length = array("q")  # its frames
        self._kind = array("B")  # their kind
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def extend(self, frame_nos: np.ndarray, sample_idx: np.ndarray, kind: int) -> None:
        frames = np.asarray(frame_nos, dtype=np.int64).ravel()
        samples = np.asarray(sample_idx, dtype=np.int64).ravel()
        if len(frames) != len(samples):
            raise ValueError(f"{len(frames)} frame numbers for {len(samples)} samples")
        if not len(frames):
            return
        kind = int(kind)
        # where a run breaks: either number does not step by one
        cut = np.flatnonzero((np.diff(frames) != 1) | (np.diff(samples) != 1)) + 1
        starts = np.concatenate(([0], cut))
        lengths = np.diff(np.concatenate((starts, [len(frames)])))
        first = 0
        if self._length:  # the first run may continue the last one
            n_last = self._length[-1]
            if (self._kind[-1] == kind and frames[0] == self._frame0[-1] + n_last
                    and samples[0] == self._sample0[-1] + n_last):  # fmt: skip
                self._length[-1] = n_last + int(lengths[0])
                first = 1
        self._frame0.extend(frames[starts[first:]].tolist())
        self._sample0.extend(samples[starts[first:]].tolist())
        self._length.extend(lengths[first:].tolist())
        self._kind.extend([kind] * (len(starts) - first))
        self._n += len(frames)

    def _runs(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return (np.frombuffer(self._frame0, dtype=np.int64) if self._frame0 else
                np.empty(0, np.int64),
                np.frombuffer(self._sample0, dtype=np.int64) if self._sample0 else
                np.empty(0, np.int64),
                np.frombuffer(self._length, dtype=np.int64) if self._length else
                np.empty(0, np.int64),
                np.frombuffer(self._kind, dtype=np.uint8) if self._kind else
                np.empty(0, np.uint8))  # fmt: skip

    def arrays(self, copy: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(frame_no, sample_idx, kind) of every frame logged, new arrays (17 bytes a frame;
        ``copy`` is kept for callers that asked for views: the runs have none to give)."""
        f0, s0, length, kind = self._runs()
        if not self._n:
            return np.empty(0, np.int64), np.empty(0, np.int64), np.empty(0, np.uint8)
        at = np.concatenate(([0], np.cumsum(length)[:-1]))  # each run's first position
        step = np.arange(self._n, dtype=np.int64) - np.repeat(at, length)
        return (np.repeat(f0, length) + step, np.repeat(s0, length) + step,
                np.repeat(kind, length))  # fmt: skip

    def samples_of(self, frame_nos: np.ndarray) -> np.ndarray:
        """The sample index of each of ``frame_nos`` (-1 where no frame of that number was
        logged), from the runs: no array of every frame."""
        seq = np.asarray(frame_nos, dtype=np.int64)
        f0, s0, length, _ = self._runs()
        if not len(f0):
            return np.full(seq.shape, -1, dtype=np.int64)
        if len(f0) > 1 and not bool(np.all(f0[1:] >= f0[:-1] + length[:-1])):
            # numbers not in order (never, from the unit): every frame, sorted
            frame_no, sample_idx, _ = self.arrays()
            order = np.argsort(frame_no, kind="stable")
            frame_no, sample_idx = frame_no[order], sample_idx[order]
            pos = np.clip(np.searchsorted(frame_no, seq), 0, len(frame_no) - 1)
            return np.where(frame_no[pos] == seq, sample_idx[pos], -1)
        run = np.clip(np.searchsorted(f0, seq, side="right") - 1, 0, len(f0) - 1)
        off = seq - f0[run]
        return np.where((off >= 0) & (off < length[run]), s0[run] + off, -1)
