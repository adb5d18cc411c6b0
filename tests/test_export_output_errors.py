"""An export that cannot be written is the output's problem, never the recording's damage
(issue 25, defect 1): a read-only drive (EROFS), a missing permission, a full disk or too long
a name gives one line naming the OUTPUT path and what to do, and no file is left behind.

The read-only drive is made two ways: every write, create and delete under one folder raises
the kernel's EROFS (monkeypatched at the calls the writers use: ``open``, ``os.replace``,
``unlink``), and, where the sandbox allows a user namespace, a real read-only tmpfs mount.
"""

from __future__ import annotations

import builtins
import errno
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_export import write_session

from gaitmon.cli import main

DAMAGED = "damaged and cannot be analysed"


class ReadOnlyFolder:
    """Make ``folder`` behave as a read-only drive for this process: creating, writing,
    renaming into and deleting anything in it raise OSError(EROFS) as the kernel does
    (deleting a file that is not there included)."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, folder: Path,
                 code: int = errno.EROFS) -> None:  # fmt: skip
        self.folder = os.path.abspath(folder)
        self.code = code
        real_open, real_replace, real_unlink = builtins.open, os.replace, os.unlink

        def inside(p: object) -> bool:
            if not isinstance(p, (str, os.PathLike)):
                return False
            return os.path.dirname(os.path.abspath(os.fspath(p))) == self.folder

        def refuse(p: object) -> OSError:
            return OSError(self.code, os.strerror(self.code), os.fspath(p))  # type: ignore[arg-type]

        def fake_open(file, mode="r", *args, **kwargs):  # type: ignore[no-untyped-def]
            if inside(file) and any(c in mode for c in "wax+"):
                raise refuse(file)
            return real_open(file, mode, *args, **kwargs)

        def fake_replace(src, dst, *args, **kwargs):  # type: ignore[no-untyped-def]
            if inside(dst) or inside(src):
                raise refuse(dst)
            return real_replace(src, dst, *args, **kwargs)

        def fake_unlink(path, *args, **kwargs):  # type: ignore[no-untyped-def]
            if inside(path):
                raise refuse(path)
            return real_unlink(path, *args, **kwargs)

        monkeypatch.setattr(builtins, "open", fake_open)
        monkeypatch.setattr(os, "replace", fake_replace)
        monkeypatch.setattr(os, "unlink", fake_unlink)


def _error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


@pytest.fixture(scope="module")
def both(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short recording of both legs."""
    out = tmp_path_factory.mktemp("both") / "walk.h5"
    rc = main(["record", "--simulate-bilateral", "--duration", "8", "--speed", "4", "-q",
               "-o", str(out)])  # fmt: skip
    assert rc == 0 and out.exists()
    return out


@pytest.mark.parametrize("fmt", ["csv", "mat", "c3d", "strides"])
@pytest.mark.parametrize("code", [errno.EROFS, errno.ENOSPC, errno.EACCES, errno.ENAMETOOLONG])
def test_an_unwritable_output_is_not_called_damage(tmp_path, capsys, monkeypatch, fmt, code):
    src = tmp_path / "walk.h5"
    write_session(src, "raw")
    ro = tmp_path / "ro"
    ro.mkdir()
    out = ro / f"out.{fmt}"
    ReadOnlyFolder(monkeypatch, ro, code)
    msg = _error(capsys, ["export", str(src), "--format", fmt, "-o", str(out)])
    assert DAMAGED not in msg and "walk.h5" not in msg, msg
    assert f"cannot write {out}" in msg, msg  # the output's own name, not a temporary one
    assert ".partial" not in msg, msg
    assert f"errno {code}" in msg, msg
    what = {errno.EROFS: "read-only", errno.ENOSPC: "disk is full",
            errno.EACCES: "no permission", errno.ENAMETOOLONG: "too long"}[code]  # fmt: skip
    assert what in msg, msg
    assert list(ro.iterdir()) == []


def test_an_unwritable_output_of_both_legs_is_not_called_damage(both, tmp_path, capsys,
                                                                monkeypatch):  # fmt: skip
    ro = tmp_path / "ro"
    ro.mkdir()
    ReadOnlyFolder(monkeypatch, ro)
    msg = _error(capsys, ["export", str(both), "--format", "csv", "-o", str(ro / "w.csv")])
    assert DAMAGED not in msg and "read-only" in msg and "errno 30" in msg, msg
    assert f"cannot write {ro / 'w_L.csv'}" in msg, msg
    assert list(ro.iterdir()) == []


def _ro_mount_works() -> bool:
    if sys.platform != "linux" or shutil.which("unshare") is None:
        return False
    try:
        r = subprocess.run(["unshare", "-rm", "sh", "-c", "mount -t tmpfs -o ro tmpfs /mnt"],
                           capture_output=True, timeout=20)  # fmt: skip
    except (OSError, subprocess.SubprocessError):
        return False
    return r.returncode == 0


