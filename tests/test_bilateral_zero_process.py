"""Zeroing both units at the start, and reprocessing a session of both legs.

``gaitmon record --simulate-bilateral --zero`` zeroes both units from the same standing window
(each unit's calibration in its own unit's header; checked against the mounting offsets the
simulator gave each unit's boards), and names the leg that could not be zeroed. ``gaitmon
process`` of a session of both legs reprocesses every unit (the file stays one of both legs,
``/sync`` unchanged), or with ``--side`` one leg into a one-unit file; each unit must come out
exactly as the one-unit ``gaitmon process`` makes it of that unit alone (the reference: the
unit's layout copied into a file of its own, reprocessed by the established one-unit path).
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon.cli import main
from gaitmon.finish import open_session
from gaitmon.finish.bilateral import open_bilateral, parts_of

RECORD = ["record", "--simulate-bilateral", "--duration", "16", "--speed", "4", "-q",
          "--standing-s", "10"]  # fmt: skip


@pytest.fixture(scope="module")
def zeroed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("bizero") / "both.h5"
    # 10 s standing (2.5 s of wall time at 4x): time to zero both on a loaded machine; then
    # 16 s recorded: 5 s or more of walking after the zeroing
    assert main([*RECORD, "--zero", "-o", str(out), "--asymmetry", "hemiparetic"]) == 0
    return out


def test_zero_stores_each_units_own_standing_offsets_and_gyro_bias(zeroed: Path) -> None:
    mounted = {}
    offsets = {}
    for side in "LR":
        with open_session(zeroed, side=side) as s:
            offsets[side] = np.degrees(s.calibration.tilt_offset_rad)
            bias = s.calibration.gyro_bias_rad_s
            assert s.calibration_changes == []  # zeroed before the first row: the header's
            knee = s.read("processed/joint_deg")[:, 1]
            assert 30.0 < knee.max() < 80.0  # zeroed knee flexion in swing (stiff on L)
        with h5py.File(zeroed, "r") as f:
            mounted[side] = f[f"units/{side}/truth"].attrs["mount_offset_deg"]
            # the gyros' true bias on the first row (it drifts over minutes, not seconds): one
            # unit's window straddling its own earlier zeroing read twice the bias (was 0.04)
            true_bias = f[f"units/{side}/truth/gyro_bias_rad_s"][0]
        np.testing.assert_allclose(bias, true_bias, atol=0.004, err_msg=side)
    for side in "LR":
        np.testing.assert_allclose(offsets[side], mounted[side], atol=0.5)
    # the two units' boards were mounted differently: a calibration on the wrong leg would fail
    assert np.max(np.abs(mounted["L"] - mounted["R"])) > 1.5


def test_a_leg_that_cannot_be_zeroed_is_named_and_nothing_is_recorded(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    import dataclasses

    from gaitmon.commands import simulate
    from gaitmon.io.sim.sensors import SensorConfig

    made = simulate.bilateral_config_from_args

    def shaky_right(args):  # the right unit's gyros far noisier than a still subject's sway
        cfg = made(args)
        right = dataclasses.replace(cfg.right, sensors=SensorConfig(seed=3, gyro_noise_rad_s=1.5))
        return dataclasses.replace(cfg, right=right)

    monkeypatch.setattr(simulate, "bilateral_config_from_args", shaky_right)
    out = tmp_path / "x.h5"
    args = [*RECORD, "--zero", "-o", str(out)]
    args[args.index("--duration") + 1] = "3"
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    assert "could not zero the right leg (R): Ask the patient to stand still" in err
    assert "left leg" not in err and "nothing was recorded" in err
    assert not list(tmp_path.iterdir())


def _one_unit_reference(both: Path, side: str, folder: Path, *options: str) -> Path:
    """The unit as a one-unit file of its own, reprocessed by the one-unit `gaitmon process`."""
    alone = folder / f"alone_{side}.h5"
    with h5py.File(both, "r") as fs, h5py.File(alone, "w") as fd:
        g = fs[f"units/{side}"]
        for k, v in g.attrs.items():
            fd.attrs[k] = v
        for name in g:
            g.copy(g[name], fd, name=name)
    ref = folder / f"ref_{side}.h5"
    assert main(["process", str(alone), "-o", str(ref), "-q", *options]) == 0
    return ref


SERIES = ("processed/tilt_deg", "processed/joint_deg", "smoothed/tilt_deg", "raw/adc",
          "events/heel_strike", "events/toe_off")  # fmt: skip


def _same_unit(a: h5py.Group, b: h5py.Group) -> None:
    for name in SERIES:
        if name in b:
            assert name in a, name
            np.testing.assert_array_equal(a[name][()], b[name][()], err_msg=name)
    assert a["smoothed/tilt_deg"].dtype == b["smoothed/tilt_deg"].dtype
    assert sorted(a["config"].attrs) == sorted(b["config"].attrs)
    for k, v in b["config"].attrs.items():
        assert np.array_equal(a["config"].attrs[k], v), k


def test_process_reprocesses_both_legs_into_a_file_of_both_legs(
    zeroed: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "new.h5"
    assert main(["process", str(zeroed), "-o", str(out), "--cutoff-hz", "6"]) == 0
    err = capsys.readouterr().err
    assert f"wrote {out} (both legs) with cutoff_hz=6; L: " in err and "; R: " in err
    with h5py.File(zeroed, "r") as fs, h5py.File(out, "r") as fo:
        assert bool(fo.attrs["bilateral"]) and fo.attrs["sides"] == "L R"
        for side in "LR":  # the clock fits come from receive times: kept as they were
            np.testing.assert_array_equal(fo[f"sync/{side}/segments"][()],
                                          fs[f"sync/{side}/segments"][()])  # fmt: skip
        for side in "LR":
            ref = _one_unit_reference(zeroed, side, tmp_path, "--cutoff-hz", "6")
            with h5py.File(ref, "r") as fr:
                _same_unit(fo[f"units/{side}"], fr)
            assert float(fo[f"units/{side}/config"].attrs["cutoff_hz"]) == 6.0
    with open_bilateral(out) as b:
        assert b.sides == ("L", "R")
        for side in "LR":
            assert len(b.unit(side).heel_strike_idx) >= 5
    assert main(["info", str(out)]) == 0
    assert "SR (L/R)" in capsys.readouterr().out
    assert not parts_of(out) and not list(tmp_path.glob("*.partial"))


def test_process_side_reprocesses_one_leg_into_a_one_unit_file(
    zeroed: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "left.h5"
    assert main(["process", str(zeroed), "--side", "L", "-o", str(out), "-q", "--method",
                 "paper"]) == 0  # fmt: skip
    with h5py.File(out, "r") as fo:
        assert not fo.attrs.get("bilateral", False) and "units" not in fo and "sync" not in fo
        ref = _one_unit_reference(zeroed, "L", tmp_path, "--method", "paper")
        with h5py.File(ref, "r") as fr:
            _same_unit(fo, fr)
    with open_session(out) as s:  # an ordinary one-unit session, its leg said
        assert s.meta.side == "L" and s.n_samples >= 1200
    assert main(["info", str(out)]) == 0
    assert "bilateral" not in capsys.readouterr().out


def test_process_side_is_checked(
    zeroed: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    one = tmp_path / "one.h5"
    assert main(["process", str(zeroed), "--side", "R", "-o", str(one), "-q"]) == 0
    assert main(["process", str(one), "--side", "R", "-o", str(tmp_path / "x.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == "gaitmon process: error: one.h5 records one unit; leave --side out"
    assert not (tmp_path / "x.h5").exists()
