"""Measure the harder simulator's parameters on the real foot-IMU walks (issue 24, item 6).

    PYTHONPATH=. python benchmarks/sim_realism_params.py [--data ../shared/data] [--per-trial]

Reads ``gdins_footprints`` (16 hallway-lap walks, a measured footprint per stride) and
``xio_closed_loop_walks`` (2 closed loops) through their own ``load.py`` and prints, per dataset
and pooled, what docs/simulator.md ("The real realism level") quotes:

* standing |a| (3-D) against g: the accelerometer's gain error as calibrated parts show it;
* the stance foot's residual motion: |omega| (3-D) and |omega_y| (the unit's pitch gyro), and
  |a| - g, over the still part of each stance (the 0.20 s before each ZV end of gdins; the
  x-io stance intervals after the first standing);
* stride-to-stride variability on straight strides (|turn| < 20 deg, the first and last two
  strides of a trial left out): stride length and time CV, both as plain SD / mean and as the
  successive-difference SD / sqrt(2) / mean ("local", blind to slow speed changes);
* the foot's pitch range per stride (gyro-integrated, de-drifted between ZV ends);
* turns: heading change per stride (3-D strapdown, tilt reset at every ZV end), the peak
  vertical turn rate in strides turning > 45 deg, the foot's roll at the stance before and
  after such strides, and the integrated gyro heading over a whole trial against the
  footprints' (a gyro scale error bound).

The machinery is numpy only (the datasets' ``common_gait.py``); about 20 s on one core.
"""

from __future__ import annotations

import argparse
import sys
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np

G = 9.80665


def _import_dataset(folder: Path) -> tuple[Any, Any]:
    """(load module, common_gait module) of one dataset folder (numpy-only helpers shipped
    with the data)."""
    sys.path.insert(0, str(folder))
    try:
        import common_gait
        import load

        return load, common_gait
    finally:
        sys.path.pop(0)
        sys.modules.pop("load", None)
        sys.modules.pop("common_gait", None)


def _standing(acc: np.ndarray, gyr: np.ndarray, n_max: int) -> np.ndarray:
    """Samples of the first still period (|omega| < 0.1 rad/s, before the first motion)."""
    w = np.linalg.norm(gyr[:n_max], axis=1)
    moving = np.flatnonzero(w > 0.3)
    end = int(moving[0]) if len(moving) else n_max
    idx = np.arange(max(end - 10, 0))
    return idx[w[idx] < 0.1]


def _attitude(cg: Any, acc: np.ndarray, gyr: np.ndarray, i0: int, i1: int, fs: float,
              f0: np.ndarray) -> np.ndarray:  # fmt: skip
    """(i1 - i0 + 1, 3, 3) body-to-level rotations from i0 (levelled from f0, yaw 0) by the
    gyro (the datasets' strapdown, step by step)."""
    q = cg._R2q(cg.level_rotation(f0))
    out = np.empty((i1 - i0 + 1, 3, 3))
    for k in range(i1 - i0 + 1):
        out[k] = cg._q2R(q)
        if i0 + k < i1:
            w = 0.5 * (gyr[i0 + k] + gyr[i0 + k + 1])
            ang = np.linalg.norm(w) / fs
            if ang > 0:
                dq = np.concatenate([[np.cos(ang / 2)], np.sin(ang / 2) * w / np.linalg.norm(w)])
                q = cg._qmul(q, dq)
                q /= np.linalg.norm(q)
    return out


