"""Errors a user can fix: a bad configuration, a bad log, data that cannot identify, an infeasible problem.

The entry point prints their message as one line (no traceback), exits non-zero and records the run
as FAILED with the full traceback in ``error.txt``; any other exception is a bug and keeps its
traceback. Each subclass also derives from the built-in type callers already catch (``ValueError``).
"""

from __future__ import annotations


class UserError(Exception):
    """A problem in what the user gave (config, data): the message says what and how to fix it."""


class ConfigError(UserError, ValueError):
    """A configuration value of the wrong type or out of range; the message names the key."""


class IdentifiabilityError(UserError, ValueError):
    """The data cannot determine the parameters (rank-deficient regressor); the message names them."""


class InfeasibleProblemError(UserError, ValueError):
    """An optimisation whose constraints cannot all hold; the message names the constraint."""


class MissingFileError(ConfigError, FileNotFoundError):
    """A file or folder a setting names does not exist; the message names the setting and the path.

    Also a ``FileNotFoundError``, which callers of file readers already catch.
    """


class UnknownNameError(ConfigError, KeyError):
    """A name a setting gives (a tool, a frame, a joint) is not among those available; the message lists them.

    Also a ``KeyError``, which callers of look-ups already catch; printed as its message, unquoted.
    """

    __str__ = Exception.__str__
