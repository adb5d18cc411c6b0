"""The lab's real-data readers, the 3-D reference of foot tilt, LOTO and the real tables
(gaitmon.lab.datasets, gaitmon.lab.reference, gaitmon.lab.real*): against the facts the data
READMEs state, against independent signals, and on synthetic data without the shared folder."""

from __future__ import annotations

import functools
import pathlib

import numpy as np
import pytest

from gaitmon.lab import datasets as D
from gaitmon.lab.reference import reference_foot_tilt, reference_up, tilt_from_up

_read_gdins = functools.cache(D.read_gdins)
_read_xio = functools.cache(D.read_xio)


@pytest.fixture
def gdins(shared_data: pathlib.Path) -> list[D.ImuTrial]:
    if not (shared_data / "gdins_footprints").is_dir():
        pytest.skip("no gdins_footprints")
    return _read_gdins(shared_data)


@pytest.fixture
def xio(shared_data: pathlib.Path) -> list[D.ImuTrial]:
    if not (shared_data / "xio_closed_loop_walks").is_dir():
        pytest.skip("no xio_closed_loop_walks")
    return _read_xio(shared_data)


def test_gdins_reader_matches_its_readme(gdins):
    # README: 16 trials exp31-exp46, 1,050 strides, 1,236 s, shipped at 100 Hz
    assert [t.name for t in gdins] == [f"exp{k}" for k in range(31, 47)]
    assert sum(len(t.extra["ref_stride_length"]) for t in gdins) == 1050
    assert all(t.fs_hz == 100.0 for t in gdins)
    assert sum(t.duration_s for t in gdins) == pytest.approx(1236, abs=1.0)
    for t in gdins:
        # one ZV end per footprint: strides + 1; board frame: standing, acc_x (up) ~ g
        assert len(t.extra["zv_end_idx"]) == len(t.extra["ref_stride_length"]) + 1
        assert 9.5 < np.median(t.acc_x[:100]) < 10.4
        np.testing.assert_array_equal(t.gyro_y, -t.gyr_xyz[:, 1])  # loader: gyro_y == -gyr_y
        np.testing.assert_array_equal(t.acc_x, t.acc_xyz[:, 2])


def test_xio_reader_matches_its_readme(xio):
    got = {t.name: t.duration_s for t in xio}
    assert got == pytest.approx({"short_walk": 41.6, "long_walk": 70.7}, abs=0.1)
    assert {t.name: float(t.extra["approx_path_length_m"]) for t in xio} == {
        "short_walk": 25.0,
        "long_walk": 60.0,
    }


def test_gaitpdb_and_broad_readers(shared_data):
    if (shared_data / "gaitpdb").is_dir():
        (rec,) = D.read_gaitpdb(shared_data)
        assert rec.fs_hz == pytest.approx(100.0, rel=1e-3)
        assert rec.duration_s == pytest.approx(121, abs=2)  # README: about 121 s
        # the total is the sum of the 8 sensors of the foot (the README's 19 columns)
        assert np.all(rec.heel["left"] <= rec.total["left"] + 1e-6)
    if (shared_data / "broad").is_dir():
        trials = D.read_broad(shared_data)
        assert [t.name for t in trials] == list(D.BROAD_TRIALS)
        assert all(t.ref_valid is not None and t.ref_valid.sum() > 1000 for t in trials)


def test_reference_at_standing_equals_the_board_accelerometer(gdins, xio):
    for t in gdins + xio:
        ref = reference_foot_tilt(t)
        acc_tilt = np.arctan2(t.acc_z, t.acc_x)
        # every trial starts with >= 1.3 s of standing (first motion at sample >= 137)
        e = np.degrees(ref[20:100] - acc_tilt[20:100])
        assert np.all(np.isfinite(e)), t.name
        # the mean over the standing, and per sample but for the accelerometer's own noise
        assert abs(np.mean(e)) < 1.0 and np.percentile(np.abs(e), 90) < 1.0, (t.name, e)


def test_reference_rate_matches_gyro_y_where_the_foot_only_pitches(gdins, xio):
    for t in gdins[:4] + xio:
        ref = reference_foot_tilt(t)
        rate = np.gradient(ref) * t.fs_hz
        gy = t.gyro_y - D.gyro_bias_at_start(t)
        pitch_only = (
            np.isfinite(rate) & (np.abs(t.gyr_xyz[:, 0]) < 0.2) & (np.abs(t.gyr_xyz[:, 2]) < 0.2)
        )
        assert pitch_only.sum() > 400
        e = np.abs(rate - gy)[pitch_only]
        assert np.median(e) < 0.03 and np.percentile(e, 95) < 0.1, (t.name, np.median(e))
        assert np.isfinite(ref).mean() > 0.95