def _heading_per_stride(cg: Any, acc: np.ndarray, gyr: np.ndarray, zv: np.ndarray, fs: float,
                        bias: np.ndarray) -> dict[str, np.ndarray]:  # fmt: skip
    """Per stride between consecutive ZV ends, from a 3-D strapdown levelled at the first:
    "turn" (heading change, rad, tilt reset at the second), "peak rate" (largest |vertical
    angular rate|, rad/s), "roll end" (the foot's roll at the second stance, from its
    accelerometer, rad), "roll rms" / "roll peak" (the roll over the stride: asin of the
    vertical component of the foot's y axis, the simulator's roll, rad)."""
    keys = ("turn", "peak rate", "roll end", "roll rms", "roll peak")
    out: dict[str, list[float]] = {k: [] for k in keys}
    g = gyr - bias
    for i0, i1 in pairwise(zv):
        f0 = acc[max(i0 - 5, 0) : i0 + 1].mean(0)
        f1 = acc[i1 : i1 + 6].mean(0)
        rot = _attitude(cg, acc, g, int(i0), int(i1), fs, f0)
        q = cg._R2q(rot[-1])
        r = cg._q2R(cg.reset_tilt_keep_yaw(q, f1))
        hx = r @ (cg.level_rotation(f1).T @ np.array([1.0, 0.0, 0.0]))
        out["turn"].append(float(np.arctan2(hx[1], hx[0])))
        wv = np.einsum("kj,kj->k", rot[:, 2, :], g[i0 : i1 + 1])  # vertical angular rate
        out["peak rate"].append(float(np.max(np.abs(wv))))
        out["roll end"].append(float(np.arctan2(f1[1], f1[2])))
        roll = np.arcsin(np.clip(rot[:, 2, 1], -1.0, 1.0))
        out["roll rms"].append(float(np.sqrt(np.mean(roll**2))))
        out["roll peak"].append(float(np.max(np.abs(roll))))
    return {k: np.asarray(v) for k, v in out.items()}


def longest_still_s(gyro_y: np.ndarray, fs: float, limit: float = 0.35) -> float:
    """The longest run (s) in which |gyro_y| stays below ``limit`` over +-2 samples (the
    still test of gaitmon.dsp.stride_length on the gyro alone)."""
    w = np.abs(gyro_y)
    if len(w) < 5:
        return 0.0
    mx = np.max(np.lib.stride_tricks.sliding_window_view(w, 5), axis=1) < limit
    edges = np.diff(np.concatenate([[0], mx.astype(np.int8), [0]]))
    runs = np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)
    return float(runs.max(initial=0)) / fs


def stance_pivot(az: np.ndarray, ax: np.ndarray, gy: np.ndarray, s: int, e: int,
                 fs: float) -> np.ndarray:  # fmt: skip
    """(forward, up) of the sensor less the point the stance foot turns about, in the foot's
    frame (m), from s (the stillest sample) to e (the roll-over into heel-off): the planar
    strapdown's velocity (levelled at s) fitted as w(t) J R(t) r, less its value at s, plus a
    constant acceleration (a tilt error at s), by least squares."""
    th0 = np.arctan2(az[s - 2 : s + 3].mean(), ax[s - 2 : s + 3].mean())
    w = gy[s : e + 1]
    th = th0 + np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) / fs)])
    c, sn = np.cos(th), np.sin(th)
    a_f = az[s : e + 1] * c - ax[s : e + 1] * sn
    a_u = az[s : e + 1] * sn + ax[s : e + 1] * c - G
    v_f = np.concatenate([[0.0], np.cumsum(0.5 * (a_f[1:] + a_f[:-1]) / fs)])
    v_u = np.concatenate([[0.0], np.cumsum(0.5 * (a_u[1:] + a_u[:-1]) / fs)])
    m = np.stack([np.stack([-sn, -c], -1), np.stack([c, -sn], -1)], 1) * w[:, None, None]
    a = m[1:] - m[0]  # (K, 2 world axes, 2 of r)
    t = (np.arange(1, len(w)) / fs)[:, None]
    rows = np.concatenate([np.concatenate([a[:, 0], t, 0 * t], 1),
                           np.concatenate([a[:, 1], 0 * t, t], 1)])  # fmt: skip
    x, *_ = np.linalg.lstsq(rows, np.concatenate([v_f[1:], v_u[1:]]), rcond=None)
    return np.asarray(x[:2])


