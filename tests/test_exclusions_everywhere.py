"""Exclusions made in review are the session's analysis state: ``gaitmon info`` and the report
leave out the same strides as an independent analysis with those ranges, and the export carries
them; and reprocessing a file (``rewrite_processed``) reports progress, can be cancelled, and
writes what ``gaitmon process`` writes."""

from __future__ import annotations

import itertools
import json

import h5py
import numpy as np
import pytest

from gaitmon.analysis import analyse_strides
from gaitmon.cli import main
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.errors import Cancelled
from gaitmon.finish import open_session, replay_pipeline
from gaitmon.finish.reprocess import partial_path, rewrite_processed
from gaitmon.io.session import SessionError, exclusions
from gaitmon.report import gather_report

pytestmark = pytest.mark.timeout(120)


@pytest.fixture(scope="module")
def walk(tmp_path_factory, record_simulated):
    return record_simulated(tmp_path_factory.mktemp("excl") / "walk.h5", duration_s=20)


def _joints_of(f):
    from gaitmon.io.session.codec import joints_from_stored_tilts

    if "processed/joint_deg" in f:
        return f["processed/joint_deg"][()]
    return joints_from_stored_tilts(f["processed/tilt_deg"][()], "processed/tilt_deg")


def _included(path, ranges):
    """The included-stride count computed here, from the file's datasets and the ranges."""
    with h5py.File(path, "r") as f:
        hs = f["events/heel_strike"][()]
        to = f["events/toe_off"][()]
        t_s = f["timeline/t_s"][()]
        # format 2 stores the tilts (0.01 deg); the joints are their differences
        joints = _joints_of(f).astype(np.float64)
        gaps = [(int(g["sample_idx"]), float(g["duration_s"])) for g in f["gaps"][()]]
        fs = float(f.attrs["sample_rate_hz"])
    rows = analyse_strides(hs, to, fs, joints, gaps, ranges, t_s=t_s)
    return sum(r.included for r in rows)


def _info(capsys, path):
    assert main(["info", str(path)]) == 0
    return capsys.readouterr().out


def test_info_report_and_export_honour_the_exclusions_made_in_review(walk, capsys, tmp_path):
    with open_session(walk) as s:
        created, n = s.created_utc, s.n_samples
        t_s = s.read("timeline/t_s")
        hs = s.heel_strike_idx
        before = gather_report(s).summary.n_strides
    assert _included(walk, []) == before
    assert f"  strides      {before} included" in _info(capsys, walk)
    # as the review window does: two ranges (a turn, a stumble) saved beside the recording
    mid = len(hs) // 2
    ranges = [
        exclusions.Exclusion(int(hs[mid]) + 5, int(hs[mid + 1]) + 5, "turn"),
        exclusions.Exclusion(int(hs[3]) + 1, int(hs[3]) + 2, "stumble"),
    ]
    sp = exclusions.save(walk, ranges, created, n, t_s)
    try:
        want = _included(walk, [(r.start_idx, r.stop_idx) for r in ranges])
        assert want < before  # the ranges do leave strides out
        text = _info(capsys, walk)
        assert f"  strides      {want} included, " in text
        assert f"2 user-excluded ranges from {sp.name}" in text
        with open_session(walk) as s:
            data = gather_report(s)
        assert data.summary.n_strides == want
        assert sum(r.included for r in data.rows) == want
        assert len(data.losses.excluded_ranges) == 2
        # the export carries them in its metadata
        csv = tmp_path / "walk.csv"
        assert main(["export", str(walk), "--format", "csv", "-o", str(csv), "-q"]) == 0
        meta = json.loads(csv.with_name("walk.meta.json").read_text(encoding="utf-8"))
        got = [(r["start_idx"], r["stop_idx"], r["label"]) for r in meta["excluded_ranges"]]
        assert got == [(r.start_idx, r.stop_idx, r.label) for r in exclusions.merge(ranges)]
        # a damaged side file: one line, no traceback, nothing excluded
        sp.write_text("{not json", encoding="utf-8")
        text = _info(capsys, walk)
        assert f"  strides      {before} included" in text and "unreadable" in text
        from gaitmon.export import export_session

        res = export_session(walk, "csv", tmp_path / "damaged.csv")
        assert any("unreadable" in p for p in res.problems)  # said, not silently dropped
    finally:
        sp.unlink(missing_ok=True)


