"""The whole-process reference of ``gaitmon bench --suite whole``: VQF's online filter over a
gaitmon session, as a plain script (read, convert, filter, write; nothing of gaitmon imported).

    python -P bench_vqf.py SESSION.h5 OUT.h5

It does what ``gaitmon process`` does for the orientation, the way a researcher with the ``vqf``
package would (Laidig & Seel 2023, its compiled online filter ``VQF.updateBatch``, 6D: gyro and
accelerometer): read the raw ADC counts ``/raw/adc`` and the channel table ``/device/channels``
with h5py; convert counts to m/s^2 and rad/s as gaitmon does (``(counts - zero_counts) *
units_per_count``, both from the table's volts: ``gaitmon.dsp.channel_table.ChannelSpec``); run one
online VQF per segment (the board measures a_x, a_z and the rate about y: the other axes are
zero); write each segment's 6D quaternion as float32, shuffle + gzip 6 as gaitmon writes its
series, into a new HDF5 file ``/vqf/<segment>/quat6D`` (N, 4). It is run by path with ``-P`` so
that neither gaitmon's package nor its modules are imported: the reference pays for its own
imports only.
"""

from __future__ import annotations

import sys

import h5py
import numpy as np
from vqf import VQF  # type: ignore[import-untyped,import-not-found,unused-ignore]

COMPRESSION = {"shuffle": True, "compression": "gzip", "compression_opts": 6}


def physical(adc: np.ndarray, table: np.ndarray) -> np.ndarray:
    """(N, channels) counts -> float64 in each channel's unit, from the stored channel table."""
    volts_per_count = table["vref_v"] / 2.0 ** table["adc_bits"]
    zero_counts = table["zero_v"] / volts_per_count
    units_per_count = volts_per_count / table["sensitivity_v_per_unit"]
    out: np.ndarray = (adc.astype(np.float64) - zero_counts) * units_per_count
    return out


def run(src: str, dst: str) -> int:
    """Filter ``src`` into ``dst``; the number of rows written per segment."""
    with h5py.File(src, "r") as f:
        adc = f["raw/adc"][()]
        table = f["device/channels"][()]
        fs_hz = float(f.attrs["sample_rate_hz"])
    x = physical(adc, table)
    kinds = [k.decode() if isinstance(k, bytes) else str(k) for k in table["kind"]]
    segs = [s.decode() if isinstance(s, bytes) else str(s) for s in table["segment"]]
    column = {(s, k): i for i, (s, k) in enumerate(zip(segs, kinds, strict=True))}
    n = len(x)
    with h5py.File(dst, "w") as out:
        for seg in dict.fromkeys(s for s, k in zip(segs, kinds, strict=True) if k == "gyro"):
            gyr = np.zeros((n, 3))
            acc = np.zeros((n, 3))
            gyr[:, 1] = x[:, column[(seg, "gyro")]]
            acc[:, 0] = x[:, column[(seg, "acc_x")]]
            acc[:, 2] = x[:, column[(seg, "acc_z")]]
            quat = VQF(1.0 / fs_hz).updateBatch(gyr, acc)["quat6D"]
            out.create_dataset(f"vqf/{seg}/quat6D", data=quat.astype(np.float32), **COMPRESSION)
    return n


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit("usage: python -P bench_vqf.py SESSION.h5 OUT.h5")
    run(sys.argv[1], sys.argv[2])