def roll_over_window(gy: np.ndarray, lo: int, hi: int, fs: float,
                     w_max: float = 2.0) -> tuple[int, int]:  # fmt: skip
    """(stillest sample of |gy| over 0.1 s in lo..hi, where |gy| first reaches w_max after it,
    at most 0.35 s on)."""
    seg = np.convolve(np.abs(gy[lo:hi]), np.ones(10) / 10, mode="same")
    s = lo + int(np.argmin(seg))
    e = s
    while e < min(s + int(0.35 * fs), len(gy) - 1) and abs(gy[e]) < w_max:
        e += 1
    return s, e


def false_pitch(az: np.ndarray, ax: np.ndarray, gy: np.ndarray, a: int, b: int,
                fs: float) -> float:  # fmt: skip
    """The planar pitch gyro's integral from stance a to stance b less the accelerometer
    pitch change (rad): what a turn seen by a rolled board (or any axis error) adds."""
    g = gy[a : b + 1]

    def tilt(i: int) -> float:
        return float(np.arctan2(az[i - 2 : i + 3].mean(), ax[i - 2 : i + 3].mean()))

    return float(np.sum(0.5 * (g[1:] + g[:-1])) / fs - (tilt(b) - tilt(a)))


def turn_episodes(turn_deg: np.ndarray) -> list[tuple[int, float]]:
    """Runs of strides turning > 20 deg: (strides, |total turn| deg)."""
    out, cur = [], []
    for x in turn_deg:
        if abs(x) > 20.0:
            cur.append(float(x))
        elif cur:
            out.append(cur)
            cur = []
    if cur:
        out.append(cur)
    return [(len(c), abs(sum(c))) for c in out]


def _turn_shape(add: Any, turn: np.ndarray) -> None:
    t = np.abs(np.degrees(turn))
    add("|turn| per stride turning > 45 deg, deg", t[t > 45.0])
    add("strides turning > 90 deg, %", 100.0 * float(np.mean(t > 90.0)))
    u = [e for e in turn_episodes(np.degrees(turn)) if e[1] > 120.0]
    add("U-turn (> 120 deg): strides turning > 20 deg", np.array([e[0] for e in u], float))
    add("strides per U-turn", len(t) / max(len(u), 1))


def _pct(x: np.ndarray, q: float) -> float:
    return float(np.percentile(x, q)) if len(x) else float("nan")