def test_a_read_only_folder_keeps_them_in_the_user_store_where_info_sees_them(
    walk, capsys, tmp_path, user_data_dir
):
    import shutil

    copy = tmp_path / "walk.h5"
    shutil.copyfile(walk, copy)
    with open_session(copy) as s:
        created, n = s.created_utc, s.n_samples
        hs = s.heel_strike_idx
    ranges = [exclusions.Exclusion(int(hs[4]) + 3, int(hs[6]) + 3, "turn")]
    want = _included(copy, [(r.start_idx, r.stop_idx) for r in ranges])
    assert want < _included(copy, [])
    # the side file cannot be written (its temporary file's name is taken by a folder; root
    # ignores permission bits, so a read-only folder is made this way)
    blocker = exclusions.side_path(copy).with_name(copy.name + ".review.json.tmp")
    blocker.mkdir()
    kept = exclusions.save(copy, ranges, created, n)
    assert kept.is_file() and user_data_dir in kept.parents
    assert not exclusions.side_path(copy).exists()
    text = _info(capsys, copy)
    assert f"  strides      {want} included, " in text and kept.name in text
    with open_session(copy) as s:
        assert gather_report(s).summary.n_strides == want
    # an older side file that cannot be changed any more does not hide newer ranges, nor
    # their removal
    blocker.rmdir()
    exclusions.save(copy, [exclusions.Exclusion(10, 20, "old")], created, n)
    blocker.mkdir()
    assert exclusions.save(copy, ranges, created, n) == kept
    assert exclusions.load(copy, created, n) == (ranges, "")
    exclusions.save(copy, [], created, n)
    assert exclusions.load(copy, created, n) == ([], "")
    exclusions.save(copy, ranges, created, n)
    # once the folder can be written again, the side file takes over and the copy goes
    blocker.rmdir()
    side = exclusions.save(copy, ranges, created, n)
    assert side == exclusions.side_path(copy) and side.is_file() and not kept.exists()
    assert f"  strides      {want} included, " in _info(capsys, copy)


def test_rewrite_processed_reports_progress_and_writes_what_the_command_writes(
    walk, tmp_path, monkeypatch, assert_stored
):
    import gaitmon.finish.reprocess as rp

    monkeypatch.setattr(rp, "COPY_CHUNK_BYTES", 64 << 10)  # several chunks for a short file
    monkeypatch.setattr(rp, "REPLAY_CHUNK_ROWS", 500)
    with open_session(walk) as s:
        config = s.config.replace(cutoff_hz=3.0)
        adc = s.read("raw/adc")
        cal, cal_log = s.calibration, list(s.calibration_changes)
    seen: list[float] = []
    out = tmp_path / "new.h5"
    res = rewrite_processed(walk, out, config, progress=seen.append)
    assert res.path == out and res.n_frames == len(adc) and res.config == config
    assert seen[-1] == 1.0 and all(b >= a for a, b in itertools.pairwise(seen))
    assert len(seen) > 5 and not partial_path(out).exists()
    # the same as a replay computed here
    joint = np.concatenate(
        [c.rows["processed/joint_deg"] for c in replay_pipeline(adc, config, cal, cal_log)]
    )
    with open_session(out) as s:
        s.use_angles("live")  # the causal filter's, which the new settings tune
        assert_stored(s.read("processed/joint_deg"), joint, "processed/joint_deg")
        assert s.config == config and s.reprocessed and not s.config_changes
    # and the same as the command line writes
    ref = tmp_path / "ref.h5"
    assert main(["process", str(walk), "-o", str(ref), "--cutoff-hz", "3"]) == 0
    with h5py.File(out, "r") as a, h5py.File(ref, "r") as b:
        for name in ("processed/tilt_deg", "smoothed/tilt_deg", "events/heel_strike",
                     "events/toe_off", "raw/adc", "timeline/t_s"):  # fmt: skip
            np.testing.assert_array_equal(a[name][()], b[name][()], err_msg=name)
        assert dict(a["config"].attrs) == dict(b["config"].attrs)


def test_rewrite_processed_converts_with_the_recordings_own_channel_table(
    walk, tmp_path, assert_stored
):
    """A unit whose channel table differs from the default: the reprocessed file converts its
    counts with the recording's table (as recovery and the review window do)."""
    import shutil

    src = tmp_path / "own_table.h5"
    shutil.copyfile(walk, src)
    with h5py.File(src, "r+") as f:
        ch = f["device/channels"][()]
        ch["sensitivity_v_per_unit"][0] *= 1.25  # body acc x reads 20 % lower
        f["device/channels"][...] = ch
    with open_session(src) as s:
        table, adc, cfg, cal = s.header.table, s.read("raw/adc"), s.config, s.calibration
        changes = list(s.calibration_changes)
    want = np.concatenate([c.rows["processed/acc_ms2"] for c in
                           replay_pipeline(adc, cfg, cal, changes, table=table)])  # fmt: skip
    out = rewrite_processed(src, tmp_path / "out.h5", cfg)
    with open_session(out.path) as s:
        got = s.read("processed/acc_ms2")
    assert_stored(got, want, "processed/acc_ms2")


def test_rewrite_processed_cancelled_midway_keeps_nothing(walk, tmp_path, monkeypatch):
    import gaitmon.finish.reprocess as rp

    monkeypatch.setattr(rp, "COPY_CHUNK_BYTES", 64 << 10)
    monkeypatch.setattr(rp, "REPLAY_CHUNK_ROWS", 500)
    with open_session(walk) as s:
        config = s.config
    out = tmp_path / "cancelled.h5"
    seen: list[float] = []
    with pytest.raises(Cancelled):
        rewrite_processed(
            walk, out, config, progress=seen.append, cancel=lambda: bool(seen) and seen[-1] > 0.5
        )
    assert 0.5 < seen[-1] < 1.0  # it was midway
    assert not out.exists() and not partial_path(out).exists()


