"""One base class for every refusal a user can cause: the command line exits 2 on its type and prints its message,
which names the file, key, argument or path and what was expected. A ``ValueError`` that is not one is a bug."""

from __future__ import annotations


class UserError(ValueError):
    """Input that cannot be used (a file, a key, an argument, a path); the message says which and what was expected."""


class UsageError(UserError):
    """Bad command-line input."""


class ScenarioError(UserError):
    """A scenario file that cannot be used; the message names the file and the key (:mod:`xcheck.scenario`, and the
    checks of its model in :mod:`xcheck.assembly`)."""
