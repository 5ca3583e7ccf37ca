"""The one exception type bodyvib raises for bad input.

Every error a user can cause (a malformed parameter file, a bad CSV, a NaN seat
input, a negative step) is a :class:`BodyvibError` whose message names the
problem and, where there is one, the fix. The command-line interface prints it
as a single line and exits non-zero.
"""

__all__ = ["BodyvibError"]


class BodyvibError(ValueError):
    """Invalid input to bodyvib: the message says what is wrong and how to fix it."""
