"""Normative band files: round trip, the shipped example, and every error the loader reports."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gaitmon.normative import (
    EXAMPLE_PREAMBLE,
    N_POINTS,
    NormativeBands,
    NormativeError,
    format_normative,
    load_normative,
    parse_normative,
    simulated_example,
    write_normative,
)

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "normative-example.csv"
META = {"source": "test values", "licence": "CC0"}
HEADER = "cycle_pct,hip_mean_deg,hip_sd_deg,knee_mean_deg,knee_sd_deg,ankle_mean_deg,ankle_sd_deg"


def _text(
    rows: int = N_POINTS,
    header: str = HEADER,
    meta: str | None = None,
    cell: tuple[int, int, str] | None = None,
) -> str:
    lines = [meta if meta is not None else "# source: test values\n# licence: CC0", header]
    n_cols = len(header.split(","))
    for r in range(rows):
        # odd columns are means (any sign), even columns SDs (>= 0)
        cells = [str(r)] + [
            f"{(r + c) % 17 - 5}.25" if c % 2 else f"{(r + c) % 5}.5" for c in range(1, n_cols)
        ]
        if cell is not None and cell[0] == r:
            cells[cell[1]] = cell[2]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def test_round_trip(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    mean = rng.uniform(-30, 70, (N_POINTS, 3))
    sd = rng.uniform(0, 8, (N_POINTS, 3))
    bands = NormativeBands(
        np.arange(N_POINTS, dtype=float), mean, sd, {**META, "name": "round trip"}
    )
    p = write_normative(bands, tmp_path / "n.csv", decimals=4)
    back = load_normative(p)
    np.testing.assert_allclose(back.mean_deg, mean, atol=0.5e-4 + 1e-12)
    np.testing.assert_allclose(back.sd_deg, sd, atol=0.5e-4 + 1e-12)
    np.testing.assert_array_equal(back.cycle_pct, np.arange(101))
    assert back.source == "test values" and back.licence == "CC0" and back.label == "round trip"
    assert back.joints == ("hip", "knee", "ankle") and back.path == p


def test_hand_written_file_with_one_joint_and_extra_columns(tmp_path: Path) -> None:
    lines = [
        "\ufeff# name: knee only",
        "# source: my lab",
        "# licence: internal",
        "# licence: (second line)",
        "# a free comment",
        "",
        "knee_sd_deg,comment,cycle_pct,knee_mean_deg",
    ]
    lines += [f"2.5,x,{r},{r / 10:.1f}" for r in range(N_POINTS)]
    p = tmp_path / "k.csv"
    p.write_text("\n".join(lines), encoding="utf-8")
    b = load_normative(p)
    assert b.joints == ("knee",)
    assert b.has("knee") and not b.has("hip")
    assert np.all(np.isnan(b.mean_deg[:, 0])) and np.all(np.isnan(b.mean_deg[:, 2]))
    np.testing.assert_allclose(b.mean_deg[:, 1], np.arange(N_POINTS) / 10)
    np.testing.assert_allclose(b.sd_deg[:, 1], 2.5)
    assert b.licence == "internal (second line)" and b.label == "knee only"
    # writing it back keeps only the knee columns
    assert "hip" not in format_normative(b).splitlines()[-N_POINTS - 1]


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        (_text(header="cycle_pct,hip_mean_deg"), "no matching 'hip_sd_deg'"),
        (_text(header="cycle_pct,comment"), "missing columns"),
        (_text(header="hip_mean_deg,hip_sd_deg"), "missing column 'cycle_pct'"),
        (_text(header="cycle_pct,knee_mean_deg,knee_sd_deg,knee_sd_deg"), "appears twice"),
        (_text(rows=100), "wrong length: 100 data rows, expected 101"),
        (_text(rows=102), "wrong length: 102"),
        # 2 metadata lines + the header, so data row 7 is line 11
        (_text(cell=(7, 3, "abc")), "line 11, column knee_mean_deg: 'abc' is not a number"),
        (_text(cell=(7, 3, "nan")), "not finite"),
        (_text(cell=(9, 4, "-1")), "negative"),
        (_text(cell=(5, 0, "6")), "cycle_pct is 6, expected 5"),
        (_text(cell=(5, 2, "1,2")), "has 8 values"),
        (_text(meta="# licence: CC0"), "'# source: ...'"),
        (_text(meta="# source: x"), "'# licence: ...'"),
        ("# source: x\n# licence: y\n", "no header row"),
    ],
)
def test_errors_name_the_problem(text: str, needle: str) -> None:
    with pytest.raises(NormativeError) as err:
        parse_normative(text, "n.csv")
    msg = str(err.value)
    assert needle in msg and "\n" not in msg


def test_file_errors(tmp_path: Path) -> None:
    with pytest.raises(NormativeError, match="does not exist"):
        load_normative(tmp_path / "missing.csv")
    p = tmp_path / "latin1.csv"
    p.write_bytes(_text().replace("test values", "caf\u00e9").encode("latin-1"))
    with pytest.raises(NormativeError, match="not UTF-8"):
        load_normative(p)


def test_shipped_example_is_labelled_and_is_what_the_simulator_gives() -> None:
    text = EXAMPLE.read_text(encoding="utf-8")
    first = text.splitlines()[0]
    assert "EXAMPLE" in first and "NOT NORMATIVE" in first
    b = load_normative(EXAMPLE)
    assert "simulat" in b.source and "not normative" in b.label.lower()
    assert all(line.lstrip("# ") in text for line in EXAMPLE_PREAMBLE)
    # regenerating it gives the same numbers (to the 2 decimals written)
    again = simulated_example()
    np.testing.assert_allclose(b.mean_deg, again.mean_deg, atol=0.0051)
    np.testing.assert_allclose(b.sd_deg, again.sd_deg, atol=0.0051)
    # the simulator's curves follow its documented key points (gaitmon.io.sim.kinematics):
    # hip 30 deg at heel strike, knee ~64 deg peak in swing, ankle ~-17 deg after toe off
    assert b.mean_deg[0, 0] == pytest.approx(30, abs=1.5)
    assert b.mean_deg[:, 1].max() == pytest.approx(64, abs=4)
    assert b.mean_deg[55:75, 2].min() == pytest.approx(-17, abs=4)
    # subjects differ (cadence, stance, knee amplitude): a real band, widest in swing
    assert b.sd_deg[:, 1].max() > 2 and np.argmax(b.sd_deg[:, 1]) > 55
