"""The simulated unit's log of every data frame it produced (delivered or not): frame number,
sample index and kind, 17 bytes a frame in growable typed arrays. The ground truth maps a
recording's rows back to the samples the unit generated through it (``io/sim/truth.py``)."""

from __future__ import annotations

from array import array

import numpy as np


class FrameLog:
    def __init__(self) -> None:
        self._frame = array("q")
        self._sample = array("q")
        self._kind = array("B")

    def extend(self, frame_nos: np.ndarray, sample_idx: np.ndarray, kind: int) -> None:
        self._frame.extend(frame_nos.tolist())
        self._sample.extend(sample_idx.tolist())
        self._kind.extend([int(kind)] * len(frame_nos))

    def arrays(self, copy: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(frame_no, sample_idx, kind). ``copy=False``: views of the log itself (no copy), for
        a unit that produces no more (the log cannot grow while they are held)."""
        if not copy:
            return (np.frombuffer(self._frame, dtype=np.int64),
                    np.frombuffer(self._sample, dtype=np.int64),
                    np.frombuffer(self._kind, dtype=np.uint8))  # fmt: skip
        return (np.array(self._frame, dtype=np.int64), np.array(self._sample, dtype=np.int64),
                np.array(self._kind, dtype=np.uint8))  # fmt: skip