def test_rewrite_processed_errors_are_one_line_session_errors(walk, tmp_path, record_simulated):
    with open_session(walk) as s:
        config = s.config
    with pytest.raises(SessionError, match="another"):
        rewrite_processed(walk, walk, config, overwrite=True)
    with pytest.raises(SessionError, match="does not exist"):
        rewrite_processed(walk, tmp_path / "no" / "x.h5", config)
    with pytest.raises(SessionError, match="does not exist"):
        rewrite_processed(tmp_path / "missing.h5", tmp_path / "x.h5", config)
    joint = record_simulated(tmp_path / "joint.h5", "--mode", "joint", duration_s=3)
    with pytest.raises(SessionError, match="only raw-mode"):
        rewrite_processed(joint, tmp_path / "y.h5", PipelineConfig())
    assert not (tmp_path / "y.h5").exists() and not partial_path(tmp_path / "y.h5").exists()



@pytest.mark.parametrize("kernel", ["whole", "fails midway", "absent"])
def test_the_recordings_copy_is_byte_for_byte_however_it_is_made(walk, tmp_path, monkeypatch,
                                                                 kernel):  # fmt: skip
    """``process`` copies the recording in the kernel (os.copy_file_range) where it can; a
    file system that refuses it midway, or a platform without it, copies in this process."""
    import errno
    import os

    import gaitmon.finish.reprocess as rp

    monkeypatch.setattr(rp, "COPY_CHUNK_BYTES", 64 << 10)
    calls: list[int] = []
    real = getattr(os, "copy_file_range", None)
    if kernel == "absent" or real is None:
        monkeypatch.delattr(os, "copy_file_range", raising=False)
    elif kernel == "fails midway":
        def refusing(src: int, dst: int, count: int) -> int:
            calls.append(count)
            if len(calls) > 2:
                raise OSError(errno.EXDEV, "Invalid cross-device link")
            return real(src, dst, count)

        monkeypatch.setattr(os, "copy_file_range", refusing)
    seen: list[float] = []
    out = tmp_path / "copy.h5"
    rp._copy(walk, out, seen.append, lambda: None)
    assert out.read_bytes() == walk.read_bytes()
    assert len(seen) > 3 and seen[-1] == 1.0
    assert all(b >= a for a, b in itertools.pairwise(seen))
    if kernel == "fails midway":
        assert len(calls) == 3


@pytest.mark.parametrize("change", [None, "paper", 600.0])
def test_process_keeps_the_stride_measures_of_the_same_heel_strikes_and_computes_others(
    walk, tmp_path, monkeypatch, change
):
    """``process`` keeps the recording's stored stride measures when its heel strikes and
    stamped inputs are the same (another tilt filter), and computes them
    for other heel strikes (another force threshold): either way they are the measures
    computed from the new file's heel strikes."""
    import gaitmon.finish.strides as st

    calls: list[int] = []
    compute = st.compute
    monkeypatch.setattr(st, "compute", lambda read, inputs, hs: calls.append(len(hs))
                        or compute(read, inputs, hs))  # fmt: skip
    with open_session(walk) as s:
        config = s.config
        before = s.heel_strike_idx
    if change == "paper":
        config = config.replace(tilt_method="paper")
    elif change == 600.0:
        config = config.replace(fsr_threshold=600.0)
    out = tmp_path / "new.h5"
    rewrite_processed(walk, out, config)
    with open_session(out) as s:
        after = s.heel_strike_idx
        stored = s.foot_stride_measures(after)  # what the file holds, stamp checked
    same = np.array_equal(before, after)
    assert same is (change != 600.0)  # (the threshold moves the heel strikes)
    assert (calls == []) is same
    with h5py.File(out, "r") as f:
        inputs = st.StrideInputs(len(f["raw/adc"]), float(f.attrs["sample_rate_hz"]),
                                 *_stride_inputs(out))  # fmt: skip
        hs = st.heel_strikes_used(f["events/heel_strike"][()], inputs.n_rows)
        adc = f["raw/adc"]
        want = compute(lambda a, b: adc[a:b], inputs, hs)
    np.testing.assert_array_equal(stored.stride_length_m, want.stride_length_m)
    np.testing.assert_array_equal(stored.foot_clearance_m, want.foot_clearance_m)
    np.testing.assert_array_equal(stored.heel_strike_idx, want.heel_strike_idx)


def _stride_inputs(path):  # type: ignore[no-untyped-def]
    """(table, calibration, calibration changes, lost frames) of a session file."""
    with open_session(path) as s:
        from gaitmon.io.session.rows import lost_before_from_gaps

        return (s.header.table, s.calibration, list(s.calibration_changes),
                lost_before_from_gaps(s.gaps, s.n_samples))  # fmt: skip
