"""Exceptions that the command line turns into a one-line message and an exit status.

``UsageError`` (exit 2): the user asked for something that cannot be done as asked
(unknown ball, K <= 0, an option out of range).
``DataError`` (exit 1): a file or table holds something wrong (malformed YAML, h > H,
a missing field, a measurement file that cannot be read).
"""


class VrcalError(Exception):
    """Base class of every error vrcal reports to its user."""

    exit_code = 1


class UsageError(VrcalError, ValueError):
    """The request cannot be carried out as asked; exit status 2."""

    exit_code = 2


class DataError(VrcalError, ValueError):
    """A file or table holds something wrong; exit status 1."""

    exit_code = 1


class EngineUnavailable(VrcalError, RuntimeError):
    """An optional physics engine is not installed; the message names the package."""

    exit_code = 1
