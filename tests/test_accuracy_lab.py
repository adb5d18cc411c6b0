"""``gaitmon lab accuracy``: the table of every tilt method against the simulator's truth (and the
shared recordings when present)."""

import numpy as np

from gaitmon.cli import main
from gaitmon.lab.accuracy import STRIDE_SCENARIOS, evaluate, format_table, labels


def test_quick_evaluation_ranks_the_methods_and_meets_the_event_goals():
    acc = evaluate(quick=True)
    paper, live, off = (acc.mean_joint(m) for m in ("paper", "live", "offline"))
    assert np.all(live < paper) and np.all(off <= live + 0.2)
    assert np.all(live <= 3.0)
    e = acc.hs_err_ms["gyro"]
    assert np.median(e) <= 20 and np.percentile(e, 95) <= 40
    assert all(v <= 5 for v in acc.fault_strides.values())
    table = format_table(acc)
    assert all(label in table for label in labels().values())
    # stride length and speed against the simulator's true strides, live and offline
    assert set(acc.stride_err_pct) == set(STRIDE_SCENARIOS)
    for per in acc.stride_err_pct.values():
        for kind in ("length", "speed"):
            for mode in ("live", "offline"):
                e = per[kind][mode]
                assert len(e) >= 25 and np.isfinite(e).mean() > 0.95
                assert np.nanmedian(e) <= 3.0
    assert "simulator stride length |error|" in table and "gait speed" in table


def test_command_prints_the_table_and_writes_it(tmp_path, capsys, shared_data):
    args = ["lab", "accuracy", "--quick", "--data", str(shared_data), "-o", str(tmp_path)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "Kalman (paper, seed 000)" in out and "BROAD" in out and "strides until flagged" in out
    assert "stride length |error|" in out
    assert "gait-aware" in (tmp_path / "accuracy.md").read_text()


def test_command_refuses_a_folder_without_recordings(tmp_path, capsys):
    assert main(["lab", "accuracy", "--quick", "--data", str(tmp_path)]) == 2
    assert "broad" in capsys.readouterr().err
