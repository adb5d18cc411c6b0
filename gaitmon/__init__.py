"""gaitmon: live monitor, recorder and reviewer for a wearable lower-limb gait-measurement unit."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("gaitmon")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"
