"""Nothing a user sees changes when the house is reshaped (issue 23).

Two recorded fixtures (one leg with frame loss, notes and a stored exclusion; both legs, a
hemiparetic walk) go through the user's commands: ``info``, ``process``, ``export`` in every
format and ``report``. Every output, read back with libraries that are not gaitmon's, must
equal what the code gave before the reshaping (``tests/golden.py`` says how it is compared and
how the expected values were made).
"""

from __future__ import annotations

from pathlib import Path

import golden
import numpy as np
import pytest


@pytest.fixture(scope="module")
def outputs(tmp_path_factory: pytest.TempPathFactory, qapp: object) -> dict[str, object]:
    # qapp: ``gaitmon report`` would otherwise make a bare QGuiApplication for the rest of
    # the run, which the widget tests after this one cannot use
    return golden.collect(tmp_path_factory.mktemp("golden"))


def test_every_output_of_both_fixtures_is_what_it_was(outputs: dict[str, object]) -> None:
    expected = golden.load()
    assert len(expected) > 1000  # every format of both fixtures, not an empty reference
    problems = golden.differences(expected, outputs)
    assert problems == [], "\n".join(problems[:40])


def test_the_comparison_sees_a_changed_number_a_changed_word_and_a_missing_file() -> None:
    expected = golden.load()
    text_key = "one_leg/info"
    array_key = next(
        k for k, v in expected.items()
        if isinstance(v, np.ndarray) and v.dtype.kind == "f" and v.size > 100
    )  # fmt: skip
    changed = dict(expected)
    changed[text_key] = str(expected[text_key]).replace("side left", "side right")
    arr = np.array(expected[array_key], dtype=float)
    arr.flat[50] += 1e-3 * max(1.0, abs(float(arr.flat[50])))
    changed[array_key] = arr
    del changed[next(iter(k for k in expected if k.startswith("two_legs/report")))]
    problems = golden.differences(expected, changed)
    assert any(p.startswith(text_key) for p in problems)
    assert any(p.startswith(array_key) for p in problems)
    assert any("missing now" in p for p in problems)
    # and a number printed with one decimal that only rounds the other way is the same
    assert golden.differences({"x": "stride 1.25 s"}, {"x": "stride 1.26 s"}) == []
    assert golden.differences({"x": "stride 1.25 s"}, {"x": "stride 1.35 s"}) != []


def test_the_fixtures_are_the_kept_recordings() -> None:
    names = sorted(p.name for p in Path(golden.DATA).iterdir())
    assert names == ["expected.npz", "one_leg.h5", "one_leg.h5.review.json", "two_legs.h5"]
