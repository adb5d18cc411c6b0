"""Ground truth of a simulated recording, stored in the session file as ``/truth``.

Only sessions recorded from the simulated unit have it. Every row of the session is mapped back
to the sample the unit generated (through the unit's frame log: the file's unwrapped sequence
number is the unit's frame number), so researchers can score any filter against what really
happened. The ``/truth`` layout and the writing belong to :mod:`gaitmon.io.session.truth`.

Besides the per-row truth and the events, ``stride_length_m``, ``stride_time_s`` and
``foot_clearance_m`` hold, for each ``heel_strike`` row, the true stride it opens
(gaitmon.io.sim.kinematics.GaitModel.strides).
"""

from __future__ import annotations

import contextlib
from pathlib import Path

import numpy as np

from gaitmon.errors import DAMAGE_ERRORS
from gaitmon.io.session.h5file import _short_error
from gaitmon.io.session.header import SessionError
from gaitmon.io.session.opening import read_stored
from gaitmon.io.session.truth import truth_writer
from gaitmon.io.sim.unit import SimulatedUnit


def row_samples(seq: np.ndarray, unit: SimulatedUnit) -> np.ndarray:
    """Sample index of each recorded row (-1 where the frame is not in the unit's log)."""
    return unit.samples_of(seq)


# Rows of the per-row truth computed at once, and samples of the events' strides: the
# simulator's truth costs ~1.5 kB of temporaries a sample (its kinematics, each stride's 201-point
# foot path), so the truth of a whole record at once made finishing a `record --simulate` peak
# at 503 MB for 20 minutes, 919 MB for 1 h, 5.1 GB for 2 h (issue 26). 10,000 rows: ~15 MB; the
# peak no longer grows with the record: each row's sample waits in a temporary file.
# The values are the same: the truth is a function of the sample index
# (tests/test_recorder_memory.py compares blocked and whole).
TRUTH_BLOCK_ROWS = 10_000


# Bytes of /truth a row takes (sample_idx int64; tilt, joint, gyro bias: 11 float32), of an
# event (its row, int64) and of a stride (3 float64); and room for HDF5's own (object headers,
# the attributes `describe` adds: ~10 kB measured) claimed on top.
_ROW_BYTES = 8 + 4 * 11
_EVENT_BYTES = 8
_STRIDE_BYTES = 3 * 8
TRUTH_HEADROOM_BYTES = 256 * 1024


def attach_ground_truth(path: str | Path, unit: SimulatedUnit,
                        block_rows: int = TRUTH_BLOCK_ROWS) -> int:  # fmt: skip
    """Write ``/truth`` into a finished session file, ``block_rows`` rows at a time; returns
    the number of rows mapped. Nothing of a row's is held for the whole record (issue 26):
    each row's sample waits in an unnamed temporary file (8 bytes a row) between the pass that
    maps the rows (the file open to read) and the one that writes them (open to write).

    A full disk (or any write error) raises :class:`SessionError` with one line: the
    recording itself is complete and stays as it was, without ``/truth`` (its space is claimed
    before HDF5 writes: ``truth_writer``)."""
    try:
        return _attach(Path(path), unit, block_rows)
    except (OSError, RuntimeError) as e:  # h5py's write errors can be RuntimeError, no errno
        raise SessionError(_truth_error(Path(path), e)) from e


def _truth_error(path: Path, e: BaseException) -> str:
    """The one line for a ground truth that could not be written: the recording's words for
    a write error (``SessionWriter``), and what the file still holds."""
    what = "the recording is complete and saved"
    with contextlib.suppress(SessionError, *DAMAGE_ERRORS), read_stored(path) as s:
        what = (f"the recording is complete and saved ({s.n_samples} rows, "
                f"{s.duration_s:.1f} s)")  # fmt: skip
    return (f"disk full or write error while storing the simulator's ground truth in "
            f"{path.name}: {_short_error(e)}; {what}, without /truth; free some space to record "
            "one with it")  # fmt: skip


