"""The engine's parts on their own: the row map, the recorder thread and the live gait panel."""

import dataclasses
import threading

import numpy as np

from gaitmon.dsp.gait import Stride
from gaitmon.dsp.pipeline import Pipeline, PipelineConfig
from gaitmon.engine.buffers import RingBuffer
from gaitmon.engine.live_gait import LiveGait
from gaitmon.engine.messages import AppendBlock, Stop
from gaitmon.engine.recorder import Recorder
from gaitmon.engine.rows import RowMap
from gaitmon.io.device import SampleBlock
from gaitmon.io.protocol import FrameKind


def raw_block(seq0: int, n: int, lost_first: int = 0) -> SampleBlock:
    lost = np.zeros(n, np.int64)
    lost[0] = lost_first
    return SampleBlock(
        kind=FrameKind.RAW,
        seq=np.arange(seq0, seq0 + n, dtype=np.int64),
        host_time_s=np.zeros(n),
        wall_offset_s=0.0,
        lost_before=lost,
        adc=np.full((n, 14), 2048, np.uint16),
    )


def test_event_rows_skip_the_rows_a_full_queue_dropped():
    rows = RowMap()
    rows.record_offset = 100  # row 0 = engine sample 100
    rows.dropped(raw_block(0, 10), None, 0, start=150)  # engine samples 150..159 never rows
    got = rows.event_rows(np.array([90, 120, 149, 150, 159, 160, 170]))
    # before row 0 and inside the dropped range: not in the file; after it: 10 rows earlier
    np.testing.assert_array_equal(got, [20, 49, 50, 60])


def test_a_dropped_block_becomes_a_gap_and_its_earlier_events_go_with_the_next_block():
    p = Pipeline(PipelineConfig()).process(raw_block(0, 10).adc)
    rows = RowMap()
    rows.record_offset = 0
    # the queue refused samples 40..49; the pipeline confirmed a heel strike at 35 with them
    refused = dataclasses.replace(p, heel_strike_idx=np.array([35, 45]))
    rows.dropped(raw_block(40, 10, lost_first=2), refused, 0, start=40)
    nxt = dataclasses.replace(p, heel_strike_idx=np.array([52]))
    out, p_rows, why = rows.outgoing(raw_block(50, 10), nxt, 0)
    assert out.lost_before is not None and out.lost_before[0] == 12  # 10 dropped + 2 lost
    assert why == "frames lost: recorder queue full"
    assert p_rows is not None
    np.testing.assert_array_equal(p_rows.heel_strike_idx, [35, 42])  # 52 - 10 dropped rows
    rows.handed_over(with_events=True)
    assert rows.carry_lost == 0 and rows.carry_reason == ""
    assert rows.carry_events == {"heel_strike_idx": [], "toe_off_idx": []}


def test_a_carried_loss_is_kept_on_a_block_that_does_not_state_its_losses():
    # a block with lost_before=None (not every source states them) used to drop the carry
    rows = RowMap()
    rows.record_offset = 0
    rows.dropped(raw_block(40, 10), None, 0, start=40)
    bare = dataclasses.replace(raw_block(50, 10), lost_before=None)
    out, _p, why = rows.outgoing(bare, None, 0)
    assert out.lost_before is not None
    np.testing.assert_array_equal(out.lost_before, [10] + [0] * 9)
    assert why == "frames lost: recorder queue full"


class FakeWriter:
    def __init__(self, fail_on_append: bool = False, gate: threading.Event | None = None):
        self.path = "fake.h5"
        self.rows = 0
        self.bytes_written = 0
        self.closed_with = ""
        self.fail_on_append = fail_on_append
        self.gate = gate

    def append(self, samples, processed, event_offset=0):
        if self.gate is not None:
            self.gate.wait(10)
        if self.fail_on_append:
            raise OSError("No space left on device")
        self.rows += len(samples)
        self.bytes_written += 100 * len(samples)

    def maybe_flush(self):
        pass

    def close(self, stop_reason="", derive=None):
        # the recorder closes through gaitmon.finish.close_recording, which hands the writer
        # the step that derives /smoothed and /strides; a writer that stores nothing skips it
        self.closed_with = stop_reason
        self.derive = derive


def test_the_recorder_reports_rows_bytes_and_a_clean_finish():
    w = FakeWriter()
    rec = Recorder(w, queue_max=10)
    assert rec.put_block(AppendBlock(raw_block(0, 7)))
    rec.put(Stop("user"))
    rec.thread.join(5)
    assert not rec.alive
    assert rec.progress.rows == 7 and rec.progress.file_bytes == 700
    assert rec.progress.finished and rec.progress.error == ""
    assert w.closed_with == "user" and rec.dropped_blocks == 0


def test_the_recorder_counts_refused_blocks_and_reports_a_write_error():
    gate = threading.Event()
    w = FakeWriter(fail_on_append=True, gate=gate)
    rec = Recorder(w, queue_max=1)
    block = AppendBlock(raw_block(0, 5))
    assert rec.put_block(block)
    # the first block is with the (held) writer or waiting: either way at most one more fits
    refused = sum(not rec.put_block(block) for _ in range(3))
    assert refused >= 2 and rec.dropped_blocks == refused
    gate.set()
    rec.put(Stop("user"))
    rec.thread.join(5)
    assert rec.progress.error == "No space left on device" and rec.progress.finished
    assert w.closed_with.startswith("error: ")


def test_live_gait_normalises_a_finished_stride_from_the_ring():
    fs_hz = 100.0
    ring = RingBuffer(500)
    n = 300
    t = np.arange(n) / fs_hz
    knee = np.linspace(0.0, 60.0, n)
    ring.append({"t_s": t, "host_time_s": t, "idx": np.arange(n, dtype=float),
                 "joint_kalman_deg": np.stack([knee] * 3, 1)})  # fmt: skip
    gait = LiveGait(fs_hz, cycle_strides=4)
    assert gait.status(ring.latest(n), n).n_strides == 0

    def stride(a, b):
        return Stride(
            start_idx=a, end_idx=b, toe_off_idx=a + 60, stride_time_s=1.0, stance_time_s=0.6,
            swing_time_s=0.4, stance_pct=60.0, swing_pct=40.0,
        )  # fmt: skip

    # the first stride since the start is start-up, as the first of a recording (analysis)
    gait.add(np.array([50, 150, 250]), np.array([110, 210]), [stride(50, 150), stride(150, 250)],
             np.empty(0, np.int64), ring=ring, samples_total=n)  # fmt: skip
    hs, to = gait.events_since(1.0)
    np.testing.assert_allclose(hs, [1.5, 2.5])
    assert len(to) == 2
    status = gait.status(ring.latest(n), n)
    assert status.n_strides == 2 and status.cycles_deg.shape == (1, 101, 3)
    assert [r for _, r in gait.excluded] == ["first stride"]
    np.testing.assert_allclose(status.cycles_deg[0, [0, -1], 1], [knee[150], knee[250]])
    assert len(status.current_deg) == n - 250  # samples since the last heel strike
