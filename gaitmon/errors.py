"""Exceptions shared by every layer: the user's problems and cancelled work."""


class UserError(Exception):
    """A problem the user can fix; printed as one line, never as a traceback."""


class Cancelled(Exception):
    """The work was cancelled by the user; nothing half-done was kept."""
