"""Format 2 storage (docs/file-format.md, "Storage"): compressed with HDF5's own filters, the
processed floats quantised, joints and gyro rates derived, an overview pyramid for the first
view; and format 1 files (tests/data, written by the format-1 writer) still open everywhere."""

from __future__ import annotations

import itertools
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon.cli import main
from gaitmon.dsp.pipeline import Pipeline
from gaitmon.finish import close_recording, open_session
from gaitmon.io.device import SampleBlock
from gaitmon.io.overview import PeakPyramid
from gaitmon.io.protocol import FrameKind
from gaitmon.io.session import (
    CHUNK_ROWS,
    FORMAT_VERSION,
    SessionHeader,
    SessionMeta,
    SessionWriter,
    per_sample_datasets,
)
from gaitmon.io.session.layout import resolution
from gaitmon.io.sim import GaitConfig, GaitModel, SensorConfig
from gaitmon.io.sim.sensors import simulate

DATA = Path(__file__).parent / "data"
V1_RAW = DATA / "format1_raw.h5"
V1_TILT = DATA / "format1_tilt.h5"
FS = 100.0
N = 3 * CHUNK_ROWS + 777  # whole chunks and a tail


@pytest.fixture(scope="module")
def walk(tmp_path_factory) -> tuple[Path, np.ndarray, Pipeline]:
    """A raw session of N rows written by SessionWriter (format 2), and its counts."""
    counts = simulate(N, GaitModel(GaitConfig(seed=4)), SensorConfig(seed=4)).counts
    path = tmp_path_factory.mktemp("v2") / "walk.h5"
    pipe = Pipeline()
    with SessionWriter(path, SessionHeader("raw", meta=SessionMeta(patient_id="S-1"))) as w:
        for a in range(0, N, 997):
            b = min(N, a + 997)
            blk = SampleBlock(FrameKind.RAW, np.arange(a, b, dtype=np.int64),
                              10.0 + np.arange(a, b) / FS, 1.7e9,
                              lost_before=np.zeros(b - a, np.int64), adc=counts[a:b])
            w.append(blk, pipe.process(counts[a:b]))
        close_recording(w)  # /smoothed and /strides stored, as the recorder closes
    return path, counts, Pipeline()


def test_every_series_is_there_exactly_or_within_its_stated_resolution(walk, assert_stored):
    path, counts, _ = walk
    ref = Pipeline().process(counts)  # the whole record at once (= chunked, by contract)
    want = {
        "processed/tilt_deg": np.degrees(ref.tilt_kalman_rad),
        "processed/tilt_acc_deg": np.degrees(ref.tilt_acc_rad),
        "processed/tilt_gyro_deg": np.degrees(ref.tilt_gyro_rad),
        "processed/joint_deg": np.degrees(ref.joint_kalman_rad),
        "processed/joint_acc_deg": np.degrees(ref.joint_acc_rad),
        "processed/joint_gyro_deg": np.degrees(ref.joint_gyro_rad),
        "processed/acc_ms2": ref.acc_ms2,
        "processed/gyro_rad_s": ref.gyro_rad_s.astype(np.float32),
        "processed/fsr_counts": ref.fsr_counts,
        "processed/heel_loaded": ref.heel_loaded.astype(np.uint8),
        "processed/toe_loaded": ref.toe_loaded.astype(np.uint8),
        "processed/phase": ref.phase.astype(np.int8),
    }
    with open_session(path) as s:
        assert s.format_version == FORMAT_VERSION == 2 and s.n_samples == N
        assert s.dataset_names == per_sample_datasets("raw")
        assert np.array_equal(s.read("raw/adc"), counts)  # bit-exact
        assert np.array_equal(s.read("timeline/seq"), np.arange(N))
        assert np.array_equal(s.read("timeline/host_time_s"), 10.0 + np.arange(N) / FS)
        s.use_angles("live")
        for name, expected in want.items():
            got = s.read(name)
            assert got.dtype == s.dataset(name).dtype, name
            assert_stored(got, expected, name)
            # any row range reads the same rows as the whole series (chunk edges included)
            a, b = CHUNK_ROWS - 3, 2 * CHUNK_ROWS + 5
            assert np.array_equal(s.read_range(a, b, [name])[name], got[a:b], equal_nan=True)
            assert np.array_equal(s.dataset(name)[a:b], got[a:b], equal_nan=True)


