"""Rows written as whole chunks compressed by libdeflate (gaitmon.io.session.chunk_write) read
back exactly as rows written through HDF5, from a real file, with HDF5's own filters."""

from __future__ import annotations

import itertools
import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest

import gaitmon.io.session.chunk_write as cw
from gaitmon.io.session.chunk_write import RowWriter

CASES = [  # dtype, width, rows per chunk, filters
    (np.int16, (4, 2), 256, {"shuffle": True, "compression": "gzip", "compression_opts": 6}),
    (np.int32, (2,), 100, {"shuffle": True, "compression": "gzip", "compression_opts": 6}),
    (np.uint8, (), 64, {"shuffle": True, "compression": "gzip", "compression_opts": 6}),
    (np.float64, (), 50, {"compression": "gzip", "compression_opts": 1}),
    (np.uint16, (14,), 7, {"shuffle": True, "compression": "gzip", "compression_opts": 9}),
    (np.float32, (3,), 40, {"shuffle": True, "compression": "lzf"}),  # (not deflate: HDF5's)
]


def _write_both(path: Path, data: np.ndarray, chunk: int, filters: dict, cuts: list[int]) -> None:
    with h5py.File(path, "w") as f:
        here = f.create_dataset("here", shape=data.shape, dtype=data.dtype,
                                chunks=(chunk, *data.shape[1:]), **filters)  # fmt: skip
        hdf5 = f.create_dataset("hdf5", shape=data.shape, dtype=data.dtype,
                                chunks=(chunk, *data.shape[1:]), **filters)  # fmt: skip
        writer = RowWriter(here.id)
        for a, b in itertools.pairwise(cuts):
            writer.write(a, data[a:b])
            hdf5[a:b] = data[a:b]


@pytest.mark.parametrize("dtype,width,chunk,filters", CASES)
def test_rows_read_back_as_written_through_hdf5(tmp_path, dtype, width, chunk, filters):
    rng = np.random.default_rng(chunk)
    n = 1037  # (the last chunk partial)
    data = rng.normal(0, 1000, (n, *width)).astype(dtype)
    # whole chunks, unaligned pieces, one row, the last chunk alone, rows written twice
    cuts = sorted({0, n, *rng.integers(0, n, 6).tolist(),
                   *range(0, n, 2 * chunk), n - n % chunk})  # fmt: skip
    path = tmp_path / "rows.h5"
    _write_both(path, data, chunk, filters, cuts)
    with h5py.File(path, "r") as f:
        assert np.array_equal(f["here"][()], data)
        assert np.array_equal(f["hdf5"][()], data)
        assert f["here"].compression == f["hdf5"].compression  # the dataset's own filters
        assert f["here"].compression_opts == f["hdf5"].compression_opts


def test_a_whole_chunk_is_stored_as_the_dataset_filter_would_decode_it(tmp_path):
    """The stored bytes of a chunk written here are a zlib stream of the shuffled chunk: what
    HDF5's deflate + shuffle filters (any HDF5 tool) decode."""
    data = np.arange(3 * 512 * 4, dtype=np.int16).reshape(-1, 4) * 7
    with h5py.File(tmp_path / "x.h5", "w") as f:
        ds = f.create_dataset("x", shape=data.shape, dtype=data.dtype, chunks=(512, 4),
                              shuffle=True, compression="gzip", compression_opts=6)  # fmt: skip
        RowWriter(ds.id).write(0, data)
        mask, stored = ds.id.read_direct_chunk((512, 0))
    assert mask == 0  # every filter applied
    chunk = data[512:1024]
    shuffled = chunk.view(np.uint8).reshape(-1, 2).T.tobytes()  # low bytes, then high bytes
    assert zlib.decompress(stored) == shuffled


def test_the_last_partial_chunk_and_a_later_overwrite(tmp_path):
    """The dataset's last rows (a partial chunk, stored padded) and a chunk written again with
    other values (as the recorder's drain then its full chunk): the latest values are read."""
    n, chunk = 1000, 256
    with h5py.File(tmp_path / "x.h5", "w") as f:
        ds = f.create_dataset("x", shape=(0, 2), maxshape=(None, 2), dtype=np.int32,
                              chunks=(chunk, 2), shuffle=True, compression="gzip")  # fmt: skip
        first = np.full((100, 2), -5, np.int32)
        ds.resize((768 + 100, 2))
        RowWriter(ds.id).write(768, first)  # (rows 0:768 never written: the fill value, 0)
        ds.resize((n, 2))
        last = np.arange(2 * (n - 768), dtype=np.int32).reshape(-1, 2)
        RowWriter(ds.id).write(768, last)
    with h5py.File(tmp_path / "x.h5", "r") as f:
        got = f["x"][()]
    assert np.array_equal(got[768:], last)
    assert not got[:768].any()