@pytest.mark.skipif(not _ro_mount_works(), reason="no user namespace to mount a read-only drive")
def test_a_real_read_only_drive(tmp_path):
    src = tmp_path / "walk.h5"
    write_session(src, "raw")
    ro = tmp_path / "ro"
    ro.mkdir()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    lines = []
    for fmt in ("csv", "mat", "c3d"):
        out = ro / f"out.{fmt}"
        cmd = (f"mount -t tmpfs -o ro tmpfs {ro} && exec {sys.executable} -m gaitmon export "
               f"{src} --format {fmt} -o {out}")
        r = subprocess.run(["unshare", "-rm", "sh", "-c", cmd], capture_output=True, text=True,
                           env=env, timeout=120)  # fmt: skip
        assert r.returncode == 2, r.stderr
        assert DAMAGED not in r.stderr and "Traceback" not in r.stderr, r.stderr
        assert f"cannot write {out}: the drive is read-only (errno 30)" in r.stderr, r.stderr
        lines.append(r.stderr)
    assert len(lines) == 3


@pytest.mark.skipif(not _ro_mount_works(), reason="no user namespace to mount a read-only drive")
def test_a_report_or_comparison_into_a_read_only_drive_is_one_line(tmp_path):
    """Issue 25, words: a report (or a comparison's PDF) into a read-only folder printed Qt's
    own "QPainter::begin(): Returned false" and the temporary file's name ("[Errno 30] ...
    '.r.pdf.6059.tmp'"); now one line naming the PDF asked for, the cause and what to do."""
    src, again = tmp_path / "walk.h5", tmp_path / "again.h5"
    for out in (src, again):
        assert main(["record", "--simulate", "--duration", "20", "--speed", "max", "-q",
                     "--patient", "P1", "-o", str(out)]) == 0  # fmt: skip
    ro = tmp_path / "ro"
    ro.mkdir()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path), "QT_QPA_PLATFORM": "offscreen"}
    for argv in (["report", str(src)], ["compare", str(src), str(again)]):
        out = ro / f"{argv[0]}.pdf"
        cmd = (f"mount -t tmpfs -o ro tmpfs {ro} && exec {sys.executable} -m gaitmon "
               f"{' '.join(argv)} -o {out}")
        r = subprocess.run(["unshare", "-rm", "sh", "-c", cmd], capture_output=True, text=True,
                           env=env, timeout=180)  # fmt: skip
        assert r.returncode == 2, r.stderr
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1, r.stderr  # no Qt warning before it
        assert "QPainter" not in r.stderr and ".tmp" not in r.stderr, r.stderr
        assert f"cannot write {out}: the drive is read-only (errno 30)" in r.stderr, r.stderr


@pytest.mark.parametrize("fmt", ["csv", "strides"])
def test_a_damaged_source_read_while_writing_is_called_damage(tmp_path, capsys, monkeypatch, fmt):
    """An HDF5 library error met while the writer reads the source (a damaged heap or chunk the
    reader's checks at the file's edge could not see) is the source's damage, not a problem
    of the output's folder (it was called "cannot write out.csv: Can't synchronously read
    data ...; choose another folder or name")."""
    import h5py

    from gaitmon.export.registry import FORMATS

    src = tmp_path / "walk.h5"
    write_session(src, "raw")
    broken = tmp_path / "broken.h5"  # a real HDF5 file with a damaged chunk
    with h5py.File(broken, "w") as f:
        f.create_dataset("x", data=np.arange(4096, dtype=np.int32), chunks=(1024,),
                         compression="gzip")  # fmt: skip
        info = f["x"].id.get_chunk_info(1)
    with open(broken, "r+b") as fh:
        fh.seek(info.byte_offset + 8)
        fh.write(b"\xff" * 64)
    form = type(FORMATS[fmt])
    made = form.unit_writer

    def unit_writer(self, options):  # type: ignore[no-untyped-def]
        # (csv's writer is a module: its write is patched through monkeypatch, so undone)
        writer = made(self, options)
        write = writer.write

        def reading_damage(*args, **kwargs):  # type: ignore[no-untyped-def]
            with h5py.File(broken, "r") as f:
                f["x"][()]  # raises the HDF5 library's OSError, as a damaged source does
            return write(*args, **kwargs)

        monkeypatch.setattr(writer, "write", reading_damage)
        return writer

    monkeypatch.setattr(form, "unit_writer", unit_writer)
    out = tmp_path / f"out.{fmt}"
    msg = _error(capsys, ["export", str(src), "--format", fmt, "-o", str(out)])
    assert "walk.h5 is damaged and cannot be exported" in msg, msg
    assert "cannot write" not in msg and "synchronously" not in msg, msg
    assert not out.exists() and not list(tmp_path.glob("out*"))


def test_after_the_damaged_source_test_an_export_of_a_good_file_works(tmp_path, monkeypatch,
                                                                      capsys):  # fmt: skip
    """The test above patches the csv writer (a module): once it is over, csv writes again
    (it once left the module's write patched, and every later csv export in that worker
    process read the damaged file)."""
    (tmp_path / "a").mkdir()
    test_a_damaged_source_read_while_writing_is_called_damage(tmp_path / "a", capsys,
                                                              monkeypatch, "csv")  # fmt: skip
    monkeypatch.undo()
    src = tmp_path / "walk.h5"
    write_session(src, "raw")
    assert main(["export", str(src), "--format", "csv", "-q", "-o", str(tmp_path / "w.csv")]) == 0
