"""The simulated unit's frame log keeps runs, not a row per frame (issue 28: the recording
process with the simulator grew ~6 MB an hour with it), and gives the same frames and the
same frame-to-sample mapping as the per-frame log it replaces (written out here)."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from gaitmon.io.sim.frame_log import FrameLog


class _PerFrame:
    """The previous log: every frame's number, sample and kind."""

    def __init__(self) -> None:
        self.frame: list[int] = []
        self.sample: list[int] = []
        self.kind: list[int] = []

    def extend(self, frames: np.ndarray, samples: np.ndarray, kind: int) -> None:
        self.frame += frames.tolist()
        self.sample += samples.tolist()
        self.kind += [kind] * len(frames)

    def samples_of(self, seq: np.ndarray) -> np.ndarray:
        frame_no, sample_idx = np.array(self.frame, np.int64), np.array(self.sample, np.int64)
        if len(frame_no) == 0:
            return np.full(len(seq), -1, dtype=np.int64)
        if len(frame_no) > 1 and not bool(np.all(frame_no[1:] > frame_no[:-1])):
            order = np.argsort(frame_no)
            frame_no, sample_idx = frame_no[order], sample_idx[order]
        pos = np.clip(np.searchsorted(frame_no, seq), 0, len(frame_no) - 1)
        return np.where(frame_no[pos] == seq, sample_idx[pos], -1)


@pytest.mark.parametrize("seed", range(6))
def test_runs_give_the_frames_and_samples_of_the_per_frame_log(seed: int) -> None:
    rng = np.random.default_rng(seed)
    log, ref = FrameLog(), _PerFrame()
    frame, sample = int(rng.integers(0, 100)), 0
    for _ in range(60):
        n = int(rng.integers(0, 40))
        kind = int(rng.choice([1, 1, 1, 2]))
        frames = frame + np.arange(n, dtype=np.int64)
        samples = sample + np.arange(n, dtype=np.int64)
        if n > 3 and rng.random() < 0.4:  # a sample skipped or repeated inside a block
            k = int(rng.integers(1, n))
            samples[k:] += int(rng.choice([-1, 2, 5]))
        log.extend(frames, samples, kind)
        ref.extend(frames, samples, kind)
        frame += n + int(rng.choice([0, 0, 1, 3]))  # non-data frames take numbers too
        sample = int(samples[-1]) + 1 if n else sample
        sample += int(rng.choice([0, 0, 0, 4]))
    assert len(log) == len(ref.frame)
    got = log.arrays()
    for a, b, dtype in zip(got, (ref.frame, ref.sample, ref.kind),
                           (np.int64, np.int64, np.uint8), strict=True):  # fmt: skip
        assert a.dtype == dtype
        np.testing.assert_array_equal(a, np.array(b, dtype))
    seq = np.arange(-5, frame + 10, dtype=np.int64)
    np.testing.assert_array_equal(log.samples_of(seq), ref.samples_of(seq))
    np.testing.assert_array_equal(log.samples_of(seq[::-3]), ref.samples_of(seq[::-3]))


def test_an_empty_log_maps_nothing() -> None:
    log = FrameLog()
    assert len(log) == 0 and all(len(a) == 0 for a in log.arrays())
    np.testing.assert_array_equal(log.samples_of(np.arange(3)), [-1, -1, -1])


def test_frames_out_of_order_map_as_the_per_frame_log() -> None:
    log, ref = FrameLog(), _PerFrame()
    for frames in (np.arange(10, 20), np.arange(0, 5), np.arange(30, 33)):
        log.extend(frames, frames * 2, 1)
        ref.extend(frames, frames * 2, 1)
    seq = np.arange(-2, 40)
    np.testing.assert_array_equal(log.samples_of(seq), ref.samples_of(seq))


def test_a_long_recording_s_log_does_not_grow_with_its_frames() -> None:
    """An hour of frames in the unit's blocks of 50, a status frame taking a number every
    second: the runs hold ~100 bytes a second of recording at most, not 17 bytes a frame."""
    log = FrameLog()
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        frame = 0
        for a in range(0, 360_000, 50):
            log.extend(frame + np.arange(50), a + np.arange(50), 1)
            frame += 50 + (a % 100 == 50)  # a status frame every 100 samples
        grown = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert grown < 360_000 * 17 / 20, grown  # the per-frame log: 6.1 MB
    assert len(log) == 360_000
    assert log.samples_of(np.array([0, 51, frame - 1]))[0] == 0
