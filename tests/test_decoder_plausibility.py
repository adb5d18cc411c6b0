"""Decoded values and sequence numbers that cannot be the unit's (issue 26, item 12): a frame
that passed its CRC by chance carried tilts of 199.5, 232.1 and -310.0 deg and a sequence number
that invented 4,957 lost frames. Crafted frames (encoded with the protocol's own encoder, so
their CRC is right) go through the real decoder, and through a Device over the real engine."""

from __future__ import annotations

import numpy as np
import pytest

from gaitmon.io import protocol as p
from gaitmon.io.decoder import FrameDecoder

FS = 100.0


def tilt(seq: int, acc: tuple[float, ...] = (1.0, 2.0, 3.0, 4.0)) -> p.TiltFrame:
    return p.TiltFrame(seq, np.array(acc), np.array([5.0, 6.0, 7.0, 8.0]))


def raw(seq: int) -> p.RawFrame:
    return p.RawFrame(seq, np.full(14, 2000, np.uint16))


@pytest.mark.parametrize("frame", [
    tilt(7, (199.5, 232.1, -310.0, 4.0)),
    p.JointFrame(7, np.array([10.0, 181.0, 0.0]), np.zeros(3), True, False, 1),
    p.JointFrame(7, np.zeros(3), np.array([0.0, 0.0, -200.0]), True, False, 1),
])
def test_a_crc_valid_frame_with_angles_beyond_180_deg_is_rejected_and_counted(frame):
    wire = p.encode_frame(raw(6)) + p.encode_frame(frame) + p.encode_frame(raw(8))
    dec = FrameDecoder()
    got = dec.feed(wire)
    assert [f.seq for f in got] == [6, 8]
    assert dec.stats.invalid_values == 1 and dec.stats.frames_lost == 0
    assert dec.stats.crc_failures == 0  # it passed its CRC: it is the values that are wrong


def test_angles_at_the_edge_of_the_circle_are_kept():
    edge = p.TiltFrame(7, np.array([180.0, -180.0, 179.99, np.nan]), np.zeros(4))
    dec = FrameDecoder()
    got = dec.feed(p.encode_frame(edge))
    assert len(got) == 1 and dec.stats.invalid_values == 0
    assert got[0].acc_tilt_deg[0] == 180.0 and np.isnan(got[0].acc_tilt_deg[3])


def _fed(frames_at: list[tuple[p.Frame, float]]) -> tuple[FrameDecoder, list[int]]:
    """Each frame fed alone at its host time (s), as a 100-Hz unit's bytes arrive."""
    dec = FrameDecoder(frame_rate_hz=FS)
    seqs: list[int] = []
    for frame, t in frames_at:
        seqs += [f.seq for f in dec.feed(p.encode_frame(frame), t)]
    return dec, seqs


def test_a_sequence_jump_the_time_cannot_explain_is_dropped_not_counted_lost():
    """Frames 100..109 every 10 ms, and between 104 and 105 a false accept numbered 5061 (4,957
    frames "lost" in 10 ms): it is dropped as implausible, nothing is counted lost."""
    frames = [(raw(100 + k), 0.01 * k) for k in range(5)]
    frames.append((tilt(5061), 0.045))
    frames += [(raw(105 + k), 0.05 + 0.01 * k) for k in range(5)]
    dec, seqs = _fed(frames)
    assert seqs == list(range(100, 110))
    s = dec.stats
    assert s.frames_lost == 0 and s.implausible_frames == 1 and s.sequence_resets == 0
    assert s.frames_ok == 10
    # the same stream without a clock: the old behaviour (the false accept delivered, and
    # 4,956 + 65,536 - ... counted as a loss and a reset)
    old = FrameDecoder()
    got = old.feed(b"".join(p.encode_frame(f) for f, _ in frames))
    assert 5061 in [f.seq for f in got] and old.stats.frames_lost == 4956


def test_a_backward_jump_that_the_next_frame_does_not_follow_is_dropped():
    frames = [(raw(3000 + k), 0.01 * k) for k in range(3)]
    frames += [(raw(12), 0.025), (raw(3003), 0.03), (raw(3004), 0.04)]
    dec, seqs = _fed(frames)
    assert seqs == [3000, 3001, 3002, 3003, 3004]
    assert dec.stats.implausible_frames == 1 and dec.stats.sequence_resets == 0


