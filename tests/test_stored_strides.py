"""The per-stride foot-IMU measures stored at close (``/strides``,
gaitmon.finish.strides): the stored and the block-wise paths give exactly the numbers
of the whole-record computation, a stale store is never used, and files without one still get
them."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon.analysis import analyse_session
from gaitmon.cli import main
from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, DEFAULT_TABLE, GYRO_IDX
from gaitmon.dsp.gyro_events import gyro_gait_events
from gaitmon.dsp.stride_length import StrideMeasures, record_stride_measures, stride_measures
from gaitmon.finish import close_recording, open_session
from gaitmon.finish import strides as st

FS = 100.0
FIELDS = ("heel_strike_idx", "stride_length_m", "foot_clearance_m", "stride_time_s",
          "foot_flat_idx")  # fmt: skip
V1_RAW = Path(__file__).parent / "data" / "format1_raw.h5"


def assert_same(got: StrideMeasures, want: StrideMeasures) -> None:
    """Bit for bit (NaN where NaN)."""
    for k in FIELDS:
        a, b = getattr(got, k), getattr(want, k)
        assert a.shape == b.shape, k
        np.testing.assert_array_equal(a, b, err_msg=k)


def reference(path: Path, heel_strike_idx: np.ndarray | None = None) -> StrideMeasures:
    """The computation as analyse_session did it before the store: the whole record's foot
    counts converted at once (written out here, not gaitmon's conversion), stride_measures over
    the distinct recorded heel strikes inside the record."""
    with open_session(path) as s:
        cols = [int(ACC_X_IDX[3]), int(ACC_Z_IDX[3]), int(GYRO_IDX[3])]
        counts = np.asarray(s.read("raw/adc"))[:, cols].astype(np.float64)
        table = s.header.table
        phys = (counts - table.zero_counts[cols]) * table.units_per_count[cols]
        bias = np.full(len(phys), float(s.calibration.gyro_bias_rad_s[3]))
        for row, cal in sorted(s.calibration_changes, key=lambda x: x[0]):
            bias[max(0, row):] = float(cal.gyro_bias_rad_s[3])
        hs = np.unique(s.heel_strike_idx if heel_strike_idx is None else heel_strike_idx)
        return stride_measures(phys[:, 0], phys[:, 1], phys[:, 2] - bias, s.sample_rate_hz,
                               hs[hs < len(phys)])  # fmt: skip


@pytest.fixture(scope="module")
def walk(tmp_path_factory, record_simulated) -> Path:
    path = tmp_path_factory.mktemp("strides") / "walk.h5"
    return record_simulated(path, duration_s=40, standing_s=3)


@pytest.fixture
def no_compute(monkeypatch):
    """Computing the measures fails the test: they must come from the store."""

    def refuse(*_a, **_k):
        raise AssertionError("computed although /strides holds them")

    monkeypatch.setattr(st, "compute", refuse)


def computed_count(monkeypatch) -> list[int]:
    """Counts the computations (the store not used)."""
    calls: list[int] = []
    real = st.compute

    def counting(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(st, "compute", counting)
    return calls


# ---- the block-wise computation ---------------------------------------------------------------


def _walk_with_a_stop(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    from gaitmon.io.sim import GaitConfig, GaitModel
    from gaitmon.io.sim.sensors import SensorModel, realistic_sensors

    gait = GaitModel(GaitConfig(seed=seed))
    sensors = SensorModel(gait, realistic_sensors(seed))
    blocks = [sensors.next_block(2500)]
    gait.stand(25.0)  # a stop mid-walk: a stride of > 3 s, then a long search span
    blocks.append(sensors.next_block(800))
    gait.walk(sensors.position / FS + 2.0)
    blocks.append(sensors.next_block(2500))
    ph = DEFAULT_TABLE.to_physical(np.concatenate([b.counts for b in blocks]))
    gy = ph[:, GYRO_IDX[3]] - ph[100:450, GYRO_IDX[3]].mean()
    hs, _ = gyro_gait_events(gy, FS)
    return ph[:, ACC_X_IDX[3]], ph[:, ACC_Z_IDX[3]], gy, hs


def _blockwise(ax, az, gy, hs, per_block: int) -> StrideMeasures:
    reads: list[tuple[int, int]] = []

    def read(a: int, b: int):
        reads.append((a, b))
        return ax[a:b].copy(), az[a:b].copy(), gy[a:b].copy()  # nothing beyond [a, b) to see

    m = record_stride_measures(read, len(gy), FS, hs, strides_per_block=per_block)
    assert len(reads) == -(-(len(hs) - 1) // per_block)
    return m


@pytest.mark.parametrize("per_block", [1, 2, 7, 100_000])
def test_strides_a_block_at_a_time_are_those_of_the_whole_record(per_block):
    ax, az, gy, hs = _walk_with_a_stop(seed=5)
    whole = stride_measures(ax, az, gy, FS, hs)
    assert np.isnan(whole.stride_length_m).sum() >= 1  # the stride that stood
    assert_same(_blockwise(ax, az, gy, hs, per_block), whole)
    # irregular heel strikes (some missed: long strides, long search spans), some past the
    # record, one before a foot-flat can be found
    rng = np.random.default_rng(3)
    some = np.sort(np.r_[hs[rng.random(len(hs)) > 0.3], len(gy) + 40])
    assert_same(_blockwise(ax, az, gy, some, per_block), stride_measures(ax, az, gy, FS, some))


def test_a_search_span_reaching_past_the_next_heel_strikes_is_read_whole():
    """After a long stride the search span of a heel strike reaches past the next heel strike's
    span: the block must hold it, or a shorter still run wins (a different anchor)."""
    n = 1000
    gy = np.full(n, 2.0)  # moving, except in the still runs below
    for a, b in ((205, 220), (260, 340), (435, 446), (700, 760)):
        gy[a:b] = 0.0
    ax, az = np.full(n, 9.80665), np.zeros(n)
    hs = np.array([0, 200, 230, 690])  # 200's span: 60 % of 200 rows; 230's: of 30 rows
    whole = stride_measures(ax, az, gy, FS, hs)
    assert 262 <= whole.foot_flat_idx[1, 0] < 320  # in 260..320, the longest run it sees
    for per_block in (1, 2):
        assert_same(_blockwise(ax, az, gy, hs, per_block), whole)


def test_blocks_on_real_sensor_noise_give_the_same_numbers(shared_data):
    """BROAD (Laidig et al. 2021, CC BY 4.0) is no walk, but its IMU has real noise, rests and
    impacts: the block-wise computation must not change a bit of what the method makes of it."""
    from scipy.signal import resample_poly

    with h5py.File(shared_data / "broad" / "24_disturbed_tapping_A.hdf5", "r") as f:
        acc, gyr = f["imu_acc"][()], f["imu_gyr"][()]
    ax, az = (resample_poly(acc[:, i], 7, 20) for i in (0, 2))
    gy = resample_poly(gyr[:, 1], 7, 20)
    hs = np.arange(50, len(gy), 97)  # made-up "heel strikes" every 0.97 s
    whole = stride_measures(ax, az, gy, FS, hs)
    assert np.isfinite(whole.stride_length_m).sum() >= 5  # rests found: strides computed
    for per_block in (1, 3, 50):
        assert_same(_blockwise(ax, az, gy, hs, per_block), whole)


# ---- stored at close, read back ---------------------------------------------------------------


def test_a_recording_stores_the_measures_and_every_reader_gets_them_from_there(walk, no_compute):
    want = reference(walk)
    assert np.isfinite(want.stride_length_m).sum() >= 20
    with h5py.File(walk, "r") as f:
        assert f["strides/stride_length_m"].shape == want.stride_length_m.shape
        np.testing.assert_array_equal(f["strides/heel_strike_idx"][()],
                                      np.unique(f["events/heel_strike"][()]))  # fmt: skip
    with open_session(walk) as s:
        assert_same(s.foot_stride_measures(), want)
        a = analyse_session(s)
    by_start = dict(zip(want.heel_strike_idx.tolist(), want.stride_length_m.tolist(),
                        strict=True))  # fmt: skip
    got = [r for r in a.rows if np.isfinite(r.stride_length_m)]
    assert len(got) >= 20
    for r in got:
        assert r.stride_length_m == by_start[r.stride.start_idx]


def test_info_report_and_exports_are_the_same_with_and_without_the_store(walk, tmp_path, capsys,
                                                                          monkeypatch):  # fmt: skip
    bare = tmp_path / "bare.h5"
    shutil.copyfile(walk, bare)
    with h5py.File(bare, "r+") as f:
        del f["strides"]  # as a file written before the store existed
    calls = computed_count(monkeypatch)
    outs = []
    for p in (walk, bare):
        assert main(["info", str(p)]) == 0
        info = capsys.readouterr().out.split("\n", 1)[1]  # (the first line names the file)
        csv = tmp_path / f"{p.stem}.strides.csv"
        assert main(["export", str(p), "--format", "strides", "-o", str(csv), "-q"]) == 0
        outs.append((info, csv.read_text()))
        with open_session(p) as s:
            outs[-1] += (repr(analyse_session(s).rows),)  # (repr: NaN is NaN)
    assert len(calls) == 3  # the bare file's, computed for info, the export and here
    assert outs[0] == outs[1]
    assert "stride length" in outs[0][0]


def test_exclusions_do_not_touch_the_store(walk, tmp_path, no_compute):
    from gaitmon.io.session import Exclusion

    with open_session(walk) as s:
        whole = analyse_session(s, exclusions=[])
        mid = whole.rows[len(whole.rows) // 2].stride
        part = analyse_session(s, exclusions=[Exclusion(mid.start_idx, mid.end_idx + 1, "turn")])
    assert part.n_user_excluded >= 1
    for key in ("stride_length_m", "foot_clearance_m"):
        np.testing.assert_array_equal([getattr(r, key) for r in part.rows],
                                      [getattr(r, key) for r in whole.rows])  # fmt: skip


# ---- a stale store is not used -----------------------------------------------------------------


def test_process_with_other_settings_stores_the_new_strides_and_a_stale_copy_is_ignored(
    walk, tmp_path, monkeypatch
):
    new = tmp_path / "other.h5"
    assert main(["process", str(walk), "-o", str(new), "--fsr-threshold", "1400", "-q"]) == 0
    with open_session(walk) as old_s, open_session(new) as new_s:
        assert not np.array_equal(old_s.heel_strike_idx, new_s.heel_strike_idx)
    want = reference(new)
    calls = computed_count(monkeypatch)
    with open_session(new) as s:
        assert_same(s.foot_stride_measures(), want)  # process stored the new ones
    assert calls == []
    # the store of the recording (other heel strikes) copied over: not used, computed instead
    with h5py.File(walk, "r") as src, h5py.File(new, "r+") as dst:
        del dst["strides"]
        src.copy("strides", dst)
    with open_session(new) as s:
        assert_same(s.foot_stride_measures(), want)
        assert calls == [1]
        s.foot_stride_measures()  # asked again: kept, not computed again
    assert calls == [1]


@pytest.mark.parametrize("change", ["method", "calibration", "rows", "shape"])
def test_a_store_from_other_inputs_or_damaged_is_not_used(walk, tmp_path, monkeypatch, change):
    import json

    import gaitmon.dsp.stride_length as sl

    p = tmp_path / "w.h5"
    shutil.copyfile(walk, p)
    want = reference(p)
    fake = np.full(want.stride_length_m.shape, 9.99)
    with h5py.File(p, "r+") as f:
        g = f["strides"]
        g["stride_length_m"][...] = fake  # so that using the store would show
        if change == "calibration":  # the foot gyro bias said to be other than it was
            stamp = json.loads(g.attrs["computed_from"])
            stamp["gyro_bias_rad_s"][0][1] += 0.01
            g.attrs["computed_from"] = json.dumps(stamp, sort_keys=True)
        elif change == "rows":
            stamp = json.loads(g.attrs["computed_from"])
            stamp["n_rows"] -= 1
            g.attrs["computed_from"] = json.dumps(stamp, sort_keys=True)
        elif change == "shape":
            del g["foot_clearance_m"]
            g["foot_clearance_m"] = np.zeros(3)
    if change == "method":
        monkeypatch.setitem(sl.METHOD, "version", sl.METHOD_VERSION + 1)
        monkeypatch.setattr(st, "METHOD", sl.METHOD)
    with open_session(p) as s:
        got = s.foot_stride_measures()
    assert_same(got, want)
    assert not np.any(got.stride_length_m == 9.99)


def test_other_heel_strikes_than_the_stored_ones_are_computed(walk, monkeypatch):
    """Review passes the events of an in-memory reprocessing: their strides, not the stored."""
    with open_session(walk) as s:
        other = s.heel_strike_idx[::2] + 3
    want = reference(walk, other)
    calls = computed_count(monkeypatch)
    with open_session(walk) as s:
        assert_same(s.foot_stride_measures(other), want)
        recorded = s.foot_stride_measures()  # from the store
        assert_same(s.foot_stride_measures(other), want)  # back to the other: kept
        assert s.foot_stride_measures() is recorded
    assert calls == [1]


# ---- files without a store ----------------------------------------------------------------------


def test_a_format_1_file_gets_them_computed_as_before(tmp_path, monkeypatch):
    src = tmp_path / V1_RAW.name
    shutil.copyfile(V1_RAW, src)
    calls = computed_count(monkeypatch)
    with open_session(src) as s:
        got = s.foot_stride_measures()
    assert calls == [1] and len(got) >= 3
    assert_same(got, reference(src))
    assert V1_RAW.read_bytes() == src.read_bytes()  # a reader never writes


def test_recovery_stores_them(tmp_path, monkeypatch):
    from gaitmon.dsp.pipeline import Pipeline
    from gaitmon.io.device import SampleBlock
    from gaitmon.io.journal import journal_path
    from gaitmon.io.protocol import FrameKind
    from gaitmon.io.session import SessionHeader, SessionMeta, SessionWriter
    from gaitmon.io.sim.sensors import simulate

    n = 6000
    counts = simulate(n).counts
    live, crashed = tmp_path / "live.h5", tmp_path / "crashed.h5"
    w = SessionWriter(live, SessionHeader("raw", meta=SessionMeta(patient_id="R-1")))
    pipe = Pipeline()
    for a in range(0, n, 500):
        b = a + 500
        w.append(SampleBlock(FrameKind.RAW, np.arange(a, b, dtype=np.int64), np.zeros(b - a),
                             0.0, lost_before=np.zeros(b - a, np.int64), adc=counts[a:b]),
                 pipe.process(counts[a:b]))  # fmt: skip
    w.flush()
    shutil.copyfile(live, crashed)  # a kill -9 here: the file and its journal
    shutil.copyfile(journal_path(live), journal_path(crashed))
    close_recording(w)
    with h5py.File(crashed, "r") as f:
        assert "strides" not in f
    calls = computed_count(monkeypatch)
    with open_session(crashed) as s:
        assert s.recovered and s.n_samples == n
        assert "strides" in s.h5 and calls == [1]  # by the recovery
        got = s.foot_stride_measures()
    assert calls == [1] and len(got) >= 10
    assert_same(got, reference(crashed))


def test_a_session_without_raw_counts_has_none(tmp_path, record_simulated):
    path = record_simulated(tmp_path / "joint.h5", "--mode", "joint", duration_s=10, standing_s=2)
    with h5py.File(path, "r") as f:
        assert "strides" not in f
    with open_session(path) as s:
        assert s.foot_stride_measures() is None


# ---- the exclusion rule over a whole session at once -------------------------------------------


def test_the_exclusions_of_all_strides_at_once_are_the_per_stride_rule():
    """analyse_strides asks the rule for 26 000 strides at once: the same reasons as the rule,
    written out here stride by stride as it stood."""
    from gaitmon.analysis import FIRST, GAP, LAST, SETTLING, USER, stride_exclusions

    def one(start, end, k, n, gap_rows, settling, ranges):
        if k == 0:
            return FIRST
        if n is not None and k == n - 1:
            return LAST
        if np.any((gap_rows > start) & (gap_rows <= end)):
            return GAP
        if any(a <= end and b > start for a, b in settling):
            return SETTLING
        if any(a < end and b > start for a, b in ranges):
            return USER
        return ""

    rng = np.random.default_rng(7)
    start = np.cumsum(rng.integers(80, 140, 400))
    end = start + rng.integers(90, 130, 400)  # (overlapping: gait-pattern independent)
    gap_rows = np.array([start[50], start[50] + 1, end[120], start[300] - 1, 10**9])
    settling = [(int(end[60]), int(end[60]) + 300), (int(start[200]), int(start[200]) + 1)]
    ranges = [(int(start[10]) + 5, int(start[12])), (int(end[119]), int(end[119]) + 1),
              (int(start[50]), int(end[52]))]  # fmt: skip
    for n in (400, None):
        k = np.arange(400)
        got = stride_exclusions(start, end, k, n, gap_rows[::-1], settling, ranges)
        want = [one(a, b, kk, n, gap_rows, settling, ranges)
                for a, b, kk in zip(start, end, k, strict=True)]  # fmt: skip
        assert got == want
        assert {FIRST, GAP, SETTLING, USER, ""} <= set(got)
        assert (LAST in got) == (n is not None)
    assert stride_exclusions([5], [9], [1], 3, np.empty(0, np.int64), [], []) == [""]


def test_stride_extremes_are_each_strides_own_to_its_last_row():
    """Range of motion over [start, end] and the knee's swing peak from toe off, per stride as
    numpy gives them one by one, also for a stride ending on the record's last row, NaN for
    one past it."""
    from gaitmon.analysis import analyse_strides

    rng = np.random.default_rng(11)
    joints = np.cumsum(rng.normal(size=(1200, 3)), axis=0)
    hs = np.array([10, 120, 230, 345, 460, 580, 700, 815, 930, 1050, 1199, 1300])
    to = hs[:-1] + 70
    rows = analyse_strides(hs, to, FS, joints)
    assert len(rows) == 11 and rows[-2].stride.end_idx == len(joints) - 1
    for r in rows[:-1]:
        a, b, t = r.stride.start_idx, r.stride.end_idx, r.stride.toe_off_idx
        seg = joints[a : b + 1]
        assert r.rom_deg == tuple(seg.max(axis=0) - seg.min(axis=0))
        assert r.knee_peak_swing_deg == joints[t : b + 1, 1].max()
    assert np.isnan(rows[-1].knee_peak_swing_deg) and np.isnan(rows[-1].rom_deg).all()
