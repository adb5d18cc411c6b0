"""A session file read without gaitmon: every physical series from h5py and the attributes alone.

Sessions are recorded with the real recorder (``gaitmon record --simulate``, one leg and both
legs) and, for files written before the attributes existed, rewritten by ``gaitmon process``
(the kept golden fixtures). The decoding here uses only h5py, numpy and each dataset's own
attributes (CF: ``value * scale_factor + add_offset``, ``_FillValue``/``missing_value`` -> NaN;
the groups' ``derivation`` for the series a file derives on read): the joint pairs are parsed
from that text and the gyro conversion from ``/device/channels``. The result must equal what
gaitmon's own reader gives, within the series' quantum.
"""

from __future__ import annotations

import contextlib
import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from gaitmon.cli import main

GOLDEN = Path(__file__).resolve().parent / "data" / "golden"


# -- the decoding a researcher writes: h5py and the attributes, nothing of gaitmon --------------


def physical(ds: h5py.Dataset) -> np.ndarray:
    """A dataset's values in its ``units``: CF unpacking, missing values as NaN."""
    stored = ds[()]
    x = stored.astype(np.float64)
    for key in ("_FillValue", "missing_value"):
        if key in ds.attrs:
            x[stored == ds.attrs[key]] = np.nan
    return x * float(ds.attrs.get("scale_factor", 1.0)) + float(ds.attrs.get("add_offset", 0.0))


def joints_from_derivation(group: h5py.Group, tilt_name: str) -> tuple[list[str], np.ndarray]:
    """The joint angles a group derives on read, rebuilt from its ``derivation`` text: the
    segment differences it names, over the tilts' ``columns``, wrapped to (-180, 180]."""
    text = str(group.attrs["derivation"])
    m = re.search(r"\(([a-z_, ]+)\) = \(([a-z_, -]+)\) of tilt_deg", text)
    assert m is not None, text
    names = [n.strip() for n in m.group(1).split(",")]
    pairs = [tuple(p.strip() for p in d.split(" - ")) for d in m.group(2).split(",")]
    tilt_ds = group[tilt_name]
    cols = [str(c) for c in tilt_ds.attrs["columns"]]
    tilt = physical(tilt_ds)
    d = np.stack([tilt[:, cols.index(a)] - tilt[:, cols.index(b)] for a, b in pairs], axis=1)
    assert "wrapped to (-180, 180]" in text
    d = np.where(d > 180, d - 360, d)
    return names, np.where(d <= -180, d + 360, d)


def gyro_from_counts(root: h5py.Group) -> np.ndarray:
    """``gyro_rad_s`` as ``/processed``'s derivation says: the gyro columns of ``/raw/adc`` in
    physical units by ``/device/channels``, minus the calibration's bias (no changes here)."""
    ch = root["device/channels"][()]
    adc = root["raw/adc"][()].astype(np.float64)
    volts = adc * ch["vref_v"] / 2.0 ** ch["adc_bits"]
    phys = (volts - ch["zero_v"]) / ch["sensitivity_v_per_unit"]
    kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in ch["kind"]]
    gyro = phys[:, [i for i, k in enumerate(kinds) if k == "gyro"]]
    assert len(root["calibration/changes"]) == 0
    return gyro - np.asarray(root["calibration"].attrs["gyro_bias_rad_s"])


def by_attributes(root: h5py.Group) -> dict[str, np.ndarray]:
    """Every per-sample physical series of a unit, stored or derived, from attributes alone."""
    out = {}
    for group in ("processed", "smoothed"):
        if group not in root:
            continue
        g = root[group]
        for name, ds in g.items():
            if "flag_values" not in ds.attrs:  # (states are not physical series)
                out[f"{group}/{name}"] = physical(ds)
        derived = [str(n) for n in g.attrs.get("derived_on_read", [])]
        for name in derived:
            if name.startswith("joint"):
                tilt = name.replace("joint", "tilt")
                if tilt in g:
                    cols, out[f"{group}/{name}"] = joints_from_derivation(g, tilt)
                    assert cols == ["hip_flexion", "knee_flexion", "ankle_dorsiflexion"]
            elif name == "gyro_rad_s":
                out[f"{group}/{name}"] = gyro_from_counts(root)
    out["timeline/t_s"] = physical(root["timeline/t_s"])
    return out


