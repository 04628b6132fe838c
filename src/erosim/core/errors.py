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