def _rot_y(th: float) -> np.ndarray:
    c, s = np.cos(th), np.sin(th)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rot_x(th: float) -> np.ndarray:
    c, s = np.cos(th), np.sin(th)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def synthetic_foot(
    n_strides: int = 6, fs: float = 100.0, roll_deg: float = 10.0, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(acc_xyz, gyr_xyz, true planar tilt) of a foot (x fwd, y left, z up) that stands 1 s,
    then per 1.2-s stride stays flat 0.4 s and swings in pitch (toe-up positive) and roll,
    no linear acceleration (the foot rotates about the sensor), with gyro noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(int((1.0 + 1.2 * n_strides + 1.0) * fs)) / fs
    pitch = np.zeros_like(t)
    roll = np.zeros_like(t)
    for k in range(n_strides):
        a = 1.0 + 1.2 * k + 0.4
        m = (t >= a) & (t < a + 0.8)
        ph = (t[m] - a) / 0.8
        pitch[m] = np.radians(-150) * np.sin(np.pi * ph) ** 2 * np.cos(np.pi * ph)
        roll[m] = np.radians(roll_deg) * np.sin(np.pi * ph) ** 2
    # body-to-world R = Rx(roll) Ry(-pitch)  (toe-up pitch turns about -y, y pointing left)
    rots = [_rot_x(r) @ _rot_y(-p) for r, p in zip(roll, pitch, strict=True)]
    acc = np.array([r.T @ np.array([0, 0, 9.81]) for r in rots])
    gyr = np.zeros_like(acc)
    for i in range(1, len(t) - 1):  # body rate from R^T R' (central difference)
        d = rots[i].T @ (rots[i + 1] - rots[i - 1]) * fs / 2
        gyr[i] = [d[2, 1], d[0, 2], d[1, 0]]
    gyr += rng.normal(0, 0.005, gyr.shape)
    up = np.array([r.T @ np.array([0, 0, 1.0]) for r in rots])
    return acc, gyr, tilt_from_up(up)


def test_reference_recovers_a_synthetic_3d_foot():
    acc, gyr, truth = synthetic_foot()
    ref = tilt_from_up(reference_up(acc, gyr, 100.0))
    ok = np.isfinite(ref)
    assert ok.mean() > 0.9
    assert np.degrees(np.max(np.abs(ref[ok] - truth[ok]))) < 0.5
    assert np.degrees(np.max(np.abs(truth))) > 50
    # the roll matters: the planar gyro's integral alone misses the truth by degrees
    planar = np.cumsum(-gyr[:, 1]) / 100.0
    assert np.degrees(np.max(np.abs(planar - truth))) > 1.0


def test_loto_on_a_toy_fit_by_hand():
    from gaitmon.lab.loto import in_sample, loto

    trials = [1.0, 2.0, 3.0, 6.0]
    fit = lambda ts: sum(ts) / len(ts)  # noqa: E731
    judge = lambda t, p: t - p  # noqa: E731
    # left out 1: mean(2, 3, 6) = 11/3; 2: 10/3; 3: 3; 6: 2
    assert loto(trials, fit, judge) == pytest.approx([1 - 11 / 3, 2 - 10 / 3, 0.0, 4.0])
    assert in_sample(trials, fit, judge) == pytest.approx([-2.0, -1.0, 0.0, 3.0])
    with pytest.raises(ValueError):
        loto([1.0], fit, judge)


def test_gdins_baseline_and_matching_reproduce_the_readme(gdins, shared_data):
    import json

    from gaitmon.lab.real_gait import gdins_strides

    readme = json.loads((shared_data / "gdins_footprints" / "check_results.json").read_text())
    dt = []
    for t in gdins:
        row = gdins_strides(t)
        # the README's own 2-D ZUPT (its check_baseline.py), reimplemented: the same MAPE
        mape = float(np.mean(np.abs(row.base_err_pct)))
        assert mape == pytest.approx(readme["per_trial"][t.name]["zupt2d_mape_pct"], abs=0.01)
        # every footprint after the first has its heel strike (the issue: as many as strides)
        assert row.hs_found == row.n_ref
        ok = np.isfinite(row.est)
        dt.append(row.est[ok] / row.speed_est[ok] - t.extra["stride_time"][ok])
        if ok.sum() >= 30:
            assert np.median(np.abs(dt[-1])) < 0.05, t.name
    # a matched stride is the same stride: its time (heel strike to heel strike) agrees with the
    # reference's (ZV end to ZV end); one stride off would be ~1 s off in a speed change
    assert np.median(np.abs(np.concatenate(dt))) < 0.035


def test_xio_baseline_reproduces_the_readme(xio):
    from gaitmon.lab.real_gait import xio_loop

    got = {t.name: xio_loop(t) for t in xio}
    # data README: "The 2-D sagittal stride lengths ... sum to 22.8 m and 56.6 m"
    assert got["short_walk"].base_distance_m == pytest.approx(22.81, abs=0.01)
    assert got["long_walk"].base_distance_m == pytest.approx(56.64, abs=0.02)
    # README: 16 and 37 strides detected; the foot gyro finds as many heel strikes
    assert got["short_walk"].n_hs == 16 and got["long_walk"].n_hs == 37


def test_command_prints_every_datasets_table(shared_data, capsys):
    from gaitmon.cli import main

    assert main(["lab", "accuracy", "--quick", "--data", str(shared_data)]) == 0
    out = capsys.readouterr().out
    for heading in (
        "### BROAD",
        "### Real walks, foot tilt against the 3-D 6-axis reference",
        "### gdins_footprints",
        "### xio_closed_loop_walks",
        "### gaitpdb",
    ):
        assert heading in out
    assert "02_undisturbed_slow_rotation_B" in out and "exp31" in out and "short_walk" in out
    assert "GaCo01_01 left" in out and "GaCo01_01 right" in out


def _synthetic_gaitpdb(path: pathlib.Path, fs: float = 100.0, seconds: float = 60.0) -> int:
    """A gaitpdb-like file: per foot a stance of 0.65 s every 1.1 s (right foot half a stride
    later), heel bump from contact to 0.17 s before its end, toe from 0.11 s after contact to
    the end; returns the number of strides per foot."""
    t = np.arange(int(seconds * fs)) / fs

    def bump(a: float, b: float) -> np.ndarray:
        x = np.clip((t - a) / (b - a), 0, 1)
        return np.where((t > a) & (t < b), np.sin(np.pi * x), 0.0)

    cols = [t]
    totals = []
    n = 0
    for shift in (0.0, 0.55):
        heel, toe, mid = (np.zeros_like(t) for _ in range(3))
        onsets = np.arange(1.0 + shift, seconds - 1.0, 1.1)
        n = len(onsets)
        for on in onsets:
            heel += 600 * bump(on, on + 0.48)
            toe += 500 * bump(on + 0.11, on + 0.65)
            mid += 100 * bump(on, on + 0.65)
        sensors = [heel, *([mid] * 6), toe]
        cols += sensors
        totals.append(np.sum(sensors, axis=0))
    np.savetxt(path, np.column_stack([*cols, *totals]), fmt="%.4f")
    return n


def test_real_tables_on_synthetic_data_without_the_shared_folder(tmp_path):
    from gaitmon.lab.real import evaluate_real, format_real

    (tmp_path / "gaitpdb").mkdir()
    n = _synthetic_gaitpdb(tmp_path / "gaitpdb" / "SYN01.txt")
    xio = tmp_path / "xio_closed_loop_walks" / "trials"
    xio.mkdir(parents=True)
    acc, gyr, _truth = synthetic_foot(n_strides=8)
    still = np.flatnonzero(np.linalg.norm(gyr, axis=1) < 0.1)
    np.savez(
        xio / "short_walk.npz",
        fs=100.0,
        t=np.arange(len(acc)) / 100.0,
        foot_acc_x=acc[:, 0],
        foot_acc_z=acc[:, 2],
        foot_gyro_y=-gyr[:, 1],
        foot_acc_xyz=acc,
        foot_gyr_xyz=gyr,
        stance_intervals=np.array([[0, still[still < 150].max()], [len(acc) - 90, len(acc) - 1]]),
    )
    real = evaluate_real(tmp_path)
    assert any(note.startswith("broad:") for note in real.notes)
    assert any(note.startswith("gdins_footprints:") for note in real.notes)
    # events: every synthetic stride found on both feet, within 100 ms
    assert [e.foot for e in real.events] == ["left", "right"]
    for e in real.events:
        assert e.n_ref_hs == n and len(e.hs_dt_ms) == n and len(e.to_dt_ms) == n
    # tilt: no linear acceleration (the accelerometer alone is exact), but the roll makes the
    # planar gyro disagree with it: the smoother stays within 2 deg, the paper's lags more
    (row,) = real.foot_tilt
    assert row.judged > 0.8 and row.rmse_deg["offline"] < 2.0  # (1 s of standing at each end)
    assert row.rmse_deg["paper"] > row.rmse_deg["offline"]
    (loop,) = real.loops
    assert loop.n_hs == 8  # one mid-swing peak per stride
    text = format_real(real)
    assert "### gaitpdb" in text and "SYN01 right" in text and "short_walk" in text
    assert "### BROAD" not in text and "broad: not in" in text


def test_loto_on_gdins_stride_gain(gdins):
    from gaitmon.lab.loto import in_sample, loto
    from gaitmon.lab.real_gait import fit_gain, gain_median_abs_err_pct, gdins_strides

    rows = [gdins_strides(t) for t in gdins[:4]]
    judge = lambda r, g: (g, gain_median_abs_err_pct(r, g))  # noqa: E731
    out = loto(rows, fit_gain, judge)
    for i, (gain, err) in enumerate(out):
        # the gain left out trial i: the median ratio over the other trials' strides only
        ratios = np.concatenate([r.ref / r.est for j, r in enumerate(rows) if j != i])
        assert gain == pytest.approx(np.nanmedian(ratios))
        ok = np.isfinite(rows[i].est)
        e = np.abs(gain * rows[i].est[ok] - rows[i].ref[ok]) / rows[i].ref[ok] * 100
        assert err == pytest.approx(np.median(e))
    gains = {g for g, _ in in_sample(rows, fit_gain, judge)}
    assert len(gains) == 1 and len({g for g, _ in out}) == len(rows)  # one fit vs one per trial
