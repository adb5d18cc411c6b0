"""The live benchmark's bookkeeping (no timing is asserted): each sample is drawn at the end of
the first paint whose newest sample is at or after it, whatever order the paints' newest
samples come in, and a sample no paint showed counts as drawn at the end of the run."""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))


def test_every_sample_is_drawn_at_the_first_paint_that_shows_it(qapp):
    from bench_gui import drawn_at

    # (newest engine index shown, paint end); the 3rd paint showed nothing new (NaN: no sample
    # in its window), the 4th an older newest sample than the 2nd (it cannot hide 5..7)
    log = [(2.0, 10.0), (7.0, 20.0), (np.nan, 25.0), (6.0, 30.0), (9.0, 40.0)]
    idx = np.arange(12)
    got = drawn_at(idx, log, end_s=99.0)
    # by hand: 0-2 at 10, 3-7 at 20, 8-9 at 40, 10-11 never drawn -> the end
    np.testing.assert_array_equal(got, [10, 10, 10, 20, 20, 20, 20, 20, 40, 40, 99, 99])
    # a NaN first paint (before any sample) does not hide what later paints show
    got = drawn_at(np.arange(3), [(np.nan, 5.0), (1.0, 8.0), (2.0, 9.0)], end_s=99.0)
    np.testing.assert_array_equal(got, [8, 8, 9])
    assert np.all(drawn_at(idx, [], end_s=7.0) == 7.0)


def test_frames_written_before_the_engines_first_sample_are_not_its_samples(qapp):
    """Frames written every 10 ms; the engine's sample 0 is the 4th frame written (3 dropped
    while connecting), each read 2 ms after it was written: the shift is 3, so every sample
    is timed from its own frame (2 ms), not from one written 30 ms earlier."""
    from bench_gui import frames_before

    written = np.arange(20) * 0.010
    eng_idx = np.arange(10, dtype=float)
    host = written[3:13] + 0.002
    assert frames_before(written, eng_idx, host) == 3
    assert frames_before(written, eng_idx, written[:10] + 0.002) == 0  # none dropped
