"""``gaitmon compare``: the PDF of a normal and a stiff-knee session shows each session's own
figures and the knee changes marked beyond their minimal detectable change (shown beside
each); the page holds together (text inside the margins, no word over another, the overlaid
curves in each session's colour); bad inputs are one-line errors."""

import re
import shutil
import subprocess

import numpy as np
import pytest
from conftest import write_simulated_session

from gaitmon.analysis import analyse_session
from gaitmon.cli import main
from gaitmon.finish import open_session

MM = 72 / 25.4


def _tool(name):
    if not shutil.which(name):
        pytest.skip(f"{name} (poppler-utils) is not installed")


def _text(pdf, *opts):
    return subprocess.run(["pdftotext", *opts, str(pdf), "-"], capture_output=True, text=True,
                          check=True).stdout  # fmt: skip


def _words(pdf):
    html = _text(pdf, "-bbox-layout")
    out = []
    for k, page in enumerate(re.split(r"<page ", html)[1:]):
        for m in re.finditer(r'<word xMin="([\d.]+)" yMin="([\d.]+)" xMax="([\d.]+)" '
                             r'yMax="([\d.]+)">([^<]*)</word>', page):  # fmt: skip
            out.append((k, *(float(v) for v in m.groups()[:4]), m.group(5)))
    return out


def _knee_peak(path):
    with open_session(path) as s:
        inc = [r for r in analyse_session(s).rows if r.included]
    v = np.array([r.knee_peak_swing_deg for r in inc])
    return v.mean(), v.std(ddof=1), len(v)


def _minus(x):
    return x.replace("-", "−")


def test_compare_pdf_normal_then_stiff_knee(qapp, normal_and_stiff_knee, tmp_path, capsys):
    _tool("pdftotext")
    normal, stiff = normal_and_stiff_knee
    out = tmp_path / "compare.pdf"
    assert main(["compare", str(stiff), str(normal), "-o", str(out)]) == 0
    said = capsys.readouterr()
    assert "wrote" in said.out and "P001" in said.out and said.err == ""
    text = _text(out, "-layout")
    assert "Gait comparison across sessions" in text and "P001" in text
    # oldest first, whatever the order given
    assert text.index("visit1_normal.h5") < text.index("visit2_stiff.h5")
    assert "2026-10-01 09:00 UTC" in text and "2026-11-01 09:30 UTC" in text
    (m1, s1, n1), (m2, s2, n2) = _knee_peak(normal), _knee_peak(stiff)
    # MDC95 by hand from the per-stride values: 1.96 · √2 · pooled SD
    mdc = 1.96 * np.sqrt(2) * np.sqrt(((n1 - 1) * s1**2 + (n2 - 1) * s2**2) / (n1 + n2 - 2))
    row = next(ln for ln in text.splitlines() if ln.strip().startswith("Peak knee flexion"))
    cells = re.split(r"\s{2,}", row.strip())
    # each session's own figures, the change with its MDC beside it, marked beyond it
    assert cells[1] == _minus(f"{m1:.1f} ± {s1:.1f}")
    assert cells[2] == _minus(f"{m2:.1f} ± {s2:.1f}")
    assert cells[3] == _minus(f"{m2 - m1:.1f} (MDC {mdc:.1f}) *") and m2 - m1 < -15
    knee_rom = next(ln for ln in text.splitlines() if ln.strip().startswith("ROM knee"))
    assert knee_rom.rstrip().endswith("*")
    for unchanged in ("Stride time (s)", "ROM hip"):
        line = next(ln for ln in text.splitlines() if ln.strip().startswith(unchanged))
        assert not line.rstrip().endswith("*"), line
    flat = re.sub(r"\s+", "", text)
    assert "MDC95=1.96·√2·SEM" in flat and "pooledstride-to-strideSD" in flat
    assert "nottest-retestreliabilitybetweendays" in flat
    # each session's gaps and excluded strides (these two: no outage, the first and last)
    assert flat.count("nolinkoutage;2stridesexcluded(firststride1,laststride1)") == 2
    assert "page 1 of 1" in text

    # the page: the words inside the margins and none over another
    words = _words(out)
    footer_y = (297 - 12) * MM
    for _page, x0, y0, x1, y1, word in words:
        assert x0 >= 10 * MM and x1 <= 200 * MM, (word, x0, x1)
        assert y1 <= footer_y or y0 >= footer_y, (word, y0, y1)
    b = np.array([w[1:5] for w in words])
    ix = np.minimum(b[:, None, 2], b[None, :, 2]) - np.maximum(b[:, None, 0], b[None, :, 0])
    iy = np.minimum(b[:, None, 3], b[None, :, 3]) - np.maximum(b[:, None, 1], b[None, :, 1])
    overlap = (ix > 0.5) & (iy > 0.5)
    np.fill_diagonal(overlap, False)
    names = [w[5] for w in words]
    assert not overlap.any(), [(names[i], names[j]) for i, j in np.argwhere(overlap)[:5]]

    if shutil.which("pdftoppm"):  # both sessions' curves drawn, each in its colour
        ppm = subprocess.run(["pdftoppm", "-r", "100", "-f", "1", "-l", "1", str(out)],
                             capture_output=True, check=True).stdout  # fmt: skip
        _magic, w, h, _maxval, data = ppm.split(maxsplit=4)
        px = np.frombuffer(data, np.uint8).reshape(int(h), int(w), 3).astype(int)
        plots = px[int(int(h) * 0.2) : int(int(h) * 0.55)]  # the band of the cycle plots
        blue = np.all(np.abs(plots - (0x1F, 0x5F, 0xD6)) < 50, axis=-1).sum()
        red = np.all(np.abs(plots - (0xD1, 0x40, 0x1F)) < 50, axis=-1).sum()
        assert blue > 200 and red > 200, (blue, red)