def measure(data: Path, per_trial: bool = False) -> dict[str, dict[str, float]]:
    out: dict[str, dict[str, float]] = {}
    pools: dict[str, dict[str, list[np.ndarray]]] = {}
    for ds in ("gdins_footprints", "xio_closed_loop_walks"):
        folder = data / ds
        if not folder.is_dir():
            continue
        load, cg = _import_dataset(folder)
        trials = load.load_all(folder)
        pool: dict[str, list[np.ndarray]] = {}
        pools[ds] = pool

        def add(key: str, v: Any, pool: dict[str, list[np.ndarray]] = pool) -> None:
            pool.setdefault(key, []).append(np.atleast_1d(np.asarray(v, dtype=np.float64)))

        for name, d in trials.items():
            fs = d["fs"]
            acc, gyr = d["foot"]["acc_xyz"], d["foot"]["gyr_xyz"]
            b = d["board"]
            st = _standing(acc, gyr, int(20 * fs))
            bias = gyr[st].mean(0) if len(st) > 20 else np.zeros(3)
            if len(st) > 20:
                add("standing |a| / g - 1", np.linalg.norm(acc[st], axis=1).mean() / G - 1.0)
                add("standing planar |a| / g - 1",
                    np.hypot(b["acc_x"][st], b["acc_z"][st]).mean() / G - 1.0)  # fmt: skip
                add("standing roll, deg", np.degrees(np.arctan2(acc[st, 1], acc[st, 2]).mean()))
            if "zv_end_idx" in d:
                zv = d["zv_end_idx"]
                still = np.concatenate([np.arange(i - 20, i + 1) for i in zv if i >= 20])
            else:
                si = d["stance_intervals"][1:-1]  # not the first and last standing
                zv = si[:, 1]
                still = np.concatenate([np.arange(a, e + 1) for a, e in si])
            g = gyr - bias
            # the stillest 0.10 s of each stance (the floor of the foot's residual motion)
            w_all = np.linalg.norm(g, axis=1)
            floor = []
            for i in zv:
                lo = max(int(i) - int(0.5 * fs), 0)
                seg = np.convolve(np.abs(b["gyro_y"][lo : int(i) + 1] + bias[1]),
                                  np.ones(10) / 10, mode="valid")  # fmt: skip
                if len(seg):
                    floor.append(float(seg.min()))
            add("stance |w_y|, stillest 0.1 s mean, rad/s", np.asarray(floor))
            runs = [longest_still_s(b["gyro_y"][a : int(i1)] + bias[1], fs)
                    for a, i1 in pairwise(zv)]  # fmt: skip
            add("longest still run per stride (|w_y| < 0.35 rad/s), s", np.asarray(runs))
            # the still phase as a simple detector finds it (|w| < 0.8 rad/s, ||a|-g| < 1.2)
            det = cg.detect_stance(acc, g, fs)
            if len(det) > 2:
                det = det[1:-1]
                idx = np.concatenate([np.arange(a, e + 1) for a, e in det])
                add("detected stance |w_y|, rad/s", np.abs(b["gyro_y"][idx] + bias[1]))
                add("detected stance |a|-g, m/s2", np.linalg.norm(acc[idx], axis=1) - G)
                add("detected stance length, s", np.array([(e - a + 1) / fs for a, e in det]))
            del w_all
            add("stance |w|, rad/s", np.linalg.norm(g[still], axis=1))
            add("stance |w_y|, rad/s", np.abs(b["gyro_y"][still] + bias[1]))
            add("stance |a|-g, m/s2", np.linalg.norm(acc[still], axis=1) - G)
            add("stance planar |a|-g, m/s2", np.hypot(b["acc_x"][still], b["acc_z"][still]) - G)
            hd = _heading_per_stride(cg, acc, gyr, zv, fs, bias)
            turn, peak, roll = hd["turn"], hd["peak rate"], hd["roll end"]
            straight = np.abs(turn) < np.radians(20.0)
            straight[:2] = straight[-2:] = False
            add("turn per stride, deg", np.degrees(turn))
            big = np.abs(turn) > np.radians(45.0)
            _turn_shape(add, turn[1:-1])
            gyb = b["gyro_y"] + bias[1]
            for w_max in (0.7, 2.0):
                piv = [stance_pivot(b["acc_z"], b["acc_x"], gyb, *roll_over_window(
                    gyb, int(i) - 40, int(i) + 5, fs, w_max), fs) for i in zv[1:-1]]  # fmt: skip
                add(f"stance pivot (to {w_max} rad/s): sensor - pivot forward, m",
                    np.array([r[0] for r in piv]))  # fmt: skip
                add(f"stance pivot (to {w_max} rad/s): sensor - pivot up, m",
                    np.array([r[1] for r in piv]))  # fmt: skip
            fp = np.degrees([false_pitch(b["acc_z"], b["acc_x"], gyb, int(i0), int(i1), fs)
                             for i0, i1 in pairwise(zv)])  # fmt: skip
            add("false pitch per stride, straight, |deg|", np.abs(fp[straight]))
            add("false pitch per stride turning > 45 deg, |deg|", np.abs(fp[big]))
            add("false pitch per 180 deg turned (strides > 45 deg), deg",
                np.abs(fp[big]) / np.degrees(np.abs(turn[big])) * 180.0)  # fmt: skip
            add("peak vertical rate in turn strides, rad/s", peak[big])
            add("peak vertical rate in straight strides, rad/s", peak[straight])
            add("stance roll after a turn stride, deg", np.degrees(np.abs(roll[big])))
            add("stance roll after a straight stride, deg", np.degrees(np.abs(roll[straight])))
            add("roll RMS over a straight stride, deg", np.degrees(hd["roll rms"][straight]))
            add("roll RMS over a turn stride, deg", np.degrees(hd["roll rms"][big]))
            add("peak |roll| in a straight stride, deg", np.degrees(hd["roll peak"][straight]))
            add("peak |roll| in a turn stride, deg", np.degrees(hd["roll peak"][big]))
            # pitch range per stride (gyro-integrated, de-drifted between ZV ends)
            rng = []
            for i0, i1 in pairwise(zv):
                th, _ = cg.stride_pitch(b["acc_z"], b["acc_x"], b["gyro_y"] + bias[1],
                                        int(i0), int(i1), fs)  # fmt: skip
                rng.append(np.degrees(th.max() - th.min()))
            add("foot pitch range per straight stride, deg", np.asarray(rng)[straight])
            t = np.diff(zv) / fs
            if "ref_stride_length" in d:
                length = d["ref_stride_length"]
                for key, v in (("length", length), ("time", t)):
                    vs = v[straight]
                    if len(vs) > 5:
                        add(f"stride {key} CV (straight)", np.std(vs) / np.mean(vs))
                        # successive differences within runs of straight strides
                        pair = straight[1:] & straight[:-1]
                        dv = np.diff(v)[pair]
                        add(f"stride {key} local CV (straight)",
                            np.std(dv) / np.sqrt(2.0) / np.mean(vs))  # fmt: skip
                pair = straight
                add("stride length-time correlation (straight)",
                    np.corrcoef(length[pair], t[pair])[0, 1])  # fmt: skip
                # gyro heading over the whole trial against the footprints' travel direction
                fp = d["footprint_xy"]
                dirs = np.unwrap(np.arctan2(np.diff(fp[:, 1]), np.diff(fp[:, 0])))
                ref_turn = dirs[-1] - dirs[0]
                if abs(ref_turn) > np.radians(170.0):
                    imu_turn = np.sum(turn[1:])  # stride 0's start to the last stride's start
                    add("whole-trial heading, gyro / footprints - 1", imu_turn / ref_turn - 1.0)
            if per_trial:
                stand = pool["standing |a| / g - 1"][-1][0] if len(st) > 20 else float("nan")
                print(f"{ds} {name}: standing |a|/g-1 {stand:+.4f}, "
                      f"stance |w_y| median {np.median(pool['stance |w_y|, rad/s'][-1]):.3f}, "
                      f"turn strides {int(big.sum())}")  # fmt: skip
        out[ds] = {}
        for key, parts in pool.items():
            v = np.concatenate(parts)
            v = v[np.isfinite(v)]
            out[ds][key + " | median"] = float(np.median(v)) if len(v) else float("nan")
            out[ds][key + " | p10"] = _pct(v, 10)
            out[ds][key + " | p90"] = _pct(v, 90)
            out[ds][key + " | n"] = float(len(v))
    return out


