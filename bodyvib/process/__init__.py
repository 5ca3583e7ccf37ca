"""Process concerns of the commands: outputs, interrupts, memory limits, progress.

Not physics and not part of the FMU run-time: :mod:`~bodyvib.process.outputs`
checks every output before the work starts and writes them atomically, all or
none; :mod:`~bodyvib.process.interrupts` defers Ctrl-C, SIGTERM and SIGHUP to safe
points; :mod:`~bodyvib.process.scratch` gives each command a private temporary folder,
removed however the command ends; :mod:`~bodyvib.process.limits` refuses sizes the
memory cannot hold, up front; :mod:`~bodyvib.process.progress` draws the progress bars.
"""

from . import interrupts, limits, outputs, progress, scratch

__all__ = ["interrupts", "limits", "outputs", "progress", "scratch"]
