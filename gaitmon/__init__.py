"""gaitmon: live monitor, recorder and reviewer for a wearable lower-limb gait-measurement unit."""

# The one place the version is written (pyproject.toml reads it): a constant, so every command
# knows it without the ~0.1 s that importlib.metadata costs at start-up.
__version__ = "0.1.0"