def _attach(path: Path, unit: SimulatedUnit, block_rows: int) -> int:
    import tempfile

    n_valid, lo, hi = 0, 0, 0
    with tempfile.TemporaryFile(dir=Path(path).parent) as tmp:
        with read_stored(Path(path)) as s:
            n = s.n_samples
            for a in range(0, n, block_rows):
                seq = s.read_range(a, a + block_rows, ["timeline/seq"])["timeline/seq"]
                got = unit.samples_of(seq)  # (the frame log's runs: no row per frame)
                tmp.write(np.ascontiguousarray(got, dtype=np.int64).tobytes())
                mapped = got[got >= 0]
                if len(mapped):
                    b_lo, b_hi = int(mapped.min()), int(mapped.max()) + 1
                    lo, hi = (b_lo, b_hi) if not n_valid else (min(lo, b_lo), max(hi, b_hi))
                    n_valid += len(mapped)
        if not n_valid:
            return 0

        def samples(a: int) -> np.ndarray:  # rows a:a + block_rows
            tmp.seek(a * 8)
            return np.frombuffer(tmp.read(min(block_rows, n - a) * 8), dtype=np.int64)

        # the events and the strides they open, piece by piece over the samples (each stride
        # is one heel strike's: the pieces partition them)
        parts = [unit.true_events(a, min(a + block_rows, hi)) for a in range(lo, hi, block_rows)]
        hs = np.concatenate([p[0] for p in parts])
        to = np.concatenate([p[1] for p in parts])
        strides = {k: np.concatenate([getattr(p[2], k) for p in parts])
                   for k in ("stride_length_m", "stride_time_s", "foot_clearance_m")}  # fmt: skip
        del parts
        # each event's row: the first recorded row at/after it (-1: after the last one)
        at = {"heel_strike": np.full(len(hs), -1, np.int64),
              "toe_off": np.full(len(to), -1, np.int64)}  # fmt: skip
        reserve = (n * _ROW_BYTES + (len(hs) + len(to)) * _EVENT_BYTES
                   + len(hs) * _STRIDE_BYTES + TRUTH_HEADROOM_BYTES)  # fmt: skip
        mount_deg = np.degrees(unit.truth(0, 0).mount_offset_rad)
        with truth_writer(path, mount_deg, reserve_bytes=reserve) as g:
            column = g.column("sample_idx", n, np.int64)
            out = {name: g.rows(name, n, cols) for name, cols in _PER_ROW.items()}
            for a in range(0, n, block_rows):
                got = samples(a)
                column[a : a + len(got)] = got
                for name, data in _per_row(unit, got).items():
                    out[name][a : a + len(data)] = data
                rows = np.flatnonzero(got >= 0)
                for name, ev in (("heel_strike", hs), ("toe_off", to)):
                    _first_at(at[name], ev, got[rows], rows + a)
            for name, rows in at.items():
                g.put(name, rows[rows >= 0])
            kept = at["heel_strike"] >= 0  # the stride each recorded hs opens
            for name, data in strides.items():
                g.put(name, data[kept])
        return n_valid


def _first_at(found: np.ndarray, events: np.ndarray, recorded: np.ndarray,
              rows: np.ndarray) -> None:  # fmt: skip
    """Give each event not yet ``found`` (-1) the first of ``rows`` whose sample
    (``recorded``, increasing, as the blocks before) is at or after it: over consecutive
    blocks, ``np.searchsorted`` of the whole record's recorded samples."""
    if not len(recorded):
        return
    todo = (found < 0) & (events <= recorded[-1])
    found[todo] = rows[np.searchsorted(recorded, events[todo])]


_PER_ROW = {"tilt_deg": 4, "joint_deg": 3, "gyro_bias_rad_s": 4}


def _per_row(unit: SimulatedUnit, samples: np.ndarray) -> dict[str, np.ndarray]:
    """The per-row truth (float32, NaN on unmapped rows) of rows whose samples are
    ``samples``."""
    valid = samples >= 0
    if not valid.any():
        return {name: np.full((len(samples), cols), np.nan, np.float32)
                for name, cols in _PER_ROW.items()}  # fmt: skip
    lo, hi = int(samples[valid].min()), int(samples[valid].max()) + 1
    truth = unit.truth(lo, hi)
    idx = np.clip(samples - lo, 0, hi - lo - 1)
    out = {}
    for name, arr in (("tilt_deg", np.degrees(truth.tilt_rad)),
                      ("joint_deg", np.degrees(truth.joint_rad)),
                      ("gyro_bias_rad_s", truth.gyro_bias_rad_s)):  # fmt: skip
        rows = arr[idx].astype(np.float32)
        rows[~valid] = np.nan
        out[name] = rows
    return out