# -- the comparison with gaitmon's reader -------------------------------------------------------


def check_unit(root: h5py.Group, session: object) -> int:
    """Compare every series of one unit with gaitmon's reader; the number compared."""
    from gaitmon.io.session.codec import tolerance

    got = by_attributes(root)
    compared = 0
    for path, x in got.items():
        name = path.replace("smoothed/", "processed/")
        source = "smoothed" if path.startswith("smoothed/") else "live"
        if name not in session.dataset_names:  # type: ignore[attr-defined]
            continue
        view = session.with_angles(source) if source in session.angle_sources else session  # type: ignore[attr-defined]
        ref = np.asarray(view.read(name), dtype=np.float64)
        assert x.shape == ref.shape, path
        assert np.array_equal(np.isnan(x), np.isnan(ref)), path
        quantum = max(tolerance(path), 1e-6 * max(1.0, float(np.nanmax(np.abs(ref)))))
        err = float(np.nanmax(np.abs(x - ref))) if x.size else 0.0
        assert err <= quantum * 1.001 + 1e-6, (path, err, quantum)
        compared += 1
    return compared


def check_every_dataset_described(f: h5py.File) -> list[str]:
    """Names of datasets without long_name, or numeric ones without units."""
    bad: list[str] = []

    def visit(name: str, obj: object) -> None:
        if not isinstance(obj, h5py.Dataset):
            return
        if "long_name" not in obj.attrs:
            bad.append(f"{name}: no long_name")
        if obj.dtype.names is None and obj.dtype.kind in "iuf" and "units" not in obj.attrs:
            bad.append(f"{name}: no units")
        if obj.dtype.names is not None and "field_units" not in obj.attrs:
            bad.append(f"{name}: no field_units")
        if obj.dtype.kind in "iu" and obj.ndim == 2 and "columns" not in obj.attrs and not (
            name.endswith(("sample_idx",))
        ):
            bad.append(f"{name}: no columns")

    f.visititems(visit)
    return bad


@pytest.fixture(scope="module")
def one_leg(tmp_path_factory: pytest.TempPathFactory, record_simulated) -> Path:
    path = tmp_path_factory.mktemp("cf") / "walk.h5"
    return record_simulated(path, "--loss-pct", "2", "--side", "R", duration_s=20)


@pytest.fixture(scope="module")
def two_legs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("cf2") / "both.h5"
    rc = main(["record", "--simulate-bilateral", "--duration", "10", "--speed", "4",
               "-o", str(out), "-q"])  # fmt: skip
    assert rc == 0
    return out


def test_one_leg_file_gives_every_series_from_its_attributes(one_leg: Path) -> None:
    from gaitmon.finish import open_session

    with h5py.File(one_leg, "r") as f:
        assert check_every_dataset_described(f) == []
        tilt = f["processed/tilt_deg"]
        assert tilt.dtype == np.int16  # stored values and dtypes unchanged: only described
        assert tilt.attrs["units"] == "degree" and float(tilt.attrs["scale_factor"]) == 0.01
        assert [str(c) for c in tilt.attrs["columns"]] == ["body", "thigh", "shank", "foot"]
        assert int(tilt.attrs["_FillValue"]) == -32768
        assert "add_offset" not in tilt.attrs  # (no series has an offset)
        with open_session(one_leg) as s:
            n = check_unit(f, s)
            # tilts (3), accelerations, force sensors, joints (3, derived), gyro (derived),
            # smoothed tilts and joints, the timeline
            assert n == 12, n
            # the overview's bins are the reader's joint angles' min/max, in degrees
            joint = s.with_angles("smoothed").read("processed/joint_deg")
            lo = physical(f["overview/smoothed_joint_deg/min"])
            k = len(joint) // 16
            want = joint[: 16 * k].reshape(k, 16, 3).min(axis=1)
            assert np.nanmax(np.abs(lo[:k] - want)) <= 0.005 + 1e-6
            # strides: metres as gaitmon measures them; -1 anchors are missing values
            m = s.foot_stride_measures()
            assert np.allclose(physical(f["strides/stride_length_m"]), m.stride_length_m,
                               equal_nan=True)  # fmt: skip
        # a gap's duration in seconds, from the table's field_units
        gaps = f["gaps"]
        units = dict(zip(gaps.dtype.names, [str(u) for u in gaps.attrs["field_units"]],
                         strict=True))  # fmt: skip
        assert units["duration_s"] == "s" and len(gaps) > 0