def test_many_sessions_continue_in_further_tables(qapp, normal_and_stiff_knee, tmp_path):
    _tool("pdftotext")
    files = list(normal_and_stiff_knee)
    for k, pattern in enumerate(("normal", "long-stance", "stiff-knee")):
        files.append(write_simulated_session(tmp_path / f"v{k + 3}.h5", pattern=pattern,
                                             seed=20 + k, n=1800,
                                             created_utc=f"2026-12-0{k + 1}T09:00:00Z"))
    out = tmp_path / "five.pdf"
    assert main(["compare", *map(str, files), "-o", str(out), "-q"]) == 0
    text = _text(out, "-layout")
    flat = re.sub(r"\s+", "", text)
    # every later session against the baseline, and from session 3 on against the previous
    for k in range(2, 6):
        assert f"Δ{k}−1" in flat
    for k in range(3, 6):
        assert f"Δ{k}−{k - 1}" in flat
    pages = int(re.search(r"page 1 of (\d+)", text).group(1))
    for page, x0, _y0, x1, _y1, word in _words(out):
        assert x0 >= 10 * MM and x1 <= 200 * MM, (page, word)
    # 4 later sessions, one a table (a change and its MDC need the width)
    assert text.count("Peak knee flexion in swing (deg)") == 4
    assert pages >= 1


def test_deidentified_comparison(qapp, normal_and_stiff_knee, tmp_path):
    _tool("pdftotext")
    out = tmp_path / "anon.pdf"
    assert main(["compare", *map(str, normal_and_stiff_knee), "-o", str(out), "--deidentify",
                 "-q"]) == 0  # fmt: skip
    text = _text(out, "-raw")
    assert "P001" not in text and ".h5" not in text and "2026-1" not in text.split("gaitmon")[0]
    assert "day 0" in text and "day 31" in text and "[removed]" in text


@pytest.mark.parametrize("case", ["one", "missing", "damaged", "truncated", "tilt", "not-pdf",
                                  "exists"])  # fmt: skip
def test_bad_inputs_one_line(case, normal_and_stiff_knee, tmp_path, capsys, record_simulated):
    normal, stiff = map(str, normal_and_stiff_knee)
    out = tmp_path / "c.pdf"
    args = [normal, stiff]
    if case == "one":
        args, words = [normal], "two or more sessions"
    elif case == "missing":
        args, words = [normal, str(tmp_path / "gone.h5")], "gone.h5 does not exist"
    elif case == "damaged":
        bad = tmp_path / "bad.h5"
        bad.write_bytes(b"\x89HDF\r\n\x1a\n" + b"\0" * 600)
        args, words = [normal, str(bad)], "bad.h5"
    elif case == "truncated":
        cut = tmp_path / "cut.h5"
        cut.write_bytes(normal_and_stiff_knee[1].read_bytes()[:50_000])
        args, words = [normal, str(cut)], "cut.h5 is damaged"
    elif case == "tilt":
        tilt = record_simulated(tmp_path / "tilt.h5", "--mode", "tilt", duration_s=5)
        args, words = [normal, str(tilt)], "tilt.h5: the unit's tilt mode sends no foot-sensor"
        capsys.readouterr()  # the recording's own line
    elif case == "not-pdf":
        out, words = tmp_path / "c.png", "name it .pdf"
    else:
        out.write_bytes(b"old")
        words = "exists; use --force"
    assert main(["compare", *args, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert words in err and err.count("\n") == 1 and "Traceback" not in err, err
    if case != "exists":
        assert not out.exists()