def test_plain_h5py_reads_it_with_hdf5s_own_filters_and_the_documented_scales(walk):
    path, counts, _ = walk
    builtin = {h5py.h5z.FILTER_DEFLATE, h5py.h5z.FILTER_SHUFFLE}
    with h5py.File(path, "r") as f, open_session(path) as s:
        assert f.attrs["format_version"] == 2
        assert "processed/joint_deg" not in f and "processed/gyro_rad_s" not in f  # derived
        seen = []

        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.chunks and obj.shape[0] >= CHUNK_ROWS:
                plist = obj.id.get_create_plist()
                ids = {plist.get_filter(k)[0] for k in range(plist.get_nfilters())}
                assert ids == builtin, (name, ids)
                seen.append(name)

        f.visititems(visit)
        assert "raw/adc" in seen and "processed/tilt_deg" in seen
        np.testing.assert_array_equal(f["raw/adc"][()], counts)
        # the documented decoding: integer / (1 / resolution); knee = thigh - shank
        s.use_angles("live")
        for name, res in resolution().items():
            if name in f:
                got = (f[name][()] / round(1 / res)).astype(np.float32)
                s.use_angles("smoothed" if name.startswith("smoothed/") else "live")
                read_as = name.replace("smoothed/", "processed/")
                np.testing.assert_array_equal(got, s.read(read_as), err_msg=name)
        s.use_angles("live")
        tilt = f["processed/tilt_deg"][()].astype(int)
        knee = ((tilt[:, 1] - tilt[:, 2]) / 100).astype(np.float32)
        np.testing.assert_array_equal(knee, s.read("processed/joint_deg")[:, 1])


def test_the_stored_overview_is_the_pyramid_of_the_rows_read(walk):
    path, _, _ = walk
    with open_session(path) as s:
        for source in s.angle_sources:
            s.use_angles(source)
            stored = s.stored_pyramid("processed/joint_deg")
            assert stored is not None, source
            built = PeakPyramid.from_array(s.read("processed/joint_deg").reshape(N, -1))
            assert len(stored.levels) == len(built.levels)
            for (lo, hi), (lo2, hi2) in zip(stored.levels, built.levels, strict=True):
                np.testing.assert_array_equal(lo, lo2)
                np.testing.assert_array_equal(hi, hi2)
        assert s.stored_pyramid("processed/tilt_deg") is None  # only the joints are stored


def test_the_stored_overview_skips_nan_rows_as_the_pyramid_of_the_rows_read(walk, tmp_path):
    """NaN tilts (a bin partly NaN, a bin all NaN, the record's short last bin) in the stored
    overview, computed from the stored codes, as the pyramid of the angles as read."""
    from gaitmon.io.session.stored_overview import write_overview

    path = tmp_path / "nan.h5"
    shutil.copy(walk[0], path)
    nan_code = np.iinfo(np.int16).min
    with h5py.File(path, "r+") as f:
        n = f["processed/tilt_deg"].shape[0]
        for name, rows, cols in (("processed/tilt_deg", slice(35, 40), [1]),  # part of a bin
                                 ("processed/tilt_deg", slice(64, 96), [0, 1, 2, 3]),  # 2 bins
                                 ("smoothed/tilt_deg", slice(n - 3, n), [2]),  # the last bin
                                 ("smoothed/tilt_deg", slice(160, 200), [3])):  # fmt: skip
            stored = f[name][()]
            stored[rows, cols] = nan_code
            f[name][()] = stored
        write_overview(f)
    with open_session(path) as s:
        for source in s.angle_sources:
            s.use_angles(source)
            joints = s.read("processed/joint_deg")
            assert np.isnan(joints).any(), source
            stored = s.stored_pyramid("processed/joint_deg")
            assert stored is not None, source
            lo, hi = stored.levels[0]
            lo2, hi2 = PeakPyramid.from_array(joints.reshape(N, -1)).levels[0]
            np.testing.assert_array_equal(lo, lo2)
            np.testing.assert_array_equal(hi, hi2)
            assert np.isnan(lo).any() or source != "live"  # (an all-NaN bin stays NaN)


