"""What a user gets from two recorded fixtures, in a form that can be compared across versions.

The fixtures in ``tests/data/golden`` are real recordings of the simulated unit (one leg with
random frame loss, a stored exclusion and notes; both legs with a hemiparetic walk), recorded
once and kept, so that the simulator may change without moving them. ``collect`` runs the
user's commands on a copy of each (``info``, ``process``, every ``export`` format, ``report``)
through ``gaitmon.cli.main``, exactly as a user types them, and reads every output back with a
library that is not gaitmon's (h5py, scipy.io.loadmat, ezc3d, pypdf, plain text) into a flat
``{name: text or array}``. The expected values were collected by the code before issue 23's
reshaping (``python tests/golden.py`` rewrites them: only do that for a change that is meant
to change what a user sees, and say so in the commit).

Compared as a user would: texts token by token, numbers in them and arrays within a relative
1e-7 (integers within 1 LSB, the quantised series), so that a new numpy's last-bit rounding does
not count as a change; times of day, the output folder and gaitmon's version are masked.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import re
import shutil
import sys
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
DATA = HERE / "data" / "golden"
FIXTURES = ("one_leg", "two_legs")
EXPECTED = DATA / "expected.npz"

_TIME = re.compile(
    r"\d{4}-\d{2}-\d{2}[T\s]\d{2}:\d{2}(:\d{2}(\.\d+)?)?(Z|\+00:00|\s+UTC)?"
    r"|\d{4}\d{2}\d{2}T\d{6}Z?"
)
_NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")
# tokens are split on whitespace and on the separators of CSV/TSV/JSON
_SPLIT = re.compile(r"[\s,;:\t\"'\[\]{}()=]+")


def _mask(text: str, tmp: Path) -> str:
    import gaitmon

    text = text.replace(str(tmp), "<tmp>").replace(gaitmon.__version__, "<version>")
    return _TIME.sub("<time>", text)


def _cli(argv: list[str]) -> str:
    from gaitmon.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        rc = main(argv)
    if rc not in (0, None):
        raise AssertionError(f"gaitmon {' '.join(argv)} exited {rc}: {err.getvalue()}")
    return out.getvalue()


def _h5(path: Path, prefix: str, tmp: Path) -> Iterator[tuple[str, object]]:
    import h5py

    def attrs(name: str, obj: h5py.HLObject) -> Iterator[tuple[str, object]]:
        for k in sorted(obj.attrs):
            v = obj.attrs[k]
            if isinstance(v, bytes):
                v = v.decode("utf-8", "replace")
            if isinstance(v, str):
                yield f"{prefix}{name}@{k}", _mask(v, tmp)
            else:
                arr = np.asarray(v)
                if arr.dtype.kind in "OSU":
                    yield f"{prefix}{name}@{k}", _mask(
                        json.dumps([x.decode() if isinstance(x, bytes) else str(x)
                                    for x in arr.ravel()]), tmp)  # fmt: skip
                else:
                    yield f"{prefix}{name}@{k}", arr

    with h5py.File(path, "r") as f:
        yield from attrs("/", f)
        names: list[str] = []
        f.visit(names.append)
        for name in sorted(names):
            obj = f[name]
            yield from attrs(name, obj)
            if isinstance(obj, h5py.Dataset):
                data = obj[()]
                arr = np.asarray(data)
                if arr.dtype.kind in "OSU" or arr.dtype.names is not None:
                    yield f"{prefix}{name}", _mask(repr(arr.tolist()), tmp)
                else:
                    yield f"{prefix}{name}", arr


def _mat(path: Path, prefix: str, tmp: Path) -> Iterator[tuple[str, object]]:
    from scipy.io import loadmat

    def walk(name: str, v: object) -> Iterator[tuple[str, object]]:
        if isinstance(v, np.ndarray) and v.dtype.names is not None:
            for field in v.dtype.names:
                for k, item in enumerate(v[field].ravel()):
                    yield from walk(f"{name}.{field}[{k}]", item)
        elif isinstance(v, np.ndarray) and v.dtype.kind == "O":
            for k, item in enumerate(v.ravel()):
                yield from walk(f"{name}[{k}]", item)
        elif isinstance(v, np.ndarray) and v.dtype.kind in "SU":
            yield name, _mask(json.dumps([str(x) for x in v.ravel()]), tmp)
        elif isinstance(v, str):
            yield name, _mask(v, tmp)
        else:
            yield name, np.asarray(v)

    m = loadmat(path, squeeze_me=False)
    for key in sorted(k for k in m if not k.startswith("__")):
        yield from walk(f"{prefix}{key}", m[key])


def _c3d(path: Path, prefix: str, tmp: Path) -> Iterator[tuple[str, object]]:
    import ezc3d

    c = ezc3d.c3d(str(path))
    yield f"{prefix}points", np.asarray(c["data"]["points"])
    yield f"{prefix}analogs", np.asarray(c["data"]["analogs"])
    for group in sorted(c["parameters"]):
        if group == "header":
            continue
        for name in sorted(c["parameters"][group]):
            p = c["parameters"][group][name]
            if not isinstance(p, dict) or "value" not in p:
                continue
            v = p["value"]
            if isinstance(v, list):
                yield f"{prefix}{group}.{name}", _mask(json.dumps([str(x) for x in v]), tmp)
            else:
                arr = np.asarray(v)
                if arr.dtype.kind in "OSU":
                    yield f"{prefix}{group}.{name}", _mask(json.dumps(arr.tolist()), tmp)
                else:
                    yield f"{prefix}{group}.{name}", arr


def _pdf(path: Path, prefix: str, tmp: Path) -> Iterator[tuple[str, object]]:
    from pypdf import PdfReader

    pages = PdfReader(str(path)).pages
    yield f"{prefix}pages", np.asarray(len(pages))
    for k, page in enumerate(pages):
        yield f"{prefix}page{k}", _mask(page.extract_text(), tmp)


def _files(out: Path, prefix: str, tmp: Path) -> Iterator[tuple[str, object]]:
    """Every file an export wrote (a file, its side files, or a folder), by its kind."""
    readers: dict[str, Callable[[Path, str, Path], Iterator[tuple[str, object]]]] = {
        ".h5": _h5, ".mat": _mat, ".c3d": _c3d, ".pdf": _pdf,
    }  # fmt: skip
    if out.is_dir():
        paths = sorted(p for p in out.rglob("*") if p.is_file())
    else:  # the file and its side files (FILE.meta.json; a two-leg export's per-leg files)
        stem = out.name.split(".")[0]
        paths = sorted(p for p in out.parent.iterdir()
                       if p.is_file() and p.name.split(".")[0] == stem)  # fmt: skip
    yield f"{prefix}files", _mask(json.dumps([str(p.relative_to(tmp)) for p in paths]), tmp)
    for p in paths:
        key = f"{prefix}{p.relative_to(tmp)}:"
        reader = readers.get(p.suffix)
        if reader is not None:
            yield from reader(p, key, tmp)
        else:
            yield key, _mask(p.read_text(encoding="utf-8", errors="replace"), tmp)


def _copy_fixture(name: str, tmp: Path) -> Path:
    src = DATA / f"{name}.h5"
    dst = tmp / src.name
    shutil.copyfile(src, dst)
    for side in DATA.glob(f"{name}.h5.*"):
        shutil.copyfile(side, tmp / side.name)
    return dst


def collect(tmp: Path) -> dict[str, object]:
    """Every output of the user's commands on both fixtures, read back (see the module doc)."""
    out: dict[str, object] = {}
    for name in FIXTURES:
        work = tmp / name
        work.mkdir()
        src = _copy_fixture(name, work)
        out[f"{name}/info"] = _mask(_cli(["info", str(src)]), tmp)
        jobs: list[tuple[str, list[str], Path]] = [
            ("process", ["process", str(src), "-o", str(work / "p.h5"), "-q"], work / "p.h5"),
            ("report", ["report", str(src), "-o", str(work / "r.pdf"), "-q"], work / "r.pdf"),
        ]
        for fmt, ext in (("csv", ".csv"), ("mat", ".mat"), ("c3d", ".c3d"),
                         ("strides", ".strides.csv"), ("bids", "")):  # fmt: skip
            target = work / f"e_{fmt}{ext}"
            jobs.append((f"export-{fmt}",
                         ["export", str(src), "--format", fmt, "-o", str(target), "-q"],
                         target))  # fmt: skip
        for label, argv, target in jobs:
            _cli(argv)
            for key, value in _files(target, f"{name}/{label}/", tmp):
                out[key] = value
    return out