def test_two_leg_file_units_and_sync_are_described(two_legs: Path) -> None:
    from gaitmon.finish import open_session

    with h5py.File(two_legs, "r") as f:
        assert check_every_dataset_described(f) == []
        for side in ("L", "R"):
            with open_session(two_legs, side=side) as s:
                assert check_unit(f[f"units/{side}"], s) == 12


def test_process_describes_a_file_written_before_the_attributes(tmp_path: Path) -> None:
    """``gaitmon process`` of the kept fixtures (recorded before the attributes existed):
    the output is described throughout, one leg and both."""
    from gaitmon.finish import open_session

    for name in ("one_leg", "two_legs"):
        src = tmp_path / f"{name}.h5"
        shutil.copyfile(GOLDEN / f"{name}.h5", src)
        with h5py.File(src, "r") as f:
            assert "units" not in f["timeline/t_s" if name == "one_leg" else
                                    "units/L/timeline/t_s"].attrs  # fmt: skip
        out = tmp_path / f"{name}_p.h5"
        assert main(["process", str(src), "-o", str(out), "-q"]) == 0
        with h5py.File(out, "r") as f:
            assert check_every_dataset_described(f) == []
            if name == "one_leg":
                with open_session(out) as s:
                    assert check_unit(f, s) >= 10


@pytest.mark.parametrize("mode", ["tilt", "joint"])
def test_the_units_own_angles_are_described_too(mode: str, tmp_path: Path, record_simulated
                                                 ) -> None:  # fmt: skip
    """Modes tilt and joint store the unit's angles (joint: the joint angles themselves,
    quantised; tilt: the tilts, the joints derived): the same reconstruction holds."""
    from gaitmon.finish import open_session

    path = record_simulated(tmp_path / f"{mode}.h5", "--mode", mode, duration_s=10)
    with h5py.File(path, "r") as f, open_session(path) as s:
        assert check_every_dataset_described(f) == []
        assert "raw" not in f and "smoothed" not in f
        n = check_unit(f, s)
        assert n == (5 if mode == "tilt" else 3), n  # tilts 2 + joints 2 + t_s; joints 2 + t_s
        if mode == "joint":
            assert float(f["processed/joint_deg"].attrs["scale_factor"]) == 0.01
            assert "derived_on_read" not in f["processed"].attrs


def test_steps_described_once_are_described_at_the_end_and_not_after_an_error(tmp_path):
    """A command that adds datasets in steps (process, a recording's close, recovery) describes
    the file once at the end (issue 28: four passes cost ~60 ms of a 1-min ``process``); an
    error within leaves the file as it is."""
    from gaitmon.io.session.attributes import describe, described_once

    for fails in (False, True):
        with h5py.File(tmp_path / f"steps-{fails}.h5", "w") as f:
            f.attrs["format_version"] = 2
            ds = f.create_dataset("timeline/t_s", data=np.arange(5.0))
            expect = pytest.raises(RuntimeError) if fails else contextlib.nullcontext()
            with expect, described_once(f):
                describe(f)  # (a step's own describe: held)
                assert "units" not in ds.attrs
                if fails:
                    raise RuntimeError("disk full")
            assert ("units" in ds.attrs) is not fails
            if not fails:
                assert ds.attrs["units"] == "s"
