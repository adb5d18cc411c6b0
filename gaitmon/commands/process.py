"""``gaitmon process FILE -o NEW``: re-run the pipeline offline from the raw counts.

The original file is never modified: NEW is a copy whose ``/processed`` series, ``/events`` and
``/config`` come from the new settings. The settings given apply to the whole recording;
standing calibrations logged during it are replayed at their rows.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import sys
from pathlib import Path

import numpy as np

from gaitmon.dsp.calibration import Calibration
from gaitmon.dsp.pipeline import PipelineConfig
from gaitmon.errors import UserError

# command-line option -> PipelineConfig field
SETTINGS = {
    "cutoff_hz": "low-pass cut-off (Hz)",
    "q_angle": "Kalman Q_angle",
    "q_gyro": "Kalman Q_gyro",
    "r": "Kalman R (accelerometer tilt variance)",
    "fsr_threshold": "FSR contact threshold (ADC counts)",
}


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", metavar="FILE", help="a raw-mode session file (.h5)")
    p.add_argument("-o", "--output", required=True, metavar="NEW", help="the new session file")
    for name, help_text in SETTINGS.items():
        p.add_argument(
            f"--{name.replace('_', '-')}",
            type=float,
            default=None,
            help=f"{help_text}; default: as recorded",
        )
    p.add_argument("--force", action="store_true", help="replace NEW if it exists")


def run(args: argparse.Namespace) -> int:
    from gaitmon.commands.info import progress_printer
    from gaitmon.io.session import SessionError, open_session

    src, dst = Path(args.file), Path(args.output)
    if dst.exists() and dst.resolve() == src.resolve():
        raise UserError("NEW must be a different file: the original recording is never modified")
    if dst.exists() and not args.force:
        raise UserError(f"{dst} already exists; choose another name or pass --force")
    if not dst.parent.is_dir():
        raise UserError(f"folder {dst.parent} does not exist")
    changes = {k: getattr(args, k) for k in SETTINGS if getattr(args, k) is not None}
    try:
        with open_session(src, progress=progress_printer("recovering")) as s:
            if s.mode != "raw":
                raise UserError(
                    f"{src.name} holds the unit's own {s.mode} angles, not raw counts; only "
                    "raw-mode sessions can be reprocessed"
                )
            try:
                config = s.config.replace(**changes)
            except ValueError as exc:
                raise UserError(f"bad setting: {exc}") from None
            calibration_log: list[tuple[int, Calibration]] = list(s.calibration_changes)
            adc = s.read("raw/adc")
            n = s.n_samples
            tmp = dst.with_name(dst.name + ".partial")
            shutil.copyfile(src, tmp)
    except SessionError as exc:
        raise UserError(str(exc)) from None
    try:
        _rewrite(tmp, adc, n, s.calibration, config, calibration_log)
        os.replace(tmp, dst)
    except OSError as exc:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise UserError(f"cannot write {dst}: {exc.strerror or exc}") from None
    print(
        f"gaitmon process: wrote {dst} ({n} frames) with "
        + (", ".join(f"{k}={v:g}" for k, v in changes.items()) or "the recorded settings"),
        file=sys.stderr,
    )
    return 0


def _rewrite(
    tmp: Path,
    adc: np.ndarray,
    n: int,
    calibration: Calibration,
    config: PipelineConfig,
    calibration_log: list[tuple[int, Calibration]],
) -> None:
    import h5py

    from gaitmon.commands.info import progress_printer
    from gaitmon.io.session import replay_pipeline

    report = progress_printer("reprocessing")
    with h5py.File(tmp, "r+") as f:
        proc = f["processed"]
        hs: list[np.ndarray] = []
        to: list[np.ndarray] = []
        replay = replay_pipeline(adc, config, calibration, calibration_log)
        for start, rows, hs_rows, to_rows in replay:
            stop = start + len(rows["processed/joint_deg"])
            for path, data in rows.items():
                f[path][start:stop] = data
            hs.append(hs_rows)
            to.append(to_rows)
            report(stop / max(n, 1))
        proc.attrs["reprocessed"] = True
        proc.attrs["source"] = "pc"
        ev = f["events"]
        for name, parts in (("heel_strike", hs), ("toe_off", to)):
            data = np.concatenate(parts) if parts else np.empty(0, np.int64)
            del ev[name]
            ev.create_dataset(name, data=data.astype(np.int64), maxshape=(None,), chunks=True)
        cfg = f["config"]
        for key, value in config.as_dict().items():
            cfg.attrs[key] = value
        cfg.attrs["event_delay_samples"] = config.event_delay_samples
        del cfg["changes"]
        dt = np.dtype([("sample_idx", np.int64), ("json", h5py.string_dtype())])
        cfg.create_dataset(
            "changes", data=np.array([], dtype=dt), maxshape=(None,), chunks=(256,)
        )
        cfg.attrs["reprocessed_from"] = json.dumps({"settings": config.as_dict()})
