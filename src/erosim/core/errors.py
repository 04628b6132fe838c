"""Errors users see: one clear sentence saying what is wrong and how to fix it.

The command line prints ``str(error)`` of any :class:`ErosimError` and exits non-zero without a
traceback (``--debug`` shows it).
"""


class ErosimError(Exception):
    """Base of every error meant for the user; the message names the problem and the fix."""

    exit_code = 2


class ConfigError(ErosimError):
    """A scenario file or ``--set`` override is malformed, unknown or out of range."""


class InputError(ErosimError):
    """An input file (DEM, hardness map, checkpoint) is missing, unreadable or inconsistent."""


class InstabilityError(ErosimError):
    """A run went unstable (NaN or exploding speed); what was written so far is kept."""

    exit_code = 3


class Interrupted(ErosimError):
    """The user pressed Ctrl-C; a checkpoint was written so the run can be resumed."""

    exit_code = 130


class BudgetError(ErosimError):
    """A model's increments do not conserve what they must (mass, volume): a bug, stopped at once."""

    exit_code = 3


def os_error_message(exc: OSError) -> str:
    """One sentence for an operating-system error (permission, read-only disk, full disk, a file in the
    way of a folder …): what happened to which path, and the fix."""
    import errno

    if exc.filename is None:  # no path to name (a library's own I/O error): its message, in one line
        text = " ".join((exc.strerror or str(exc) or type(exc).__name__).split())
        return f"{text.rstrip('.')}; check the paths involved and the disk."
    path = exc.filename
    sentences = {
        errno.EACCES: f"Permission denied for '{path}'; choose a place you can write to (for a run, --out DIR) "
        "or change its permissions.",
        errno.EROFS: f"'{path}' is on a read-only file system; write somewhere else (for a run, --out DIR).",
        errno.ENOSPC: f"No space left on the disk holding '{path}'; free some space or write to another disk.",
        errno.ENOTDIR: f"'{path}' cannot be used: part of that path is a file, not a folder; choose another path.",
        errno.EISDIR: f"'{path}' is a folder, not a file; name a file.",
        errno.ENOENT: f"File not found: '{path}'; check the path.",
        errno.EEXIST: f"'{path}' exists already; choose another name or remove it.",
    }
    sentences[errno.EPERM] = sentences[errno.EACCES]
    sentences[errno.EDQUOT] = sentences[errno.ENOSPC]
    reason = exc.strerror or str(exc) or type(exc).__name__
    return sentences.get(exc.errno, f"{reason} for '{path}'; check the path and the disk.")