def test_a_real_jump_confirmed_by_the_next_frame_is_kept_and_counted_lost():
    """A burst of 300 frames lost in 0.1 s of host time (a sped-up simulator, or frames that
    arrived bunched): the next frame follows the new number, so both are delivered and the 300
    are counted lost; a reboot (backwards, confirmed) is a reset, as before."""
    frames = [(raw(k), 0.01 * k) for k in range(5)]
    frames += [(raw(305), 0.05), (raw(306), 0.06), (raw(307), 0.07)]
    frames += [(raw(2), 0.08), (raw(3), 0.09)]
    dec, seqs = _fed(frames)
    assert seqs == [0, 1, 2, 3, 4, 305, 306, 307, 2, 3]
    s = dec.stats
    assert s.frames_lost == 300 and s.implausible_frames == 0 and s.sequence_resets == 1


def test_a_jump_the_time_explains_is_taken_at_once():
    """An 8-s link cut: 800 frames missing after 8 s of silence are a plausible loss."""
    frames = [(raw(k), 0.01 * k) for k in range(3)] + [(raw(803), 8.03)]
    dec, seqs = _fed(frames)
    assert seqs == [0, 1, 2, 803] and dec.stats.frames_lost == 800
    assert dec.stats.implausible_frames == 0


# --- where the user reads it: the device's link line, the file, info, report, live -----------


class Replay:
    """A unit that sends these bytes once, then nothing."""

    def __init__(self, data: bytes) -> None:
        self.data = data

    def write(self, data: bytes) -> None:
        pass

    def read(self) -> bytes:
        out, self.data = self.data, b""
        return out


def test_the_device_drops_a_false_accept_and_says_so(tmp_path):
    """Through the real Device (its decoder runs on the host clock): the frame numbered 5061
    between 104 and 105 is dropped, no frame is counted lost, and the link line says it."""
    import time

    from gaitmon.io.device import Device
    from gaitmon.io.transport import InProcessTransport

    frames = [raw(100 + k) for k in range(5)] + [tilt(5061)] + [raw(105 + k) for k in range(5)]
    unit = Replay(b"".join(p.encode_frame(f) for f in frames))
    with Device(InProcessTransport(unit)) as dev:
        deadline = time.monotonic() + 30
        while dev.stats.decoder.frames_ok < 10 and time.monotonic() < deadline:
            time.sleep(0.01)
        stats = dev.stats
    d = stats.decoder
    assert (d.frames_ok, d.frames_lost, d.implausible_frames) == (10, 0, 1)
    assert "1 implausible frame," in stats.describe()


@pytest.fixture
def recorded_with_one(tmp_path, record_simulated):
    """A session whose link totals say 2 implausible frames, written by the session writer."""
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.pipeline import PipelineConfig
    from gaitmon.finish import close_recording
    from gaitmon.io.decoder import DecoderStats
    from gaitmon.io.device import LinkStats
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.transport import LinkState, TransportStatus

    path = tmp_path / "s.h5"
    w = SessionWriter(path, SessionHeader("raw", FS, meta=SessionMeta(), device={},
                                          config=PipelineConfig(),
                                          calibration=Calibration.identity()))  # fmt: skip
    status = TransportStatus(LinkState.CONNECTED, "")
    w.update_link(LinkStats(DecoderStats(frames_ok=50, crc_failures=3, implausible_frames=2),
                            status, True, p.FrameKind.RAW, 0, 0))  # fmt: skip
    close_recording(w)
    return path


def test_the_file_info_report_and_live_line_show_them(recorded_with_one, capsys):
    import h5py

    from gaitmon.cli import main
    from gaitmon.finish import open_session
    from gaitmon.live.health import HealthTracker
    from gaitmon.report import session_losses
    from gaitmon.ui.report_pdf.sheet import _link_line

    with h5py.File(recorded_with_one, "r") as f:
        assert int(f["link"].attrs["implausible_frames"]) == 2
    assert main(["info", str(recorded_with_one)]) == 0
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "CRC failure" in ln)
    assert "3 CRC failures, 2 implausible frames," in line
    with open_session(recorded_with_one) as s:
        losses = session_losses(s, [], ())
    assert losses.implausible_frames == 2

    class Data:
        pass

    data = Data()
    data.losses = losses  # type: ignore[attr-defined]
    assert "2 implausible frames" in _link_line(data)  # type: ignore[arg-type]
    health = HealthTracker().update(1.0, 50, 0, 3, 100.0, 0.0, implausible=2)
    assert "2 implausible" in health.text and "implausible frames" in health.tooltip