@pytest.mark.parametrize("in_order", [True, False])
def test_the_overview_of_the_rows_as_written_equals_it_read_back(walk, tmp_path, monkeypatch,
                                                                 in_order):  # fmt: skip
    """OverviewBuilder (``gaitmon process`` feeds it the tilts as it writes them, in pieces of
    any length) gives the overview read back from the rows; fed out of order, the rows are
    read back instead."""
    from gaitmon.io.session import stored_overview as so

    whole, built = tmp_path / "whole.h5", tmp_path / "built.h5"
    shutil.copy(walk[0], whole)
    shutil.copy(walk[0], built)
    with h5py.File(whole, "r+") as f:
        so.write_overview(f)
    rng = np.random.default_rng(5)
    builder = so.OverviewBuilder()
    with h5py.File(built, "r+") as f:
        for tilt in ("processed/tilt_deg", "smoothed/tilt_deg"):
            rows = f[tilt][()]
            cuts = sorted({0, len(rows), *rng.integers(0, len(rows), 40).tolist(), 7, 9})
            pieces = list(itertools.pairwise(cuts))
            if not in_order:
                pieces[1], pieces[2] = pieces[2], pieces[1]
            for a, b in pieces:
                builder.add(tilt, a, rows[a:b])
        reads: list[str] = []
        joint_codes = so._joint_codes
        monkeypatch.setattr(so, "_joint_codes", lambda f, path, a, b: reads.append(path)
                            or joint_codes(f, path, a, b))  # fmt: skip
        so.write_overview(f, builder)
    assert bool(reads) is not in_order
    with h5py.File(whole, "r") as a, h5py.File(built, "r") as b:
        for series in ("processed_joint_deg", "smoothed_joint_deg"):
            for m in ("min", "max"):
                np.testing.assert_array_equal(a["overview"][series][m][()],
                                              b["overview"][series][m][()])  # fmt: skip


def test_the_review_document_takes_the_stored_overview_without_reading_the_rows(walk):
    from gaitmon.review.model import OVERVIEW_SERIES, open_document

    path, _, _ = walk
    doc = open_document(path)
    try:
        reads = []
        ov = doc.recorded.overview
        ov._read = lambda *a: reads.append(a) or np.zeros((0, 3))  # any row read is seen
        assert ov.has_pyramid(OVERVIEW_SERIES)
        # 500 bins of 26 rows: coarser than the stored 16-row bins (finer, a short series is
        # drawn from its rows: test_review_gaps::test_a_short_series_envelope_is_its_rows)
        ov.envelope(OVERVIEW_SERIES, 1000)
        assert reads == []
    finally:
        doc.close()


def test_the_per_sample_data_take_under_52_bytes_a_row(walk):
    """The size goal (8 hours in 150 MB) as bytes a row: what grows with the session. The
    rest is a fixed ~80 KB of metadata (a few minutes' worth of rows)."""
    path, _, _ = walk
    with h5py.File(path, "r") as f:
        sizes: list[int] = []
        f.visititems(lambda _, o: sizes.append(o.id.get_storage_size())
                     if isinstance(o, h5py.Dataset) else None)  # fmt: skip
    assert sum(sizes) / N < 52  # format 1: ~200
    assert path.stat().st_size - sum(sizes) < 120_000


