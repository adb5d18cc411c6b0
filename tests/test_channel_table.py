"""The channel table (gaitmon.dsp.channel_table) is the one source of the unit's shape: today's
numbers come out of it unchanged, everything sized by it agrees with it, and the protocol's
layout imports it without numpy."""

import subprocess
import sys

import numpy as np

from gaitmon.dsp import channel_table as T
from gaitmon.dsp.angles import joint_angles
from gaitmon.io import protocol as P
from gaitmon.io.journal import ROW_DTYPES, RecordType
from gaitmon.io.session.layout import _PER_SAMPLE, ANGLE_CONVENTION, per_sample_datasets


def test_todays_unit_four_segments_three_joints_fourteen_channels_in_the_documented_order():
    assert T.SEGMENTS == ("body", "thigh", "shank", "foot")
    assert T.JOINTS == ("hip", "knee", "ankle")
    assert (T.N_SEGMENTS, T.N_JOINTS, T.N_CHANNELS) == (4, 3, 14)
    segments = ("body", "thigh", "shank", "foot")
    names = [f"{s}_{k}" for s in segments for k in ("acc_x", "acc_z", "gyro")]
    assert (*names, "heel_fsr", "toe_fsr") == T.CHANNEL_NAMES
    assert [c.index for c in T.CHANNELS] == list(range(14))


def test_joint_pairs_give_the_clinical_signs():
    # hip flexion + = thigh - body; knee flexion + = thigh - shank;
    # ankle dorsiflexion + = foot - shank
    assert T.JOINT_PAIRS == ((1, 0), (1, 2), (3, 2))
    body, thigh, shank, foot = 0.05, 0.40, 0.10, 0.25
    hip, knee, ankle = joint_angles(np.array([[body, thigh, shank, foot]]))[0]
    assert np.allclose([hip, knee, ankle], [thigh - body, thigh - shank, foot - shank])
    assert ANGLE_CONVENTION == (
        "Segment tilts are sagittal, positive counter-clockwise seen from the subject's right "
        "side, zero in the upright standing calibration pose. Hip flexion + = thigh - body; "
        "knee flexion + = thigh - shank; ankle dorsiflexion + = foot - shank; every difference "
        "wrapped to (-180, 180] degrees."
    )


def test_wire_journal_and_file_are_sized_by_the_table():
    assert P.PAYLOAD_LEN[P.FrameKind.RAW] == 2 * T.N_CHANNELS == 28
    assert P.PAYLOAD_LEN[P.FrameKind.TILT] == 4 * T.N_SEGMENTS == 16
    assert P.PAYLOAD_LEN[P.FrameKind.JOINT] == 4 * T.N_JOINTS + 2 == 14
    assert ROW_DTYPES[RecordType.RAW]["adc"].shape == (T.N_CHANNELS,)
    assert ROW_DTYPES[RecordType.TILT]["kalman_tilt_deg"].shape == (T.N_SEGMENTS,)
    assert ROW_DTYPES[RecordType.JOINT]["kalman_joint_deg"].shape == (T.N_JOINTS,)
    assert "raw/adc" in per_sample_datasets("raw")
    assert _PER_SAMPLE["raw/adc"][0] == (14,)
    assert _PER_SAMPLE["processed/acc_ms2"][0] == (4, 2)
    assert _PER_SAMPLE["processed/joint_deg"][0] == (3,)
    # the unit's fingerprint of its table, as docs/protocol.md gives it
    assert P.channel_table_crc() == P.DEFAULT_TABLE_CRC == 0xA6E7


def test_the_table_and_the_wire_layout_import_without_numpy():
    code = (
        "import sys\n"
        "import gaitmon.dsp.channel_table, gaitmon.io.wire\n"
        "from gaitmon.io.wire import PAYLOAD_LEN, FrameKind\n"
        "print('numpy' in sys.modules, PAYLOAD_LEN[FrameKind.RAW])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "28"]