def _direct(ds: h5py.Dataset) -> list[int]:
    """The first rows of the chunks of ``ds`` whose stored bytes are libdeflate's stream of
    the shuffled chunk (written here; HDF5's zlib writes other bytes)."""
    from deflate import zlib_compress

    level = ds.compression_opts
    rows = ds.chunks[0]
    out = []
    for a in range(0, ds.shape[0], rows):
        chunk = np.zeros(ds.chunks, ds.dtype)
        part = ds[a : a + rows]
        chunk[: len(part)] = part
        shuffled = np.ascontiguousarray(chunk.reshape(-1).view(np.uint8)
                                        .reshape(-1, ds.dtype.itemsize).T)  # fmt: skip
        if ds.id.read_direct_chunk((a, *(0,) * (ds.ndim - 1)))[1] == zlib_compress(shuffled, level):
            out.append(a)
    return out


def test_whole_chunks_are_compressed_here_and_other_writes_go_through_hdf5(tmp_path):
    data = np.arange(1000 * 3, dtype=np.float32).reshape(-1, 3)
    _write_both(tmp_path / "x.h5", data, 100, {"shuffle": True, "compression": "gzip"},
                [0, 200, 250, 300, 900, 1000])  # fmt: skip
    with h5py.File(tmp_path / "x.h5", "r") as f:
        assert np.array_equal(f["here"][()], data)
        # 0:200 two whole chunks, 200:250 and 250:300 pieces of one (HDF5's), 300:900 six
        # whole chunks from an aligned start, 900:1000 the last
        assert _direct(f["here"]) == [0, 100, *range(300, 1000, 100)]
        assert _direct(f["hdf5"]) == []  # (the check tells the two apart)


def test_without_libdeflate_hdf5_writes_every_chunk(tmp_path, monkeypatch):
    data = (1000 * np.sin(np.arange(900 * 4) / 50.0)).astype(np.int16).reshape(-1, 4)
    monkeypatch.setattr(cw, "_compress", None)
    _write_both(tmp_path / "x.h5", data, 128, {"shuffle": True, "compression": "gzip"},
                [0, 256, 900])  # fmt: skip
    with h5py.File(tmp_path / "x.h5", "r") as f:
        assert np.array_equal(f["here"][()], data)
        assert _direct(f["here"]) == []


@pytest.mark.parametrize("fits", [True, False])
def test_a_dataset_that_fits_is_read_from_its_chunk_cache_after_the_first_pass(tmp_path, fits):
    """open_cached (``gaitmon process`` reads the raw counts in two or three passes): a dataset
    that fits in the cache is decompressed once, so a second pass reads the cache, not the
    file (shown by damaging the file's chunks between the passes); one that does not fit is
    opened as usual (a partial cache would hold nothing a pass in order reads again)."""
    from gaitmon.io.session.h5file import open_cached

    data = (1000 * np.sin(np.arange(80_000 * 14) / 77.0)).astype(np.uint16).reshape(-1, 14)
    path = tmp_path / "raw.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("raw/adc", data=data, chunks=(4096, 14), shuffle=True,
                         compression="gzip")  # fmt: skip
    with h5py.File(path, "r") as f:
        where = [f["raw/adc"].id.get_chunk_info(i) for i in range(f["raw/adc"].id.get_num_chunks())]
    with h5py.File(path, "r", rdcc_nbytes=1 << 20) as f:  # (the file's default: 1 MiB)
        ds = open_cached(f, "raw/adc", (64 << 20) if fits else (1 << 21))
        nbytes = ds.id.get_access_plist().get_chunk_cache()[1]
        assert nbytes >= data.nbytes if fits else nbytes == 1 << 20  # (not enlarged for part)
        assert np.array_equal(np.concatenate([ds[a : a + 5000] for a in range(0, len(data), 5000)]),
                              data)  # fmt: skip
        with open(path, "r+b") as raw:  # every chunk's bytes damaged on disk
            for info in where:
                raw.seek(info.byte_offset + 4)
                raw.write(b"\x00" * 32)
        if fits:
            again = f["raw/adc"]  # (another open of the same dataset shares the cache)
            assert np.array_equal(again[()], data)
        else:
            with pytest.raises(OSError):
                ds[()]