@pytest.mark.parametrize("fixture", [V1_RAW, V1_TILT], ids=["raw", "tilt"])
def test_format_1_files_open_as_they_were_written(fixture):
    with open_session(fixture) as s, h5py.File(fixture, "r") as f:
        assert s.format_version == 1 and s.n_samples > 500
        for name in s.dataset_names:
            s.use_angles("live")
            np.testing.assert_array_equal(s.read(name), f[name][()], err_msg=name)
        if s.mode == "raw":
            s.use_angles("smoothed")
            np.testing.assert_array_equal(s.read("processed/joint_deg"), f["smoothed/joint_deg"])
        assert s.stored_pyramid("processed/joint_deg") is None  # built from the rows


@pytest.mark.parametrize("fixture", [V1_RAW, V1_TILT], ids=["raw", "tilt"])
def test_format_1_files_through_every_command(fixture, tmp_path, capsys, qapp):
    # (qapp: the report command needs a Qt application; pytest-qt's, as the report tests use)
    from gaitmon.review.model import analyse, open_document

    src = tmp_path / fixture.name
    shutil.copyfile(fixture, src)
    assert main(["info", str(src)]) == 0
    out = capsys.readouterr().out
    assert "format 1" in out
    for fmt in ("csv", "mat", "c3d"):
        assert main(["export", str(src), "--format", fmt, "-o", str(tmp_path / f"x.{fmt}"),
                     "-q"]) == 0, fmt  # fmt: skip
    if fixture == V1_RAW:
        assert main(["report", str(src), "-o", str(tmp_path / "r.pdf")]) == 0
        assert main(["process", str(src), "-o", str(tmp_path / "p.h5")]) == 0
        with open_session(tmp_path / "p.h5") as p, open_session(src) as s:
            assert p.format_version == 1 and p.n_samples == s.n_samples
        doc = open_document(src)
        try:
            assert len(analyse(doc, doc.recorded, []).rows) > 10
        finally:
            doc.close()
    assert fixture.read_bytes() == src.read_bytes()  # nothing wrote into the recording