def _tokens(text: str) -> list[str]:
    return [t for t in _SPLIT.split(text) if t]


def _same_number(a: str, b: str) -> bool:
    x, y = float(a), float(b)
    if math.isnan(x) and math.isnan(y):
        return True
    # printed numbers: the last printed digit may round the other way after a last-bit change
    digits = len(a.split(".")[1].rstrip("eE0123456789+-") or a.split(".")[1]) if "." in a else 0
    return abs(x - y) <= max(1e-7 * max(abs(x), abs(y)), 1.01 * 10.0**-digits)


def differences(expected: dict[str, object], got: dict[str, object]) -> list[str]:
    """What differs, one line each (empty when a user would see the same)."""
    problems = []
    for key in sorted(set(expected) | set(got)):
        if key not in got:
            problems.append(f"{key}: missing now")
            continue
        if key not in expected:
            problems.append(f"{key}: new output")
            continue
        e, g = expected[key], got[key]
        if isinstance(e, str) or isinstance(g, str):
            if not (isinstance(e, str) and isinstance(g, str)):
                problems.append(f"{key}: text against numbers")
                continue
            te, tg = _tokens(e), _tokens(g)
            if len(te) != len(tg):
                problems.append(f"{key}: {len(tg)} tokens, expected {len(te)}")
                continue
            for k, (a, b) in enumerate(zip(te, tg, strict=True)):
                if a == b:
                    continue
                if _NUMBER.match(a) and _NUMBER.match(b) and _same_number(a, b):
                    continue
                problems.append(f"{key}: token {k} is {b!r}, expected {a!r}")
                break
            continue
        ea, ga = np.asarray(e), np.asarray(g)
        if ea.shape != ga.shape:
            problems.append(f"{key}: shape {ga.shape}, expected {ea.shape}")
        elif ea.dtype.kind in "iub" and ga.dtype.kind in "iub":
            bad = np.abs(ea.astype(np.int64) - ga.astype(np.int64)) > 1
            if bad.any():
                problems.append(f"{key}: {int(bad.sum())} values differ by more than 1")
        elif not np.allclose(ea.astype(float), ga.astype(float), rtol=1e-7, atol=1e-9,
                             equal_nan=True):  # fmt: skip
            problems.append(f"{key}: values differ (max |diff| "
                            f"{np.nanmax(np.abs(ea.astype(float) - ga.astype(float))):.3g})")
    return problems


def save(values: dict[str, object], path: Path = EXPECTED) -> None:
    arrays = {k: (np.asarray(v, dtype=np.str_) if isinstance(v, str) else np.asarray(v))
              for k, v in values.items()}  # fmt: skip
    np.savez_compressed(path, **arrays)  # type: ignore[arg-type]


def load(path: Path = EXPECTED) -> dict[str, object]:
    with np.load(path, allow_pickle=False) as z:
        return {k: (str(z[k]) if z[k].dtype.kind == "U" else z[k]) for k in z.files}


if __name__ == "__main__":  # python tests/golden.py: rewrite the expected outputs
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        values = collect(Path(d))
    save(values)
    print(f"wrote {len(values)} outputs to {EXPECTED}", file=sys.stderr)
