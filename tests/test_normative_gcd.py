"""GCD normal data: files laid out as published GCD files are (tests/data/gcd, see its README),
the errors for bad ones, and the deviation from a band against hand-computed values."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from gaitmon.normative import (
    N_POINTS,
    NormativeBands,
    NormativeError,
    deviation_deg,
    load,
    load_normative,
)

DATA = Path(__file__).resolve().parent / "data" / "gcd"
VICON = DATA / "vicon_style_normal.gcd"
SIDES = DATA / "sides_sd_sections_101.gcd"


def test_vicon_style_two_columns_51_points_resampled_to_101() -> None:
    b = load(VICON)
    assert b.joints == ("hip", "knee", "ankle")
    # the file's 51 points are every 2 %: they land on the even points unchanged
    k = np.arange(51)
    np.testing.assert_allclose(b.mean_deg[::2, 0], 30.0 - k)
    np.testing.assert_allclose(b.mean_deg[::2, 1], 2.0 * k)
    np.testing.assert_allclose(b.sd_deg[::2, 1], 1.0 + k / 50)
    # odd points halfway between: knee 2k at point 2k, so point 2k+1 is 2k+1
    np.testing.assert_allclose(b.mean_deg[1::2, 1], 2.0 * k[:-1] + 1.0)
    np.testing.assert_allclose(b.mean_deg[:, 1], np.arange(N_POINTS, dtype=float))
    np.testing.assert_allclose(b.mean_deg[:, 2], 5.0)
    np.testing.assert_allclose(b.sd_deg[:, 2], 2.5)
    np.testing.assert_allclose(b.sd_deg[:, 0], 4.0)
    # PelvicTilt, HipPower and the scalars are not joints: skipped, not mistaken for one
    assert "Oxford Metrics" in b.source and "51 points" in b.source and "resampled" in b.source
    assert "not stated" in b.licence
    assert b.label == "vicon_style_normal (GCD)"
    assert b.path == VICON


def test_load_normative_is_the_same_entry_point_and_picks_by_content(tmp_path: Path) -> None:
    # a GCD saved with another extension is still recognised by its '#!DST' / '!Name' lines
    other = tmp_path / "normals.txt"
    other.write_bytes(VICON.read_bytes())
    a, b = load_normative(VICON), load(other)
    np.testing.assert_array_equal(a.mean_deg, b.mean_deg)


def test_side_prefixed_curves_with_sd_sections_101_points() -> None:
    left = load(SIDES, side="left")
    right = load(SIDES, side="Right")
    assert left.joints == right.joints == ("knee",)
    np.testing.assert_allclose(left.mean_deg[:, 1], np.arange(N_POINTS) % 50)
    np.testing.assert_allclose(left.sd_deg[:, 1], 2.0)
    np.testing.assert_allclose(right.mean_deg[:, 1], 100.0 - np.arange(N_POINTS))
    np.testing.assert_allclose(right.sd_deg[:, 1], 3.0)
    assert "101 points" in left.source and "resampled" not in left.source
    # no side asked for: both present, so Left, and the source says so
    default = load(SIDES)
    np.testing.assert_array_equal(default.mean_deg, left.mean_deg)
    assert "Left ones are used" in default.source


def test_latin1_and_unprefixed_single_column(tmp_path: Path) -> None:
    values = "\n".join(f"{v}" for v in range(51))
    sd = "\n".join("1.5" for _ in range(51))
    text = f"#!DST-0.1 GCD Labor für Ganganalyse\n!HipFlexExt\n{values}\n!HipFlexExtSD\n{sd}\n"
    p = tmp_path / "labor.gcd"
    p.write_bytes(text.encode("latin-1"))
    b = load(p)
    assert b.joints == ("hip",)
    np.testing.assert_allclose(b.mean_deg[:, 0], np.arange(N_POINTS) / 2)
    np.testing.assert_allclose(b.sd_deg[:, 0], 1.5)


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "bad.gcd"
    p.write_text(text, encoding="utf-8")
    return p


def _pairs(n: int, mean: str = "1.0", sd: str = "0.5") -> str:
    return "\n".join(f"{mean} {sd}" for _ in range(n))


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        # 50 lines: neither 51 nor 101 points
        (f"!KneeFlexExt 3\n{_pairs(50)}\n", "KneeFlexExt (line 1) has 50 data lines"),
        # a word in the numbers: line 4 named
        (f"!KneeFlexExt 3\n1 2\n3 4\nabc 5\n{_pairs(48)}\n", "line 4 (variable KneeFlexExt)"),
        # one curve and no SD for it
        ("!KneeFlexExt\n" + "\n".join("1" for _ in range(51)) + "\n", "has no SD"),
        # the same variable twice
        (f"!KneeFlexExt\n{_pairs(51)}\n!KneeFlexExt\n{_pairs(51)}\n", "appears twice"),
        # only variables gaitmon cannot use
        (f"!PelvicTilt 3\n{_pairs(51)}\n", "no hip, knee or ankle flexion variable"),
        # a negative SD
        (f"!DorsiPlanFlex 3\n{_pairs(50)}\n1.0 -0.2\n", "SD -0.2 at point 51 is negative"),
        # numbers before any variable
        ("#!DST-0.1 GCD x\n1.0 2.0\n", "line 2: '1.0 2.0' before any '!Name'"),
        # three numbers per line
        ("!KneeFlexExt\n" + "\n".join("1 2 3" for _ in range(51)) + "\n", "3 numbers"),
        # an SD section of the wrong length
        ("!KneeFlexExt\n" + "\n".join("1" for _ in range(51)) + "\n!KneeFlexExt_SD\n"
         + "\n".join("1" for _ in range(101)) + "\n", "KneeFlexExt_SD (line 53) must have"),
    ],
)  # fmt: skip
def test_bad_gcd_files_give_one_line_errors(tmp_path: Path, text: str, expected: str) -> None:
    with pytest.raises(NormativeError) as e:
        load(_write(tmp_path, text))
    msg = str(e.value)
    assert expected in msg, msg
    assert "\n" not in msg and "bad.gcd" in msg


def test_wrong_side_names_what_the_file_has(tmp_path: Path) -> None:
    p = _write(tmp_path, f"!LeftKneeFlexExt 3\n{_pairs(51)}\n")
    assert load(p, side="left").has("knee")
    with pytest.raises(NormativeError, match="for the right side; the file has left"):
        load(p, side="right")


def _band(mean: np.ndarray) -> NormativeBands:
    return NormativeBands(np.arange(N_POINTS, dtype=float), mean, np.ones_like(mean),
                          {"source": "t", "licence": "t"})  # fmt: skip


def test_deviation_is_rms_over_the_cycle_hand_computed() -> None:
    k = np.arange(N_POINTS)
    ref = np.stack([20 * np.cos(2 * np.pi * k / 100), 30 + 0 * k, np.full(N_POINTS, np.nan)], 1)
    band = _band(ref)
    patient = ref.copy()
    patient[:, 0] += 3.0  # hip: a constant 3 deg offset -> RMS 3
    # knee: 4 sin(2 pi k / 100); sum over k = 0..100 of sin^2 is 50 (k = 0 and 100 are 0),
    # so RMS = 4 sqrt(50 / 101)
    patient[:, 1] += 4.0 * np.sin(2 * np.pi * k / 100)
    patient[:, 2] = 0.0  # ankle: the band has none
    d = deviation_deg(patient, band)
    assert d[0] == pytest.approx(3.0, abs=1e-12)
    assert d[1] == pytest.approx(4.0 * math.sqrt(50 / 101), abs=1e-12)
    assert math.isnan(d[2])
    # a patient mean with no strides (NaN) gives NaN, not a number
    assert np.isnan(deviation_deg(np.full((N_POINTS, 3), np.nan), band)).all()
    with pytest.raises(ValueError, match="shape"):
        deviation_deg(np.zeros((51, 3)), band)
