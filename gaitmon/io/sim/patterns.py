"""The simulator's gait patterns and realism levels by name: plain constants, so the command
line lists them without importing the gait model (numpy, scipy)."""

# Pathological patterns: (stance fraction, swing knee-flexion scale)
PATTERNS: dict[str, tuple[float, float]] = {
    "normal": (0.60, 1.0),
    "stiff-knee": (0.60, 0.45),  # reduced swing knee flexion (e.g. rectus femoris spasticity)
    "long-stance": (0.70, 1.0),  # prolonged stance, short swing (e.g. antalgic / slow gait)
}

# How hard the simulator is (gaitmon.io.sim.config, docs/simulator.md "Realism levels"):
# "default" the kind simulator of the tests and golden outputs, "real" as hard as real feet.
REALISM_LEVELS = ("default", "real")
