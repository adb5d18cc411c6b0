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


def _output_advice() -> dict[int, str]:
    import errno

    advice = {
        errno.EROFS: "the drive is read-only{code}; save to a folder on a writable drive",
        errno.EACCES: "no permission to write there{code}; choose a folder you may write to, or "
                      "ask for write access",
        errno.EPERM: "no permission to write there{code}; choose a folder you may write to, or "
                     "ask for write access",
        errno.ENOSPC: "the disk is full{code}; free some space or save to another drive",
        errno.ENAMETOOLONG: "the name is too long{code}; choose a shorter output name or folder",
        errno.EISDIR: "a folder has that name{code}; choose another output name",
        errno.ENOENT: "its folder does not exist{code}; choose an existing folder",
    }  # fmt: skip
    if hasattr(errno, "EDQUOT"):  # not on Windows
        advice[errno.EDQUOT] = "the disk quota is used up{code}; free some space or save elsewhere"
    return advice


def output_error_text(exc: OSError, path: object) -> str:
    """One line for an OSError met while WRITING ``path`` (an output: a report, an export):
    the output's path, what went wrong and what to do. Never a word of the input's damage:
    a read-only drive, a full disk or a missing permission is the output's problem."""
    code = f" (errno {exc.errno})" if exc.errno else ""
    advice = _output_advice().get(exc.errno or 0)
    if advice is None:
        what = exc.strerror or " ".join(str(exc).split())[:160] or type(exc).__name__
        return f"cannot write {path}: {what}{code}; choose another folder or name"
    return f"cannot write {path}: {advice.format(code=code)}"


def is_output_error(exc: BaseException, input_path: object) -> bool:
    """Whether ``exc`` is a problem of writing somewhere, not of reading ``input_path``: an
    error only writing gives (read-only drive, full disk, quota, too long a name), or a
    missing permission on another file than the input."""
    import errno
    import os

    if not isinstance(exc, OSError) or not exc.errno:
        return False
    if exc.errno in (errno.EROFS, errno.ENOSPC, errno.ENAMETOOLONG,
                     getattr(errno, "EDQUOT", errno.ENOSPC)):  # fmt: skip
        return True
    name = exc.filename
    if exc.errno not in (errno.EACCES, errno.EPERM) or not isinstance(name, (str, bytes)):
        return False
    if not isinstance(input_path, (str, os.PathLike)):
        return False
    return os.path.abspath(os.fsdecode(name)) != os.path.abspath(os.fspath(input_path))