def test_the_event_delay_is_scipys_without_importing_scipy_signal(tmp_path):
    """The review's first view asks for the phase lag (the low-pass's DC group delay): it is
    computed with numpy alone (importing scipy.signal took 1.2 s of that view), equal to
    scipy's where scipy is accurate and to the impulse response's centroid where it is not."""
    import subprocess
    import sys

    from scipy import signal

    from gaitmon.dsp.pipeline import PipelineConfig, butterworth_dc_delay_samples

    for order in (1, 2, 3, 4):
        for fc in (0.5, 1.0, 2.5, 4.0, 6.0, 10.0, 20.0, 40.0):
            b, a = signal.butter(order, fc, fs=100.0)
            _, gd = signal.group_delay((b, a), w=[0.0], fs=100.0)
            assert butterworth_dc_delay_samples(order, fc, 100.0) == pytest.approx(gd[0],
                                                                                   rel=1e-6)
    sos = signal.butter(8, 2.0, fs=1000.0, output="sos")  # scipy's group_delay: ~0 here
    h = signal.sosfilt(sos, np.r_[1.0, np.zeros(199_999)])
    centroid = (np.arange(len(h)) * h).sum() / h.sum()
    assert butterworth_dc_delay_samples(8, 2.0, 1000.0) == pytest.approx(centroid, rel=1e-9)
    assert PipelineConfig().event_delay_samples == 6  # 2nd order, 4 Hz at 100 Hz: 5.6 samples
    code = ("import sys\nfrom gaitmon.review.model import open_document\n"
            "from gaitmon.review.view import phase_lag\n"
            f"doc = open_document({str(V1_RAW)!r})\n"
            "print(phase_lag(doc, doc.recorded), 'scipy.signal' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.split()  # fmt: skip
    assert out == [str(PipelineConfig().phase_lag_samples), "False"]


def test_a_crash_of_a_format_1_recording_is_recovered_into_format_2(tmp_path):
    """A journal (its layout did not change) left beside a format-1 file by the gaitmon
    before format 2 is rebuilt into a format-2 file with every row handed over, and the
    patient id from the old file."""
    import json
    import struct

    from gaitmon.io.journal import MAGIC, RecordType, encode_json, journal_path

    n = CHUNK_ROWS + 500
    counts = simulate(n).counts
    live, crashed = tmp_path / "live.h5", tmp_path / "crashed.h5"
    w = SessionWriter(live, SessionHeader("raw", meta=SessionMeta(patient_id="OLD-7")),
                      format_version=1)  # fmt: skip
    pipe = Pipeline()
    for a in range(0, n, 450):
        b = min(n, a + 450)
        w.append(SampleBlock(FrameKind.RAW, np.arange(a, b, dtype=np.int64), np.zeros(b - a),
                             0.0, lost_before=np.zeros(b - a, np.int64), adc=counts[a:b]),
                 pipe.process(counts[a:b]))  # fmt: skip
    w.flush()
    shutil.copyfile(live, crashed)
    raw = journal_path(live).read_bytes()
    close_recording(w)
    # the header record as the format-1 gaitmon wrote it
    assert raw[: len(MAGIC)] == MAGIC
    length = struct.unpack_from("<I", raw, len(MAGIC) + 1)[0]
    end = len(MAGIC) + 5 + length + 4
    header = json.loads(raw[len(MAGIC) + 5 : len(MAGIC) + 5 + length])
    header["format_version"] = 1
    journal_path(crashed).write_bytes(MAGIC + encode_json(RecordType.HEADER, header) + raw[end:])
    with h5py.File(crashed, "r") as f:
        assert f.attrs["format_version"] == 1
    with open_session(crashed) as s:
        assert s.recovered and s.format_version == 2 and s.n_samples == n
        assert s.meta.patient_id == "OLD-7"
        assert np.array_equal(s.read("raw/adc"), counts)


def test_long_reads_are_decoded_a_block_at_a_time_with_the_same_result(walk, monkeypatch):
    import gaitmon.io.session.reader as reader

    path, _, _ = walk
    with open_session(path) as s:
        whole = {name: s.read(name) for name in s.dataset_names}
        monkeypatch.setattr(reader, "_DECODE_ROWS", 1000)  # 13 blocks, the last one short
        for name, want in whole.items():
            np.testing.assert_array_equal(s.read(name), want, err_msg=name)
            part = s.read_range(999, 12_345, [name])[name]
            np.testing.assert_array_equal(part, want[999:12_345], err_msg=name)


def test_a_long_record_is_smoothed_in_blocks_with_the_same_angles(monkeypatch):
    """The smoother runs over a long record in blocks with context either side (its memory
    grew ~140 MB per hour): the angles stay those of one pass, well inside 0.01 deg."""
    import gaitmon.finish.smoothed as sm
    from gaitmon.dsp.calibration import Calibration
    from gaitmon.dsp.channels import DEFAULT_TABLE

    n = 30_000
    counts = simulate(n, GaitModel(GaitConfig(seed=5)), SensorConfig(seed=5)).counts
    args = (counts, DEFAULT_TABLE, Calibration.identity(), [], np.zeros(n, np.int64), FS)
    whole = sm.smoothed_angles(*args)  # n < one block: one pass
    monkeypatch.setattr(sm, "SMOOTH_BLOCK_ROWS", 7000)  # 5 blocks, the last one short
    monkeypatch.setattr(sm, "SMOOTH_OVERLAP_ROWS", 6000)  # 60 s: ~3e-5 deg measured
    blocks = sm.smoothed_angles(*args)
    for name, want in whole.items():
        err = np.abs(blocks[name].astype(np.float64) - want)
        assert err.max() < 1e-3, (name, err.max())
        assert not np.array_equal(blocks[name], want)  # (really computed in blocks)
