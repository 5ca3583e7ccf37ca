"""Process concerns of the commands: outputs, interrupts, memory limits, progress.

Not physics and not part of the FMU run-time: :mod:`~bodyvib.process.outputs`
checks every output before the work starts and writes them atomically, all or
none; :mod:`~bodyvib.process.interrupts` defers Ctrl-C, SIGTERM and SIGHUP to safe
points; :mod:`~bodyvib.process.scratch` gives each command a private temporary folder,
removed however the command ends; :mod:`~bodyvib.process.limits` refuses sizes the
memory cannot hold, up front; :mod:`~bodyvib.process.progress` draws the progress bars;
:mod:`~bodyvib.process.extras` says which optional part of bodyvib a task needs.
:mod:`~bodyvib.process.units` reads the units input files' column headers name.

Here the modules are the public interface (``from bodyvib.process import outputs``, then
``outputs.atomic_write_text``): each is a small namespace of one concern, and their
names (``check``, ``message``) read well only under the module's name.
"""

from . import extras, interrupts, limits, outputs, progress, scratch, units

__all__ = ["extras", "interrupts", "limits", "outputs", "progress", "scratch", "units"]