def measure_sim(realism: str, seed: int = 4, seconds: float = 115.0) -> dict[str, float]:
    """The same measures, as far as the simulator has them, on its foot at a realism level
    (true events for the strides; the truth's roll and heading for the out-of-plane ones)."""
    from gaitmon.dsp.channels import ACC_X_IDX, ACC_Z_IDX, GYRO_IDX
    from gaitmon.io.sim.config import SimConfig
    from gaitmon.io.sim.kinematics import GaitModel
    from gaitmon.io.sim.sensors import simulate

    cfg = SimConfig(realism=realism, seed=seed)
    n = int((seconds + 5.0) * 100)
    gait = GaitModel(cfg.gait_config())
    sb = simulate(n, gait, cfg.sensor_config())
    k, ph = sb.kinematics, sb.physical
    foot = 3
    out: dict[str, float] = {}
    stand = np.arange(100, 450)
    out["standing planar |a| / g - 1"] = float(
        np.mean(np.hypot(ph[stand, ACC_X_IDX[foot]], ph[stand, ACC_Z_IDX[foot]])) / G - 1.0
    )
    w = np.abs(ph[:, GYRO_IDX[foot]] - sb.gyro_bias_rad_s[:, foot])
    hs, to = gait.events(0, n)
    floor = []
    for h in hs[1:-1]:
        t = to[to > h][0]
        floor.append(np.convolve(w[h:t], np.ones(10) / 10, mode="valid").min())
    out["stance |w_y|, stillest 0.1 s mean, rad/s"] = float(np.median(floor))
    runs = [longest_still_s(w[a:b], 100.0) for a, b in pairwise(hs[1:])]
    out["longest still run per stride (|w_y| < 0.35 rad/s), s"] = float(np.median(runs))
    out["  the same, p10"] = float(np.percentile(runs, 10))
    # the datasets' simple detector (|w| < 0.8 rad/s, ||a| - g| < 1.2 m/s^2 over 50 ms), on the
    # planar channels, the accelerometer divided by its drawn gain (as the real IMUs are
    # calibrated)
    from gaitmon.io.sim.sensors import SensorModel

    gain = float(np.mean(SensorModel(gait, cfg.sensor_config()).acc_gain[foot]))
    a = np.hypot(ph[:, ACC_X_IDX[foot]], ph[:, ACC_Z_IDX[foot]]) / gain - G
    box = np.ones(5) / 5
    det = ((np.convolve(w, box, "same") < 0.8) & (np.convolve(np.abs(a), box, "same") < 1.2)
           & (k.walking > 0.999))  # fmt: skip
    out["detected stance |w_y|, rad/s"] = float(np.median(w[det]))
    out["detected stance |a|-g, m/s2 (median)"] = float(np.median(a[det]))
    out["detected stance |a|-g, m/s2 (p90)"] = float(np.percentile(a[det], 90))
    st = gait.strides(0, n)
    turn = st.turn_rad if st.turn_rad is not None else np.zeros(len(st.heel_strike_idx))
    vert = (k.yaw_rate_rad_s + k.board_yaw_rate_rad_s[:, foot]
            - k.rate_rad_s[:, foot] * np.sin(k.roll_rad[:, foot]))  # fmt: skip
    straight_peak, turn_peak, rms, pitch = [], [], [], []
    for a, b, tr in zip(st.heel_strike_idx[2:-1], st.heel_strike_idx[3:], turn[2:-1],
                        strict=True):  # fmt: skip
        v = float(np.max(np.abs(vert[a:b])))
        if abs(tr) > np.radians(45.0):
            turn_peak.append(v)
        elif abs(tr) < np.radians(20.0):
            straight_peak.append(v)
            rms.append(float(np.degrees(np.sqrt(np.mean(k.roll_rad[a:b, foot] ** 2)))))
            th = np.degrees(k.tilt_rad[a:b, foot])
            pitch.append(float(th.max() - th.min()))
    out["peak vertical rate in turn strides, rad/s"] = float(np.median(turn_peak or [np.nan]))
    out["peak vertical rate in straight strides, rad/s"] = float(np.median(straight_peak))
    out["roll RMS over a straight stride, deg"] = float(np.median(rms))
    out["foot pitch range per straight stride, deg"] = float(np.median(pitch))
    ok = np.abs(turn[2:-1]) < np.radians(20.0)
    for key, v in (("length", st.stride_length_m[2:-1]), ("time", st.stride_time_s[2:-1])):
        out[f"stride {key} CV (straight)"] = float(np.std(v[ok]) / np.mean(v[ok]))
    out["turn strides (> 45 deg), %"] = float(100.0 * np.mean(np.abs(turn) > np.radians(45.0)))
    t = np.abs(np.degrees(turn[2:-1]))
    tb = t[t > 45.0] if np.any(t > 45.0) else np.array([np.nan])
    out["|turn| per stride turning > 45 deg, deg (median)"] = float(np.median(tb))
    out["|turn| per stride turning > 45 deg, deg (p90)"] = float(np.percentile(tb, 90))
    out["strides turning > 90 deg, %"] = float(100.0 * np.mean(t > 90.0))
    u = [e for e in turn_episodes(np.degrees(turn[2:-1])) if e[1] > 120.0]
    out["U-turn (> 120 deg): strides turning > 20 deg (median)"] = float(
        np.median([e[0] for e in u])) if u else float("nan")  # fmt: skip
    out["strides per U-turn"] = len(t) / max(len(u), 1)
    # the stance pivot and the false pitch, at the stillest sample of each stance
    gy = ph[:, GYRO_IDX[foot]] - sb.gyro_bias_rad_s[:, foot]
    ax, az = ph[:, ACC_X_IDX[foot]], ph[:, ACC_Z_IDX[foot]]
    anchors = []
    for w_max in (0.7, 2.0):
        anchors, piv = [], []
        for h in hs[2:-1]:
            s, e = roll_over_window(gy, int(h), int(to[to > h][0]), 100.0, w_max)
            anchors.append(s)
            piv.append(stance_pivot(az, ax, gy, s, e, 100.0))
        for j, axis in enumerate(("forward", "up")):
            out[f"stance pivot (to {w_max} rad/s): sensor - pivot {axis}, m"] = float(
                np.median([r[j] for r in piv]))  # fmt: skip
    tr = np.degrees([k.heading_rad[b] - k.heading_rad[a] for a, b in pairwise(anchors)])
    fp = np.degrees([false_pitch(az, ax, gy, a, b, 100.0) for a, b in pairwise(anchors)])
    big = np.abs(tr) > 45.0
    out["false pitch per stride, straight, |deg|"] = float(np.median(np.abs(fp[np.abs(tr) < 20])))
    out["false pitch per stride turning > 45 deg, |deg|"] = float(
        np.median(np.abs(fp[big]))) if big.any() else float("nan")  # fmt: skip
    out["false pitch per 180 deg turned (strides > 45 deg), deg"] = float(
        np.median(np.abs(fp[big]) / np.abs(tr[big]) * 180.0)) if big.any() else float("nan")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--data", type=Path, default=None)
    ap.add_argument("--per-trial", action="store_true")
    ap.add_argument("--no-sim", action="store_true", help="leave out the simulator's columns")
    args = ap.parse_args(argv)
    data = args.data
    if data is None:
        from gaitmon.lab.accuracy import default_data_dir

        data = default_data_dir()
    if data is None or not data.is_dir():
        print("no shared data folder (--data DIR)")
        return 1
    res = measure(data, args.per_trial)
    for ds, r in res.items():
        print(f"\n## {ds}\n")
        print("| measure | median | p10 | p90 | n |")
        print("|---|---|---|---|---|")
        keys = list(dict.fromkeys(k.rsplit(" | ", 1)[0] for k in r))
        for k in keys:
            print(f"| {k} | {r[k + ' | median']:.4g} | {r[k + ' | p10']:.4g} | "
                  f"{r[k + ' | p90']:.4g} | {r[k + ' | n']:.0f} |")  # fmt: skip
    if not args.no_sim:
        print("\n## simulator (foot; 115 s of walking, seed 4)\n")
        print("| measure | default | real |")
        print("|---|---|---|")
        easy, hard = measure_sim("default"), measure_sim("real")
        for key in hard:
            print(f"| {key} | {easy[key]:.4g} | {hard[key]:.4g} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
