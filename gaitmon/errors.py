"""Exceptions shared by every layer: the user's problems and cancelled work."""


class UserError(Exception):
    """A problem the user can fix; printed as one line, never as a traceback."""


class Cancelled(Exception):
    """The work was cancelled by the user; nothing half-done was kept."""


# What analysing a damaged file's contents can raise past the reader's checks (numpy on odd
# shapes, h5py on a bad chunk). TypeError, AttributeError, NameError are left out: they are
# programming errors, and stay tracebacks.
DAMAGE_ERRORS: tuple[type[BaseException], ...] = (
    ValueError, IndexError, KeyError, OSError, RuntimeError, ZeroDivisionError,
    FloatingPointError, OverflowError,
)  # fmt: skip
