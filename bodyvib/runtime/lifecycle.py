"""The FMI life cycle both cores share: initialization, the step's preconditions, messages.

:class:`~bodyvib.runtime.engine.FmuCore` (a network) and
:class:`~bodyvib.runtime.tabulated.SourceCore` (a tabulated signal) answer the same
FMI calls (:class:`bodyvib.runtime.cores.Core`). What they do alike lives here
once: ``fmi2ExitInitializationMode`` either succeeds or leaves the instance
refusing to step with the reason it failed; ``fmi2DoStep`` refuses a step size
that is not positive and finite, and a step before initialization; warnings and
errors go to the host's logger when there is one.
"""

from typing import Callable, Optional

from .errors import BodyvibError

__all__ = ["Lifecycle"]


class Lifecycle:
    """Mixin of a core: its initialization state and the checks every step makes.

    A core sets ``name`` (the FMU's name, in messages) and ``_log`` (``log(message,
    level)`` or None), and calls ``_not_initialized`` in its constructor.

    Examples
    --------
    >>> class Core(Lifecycle):
    ...     name, _log = "Demo", None
    ...     def __init__(self):
    ...         self._not_initialized()
    >>> core = Core()
    >>> core._refuse_step()
    Traceback (most recent call last):
    ...
    bodyvib.runtime.errors.BodyvibError: Demo: do_step before initialization; call fmi2ExitInitializationMode first
    >>> core._initialize(lambda: None, "set a valid value")
    >>> core._initialized
    True
    """

    name: str
    _log: Optional[Callable[[str, str], None]]

    def _not_initialized(self) -> None:
        """The state of a new instance: not initialized, no failure to report."""
        self._initialized = False
        self._init_error: Optional[str] = None

    def _initialize(self, prepare: Callable[[], None], fix: str) -> None:
        """Run ``prepare`` (check parameters, build); on its error the instance refuses to step.

        Parameters
        ----------
        prepare : callable
            No arguments; raises :class:`BodyvibError` on what the instance cannot run.
        fix : str
            The remedy named in the refusal of later steps (``"set valid parameters"``).

        Raises
        ------
        BodyvibError
            What ``prepare`` raised; a later step repeats it with the remedy (:meth:`_refuse_step`).
        """
        self._initialized = False
        try:
            prepare()
        except BodyvibError as exc:
            self._init_error = f"{exc}; the instance refuses to step (reset and {fix})"
            raise
        self._init_error = None
        self._initialized = True

    # A step tests its preconditions inline (``0.0 < h < math.inf``, ``self._initialized``:
    # no call on the hot path) and calls these to refuse, in the same words for both cores.
    def _refuse_step_size(self, step_size: float) -> None:
        """Refuse a communication step size that is not positive and finite (s)."""
        raise BodyvibError(
            f"{self.name}: communication step size must be positive and finite, got {step_size!r} s"
        )

    def _refuse_step(self) -> None:
        """Refuse a step before initialization, or after a failed one (with its reason)."""
        raise BodyvibError(
            self._init_error
            or f"{self.name}: do_step before initialization; call fmi2ExitInitializationMode first"
        )

    def _message(self, text: str, level: str = "error") -> None:
        """Send ``text`` to the host's logger (``level`` ``"warning"`` or ``"error"``), if any."""
        if self._log is not None:
            self._log(text, level)
