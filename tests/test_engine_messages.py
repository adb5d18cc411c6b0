"""The recorder's messages (``gaitmon.engine.messages``): each kind reaches its writer call, in
the order queued, and a message cannot change after it is queued."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.engine.messages import (
    AddMarker,
    AppendBlock,
    LogCalibration,
    LogConfig,
    Stop,
    UpdateLink,
)
from gaitmon.engine.recorder import Recorder
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import FrameKind


def _block(n: int, lost_at: dict[int, int] | None = None) -> SampleBlock:
    lost = np.zeros(n, np.int64)
    for i, k in (lost_at or {}).items():
        lost[i] = k
    return SampleBlock(kind=FrameKind.RAW, seq=np.arange(n, dtype=np.int64),
                       host_time_s=np.zeros(n), wall_offset_s=0.0, lost_before=lost,
                       adc=np.zeros((n, 14), np.uint16))  # fmt: skip


class CallLog:
    """A session writer that notes each call."""

    def __init__(self) -> None:
        self.path = "log.h5"
        self.header = SimpleNamespace(sample_rate_hz=100.0)
        self.rows = 0
        self.bytes_written = 0
        self.calls: list[tuple[object, ...]] = []

    def append(self, samples, processed=None, *, event_offset=0):
        self.rows += len(samples)
        self.calls.append(("append", int(samples.seq[0]), len(samples)))

    def add_gap(self, n_lost, duration_s, reason):
        self.calls.append(("gap", n_lost, duration_s, reason))

    def add_marker(self, label, sample_idx=None):
        self.calls.append(("marker", label, sample_idx))

    def log_config(self, config):
        self.calls.append(("config", config))

    def log_calibration(self, cal):
        self.calls.append(("calibration", cal))

    def update_link(self, stats, reconnects_base=0):
        self.calls.append(("link", stats))

    def maybe_flush(self):
        pass

    def close(self, *, stop_reason="user", derive=None):
        # derive: what gaitmon.finish.close_recording hands the writer to store /smoothed
        # and /strides (a call log stores nothing to derive from)
        self.calls.append(("close", stop_reason))


def test_each_message_reaches_its_writer_call_in_order():
    w = CallLog()
    rec = Recorder(w, queue_max=10)  # type: ignore[arg-type]
    cfg, cal = PipelineConfig(), Calibration.identity()
    stats = object()
    assert rec.put_block(AppendBlock(_block(5)))
    rec.put(AddMarker("next row"))
    rec.put(AddMarker("on row 2", row=2))
    rec.put(LogConfig(cfg))
    rec.put(LogCalibration(cal))
    # 3 frames lost before sample 2: a gap there, with the block's reason
    assert rec.put_block(AppendBlock(_block(4, {2: 3}), gap_reason="link lost: reconnected"))
    rec.put(UpdateLink(stats))  # type: ignore[arg-type]
    rec.put(Stop("duration"))
    rec.thread.join(5)
    assert not rec.alive and rec.progress.finished and rec.progress.error == ""
    assert w.calls == [
        ("append", 0, 5),
        ("marker", "next row", None),
        ("marker", "on row 2", 2),
        ("config", cfg),
        ("calibration", cal),
        ("append", 0, 2),
        ("gap", 3, 0.03, "link lost: reconnected"),
        ("append", 2, 2),
        ("link", stats),
        ("close", "duration"),
    ]
    assert rec.progress.rows == 9


def test_a_gap_before_the_first_row_of_a_later_block_takes_its_own_reason():
    w = CallLog()
    rec = Recorder(w, queue_max=10)  # type: ignore[arg-type]
    assert rec.put_block(AppendBlock(_block(3)))
    assert rec.put_block(AppendBlock(_block(3, {0: 7}), first_gap_reason="frames lost: queue"))
    rec.put(Stop())
    rec.thread.join(5)
    assert ("gap", 7, 0.07, "frames lost: queue") in w.calls
    assert w.calls[-1] == ("close", "user")


def test_messages_are_frozen():
    m = AddMarker("a", row=1)
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.row = 2  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        Stop().reason = "x"  # type: ignore[misc]
