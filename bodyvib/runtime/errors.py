"""The one exception type bodyvib raises for bad input.

Every error a user can cause (a malformed parameter file, a bad CSV, a NaN seat
input, a negative step) is a :class:`BodyvibError` whose message names the
problem and, where there is one, the fix. The command-line interface prints it
as a single line and exits non-zero.

The library names its own parameters in a message (``retry_failed=True needs
resume=True``) and lists them in ``parameters``; the command line shows each as the flag
that sets it (``--retry-failed needs --resume``, :func:`bodyvib.cli.flags.in_flags`).
"""

from typing import Iterable

__all__ = ["BodyvibError"]


class BodyvibError(ValueError):
    """Invalid input to bodyvib: the message says what is wrong and how to fix it.

    Parameters
    ----------
    message : str
        One line: the problem and, where there is one, the fix.
    parameters : iterable of str
        The Python parameters (or settings fields) the message names, as it names them:
        the command line replaces each with its flag.

    Examples
    --------
    >>> e = BodyvibError("retry_failed=True needs resume=True", parameters=("retry_failed", "resume"))
    >>> str(e), e.parameters
    ('retry_failed=True needs resume=True', ('retry_failed', 'resume'))
    """

    def __init__(self, message: str = "", *, parameters: Iterable[str] = ()):
        super().__init__(message)
        self.parameters = tuple(parameters)

    def __reduce__(self) -> tuple:
        # a worker's error crosses to the client pickled: keep the parameters
        return (_rebuild, (type(self), self.args, self.parameters))


def _rebuild(cls: type, args: tuple, parameters: tuple) -> "BodyvibError":
    error = cls(*args)
    error.parameters = parameters
    return error
