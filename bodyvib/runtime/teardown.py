"""A clean process exit for hosts of pythonfmu 0.7.0 FMUs (Linux).

The bug this works around. pythonfmu 0.7.0's binary (``binaries/linux64/<model>.so``)
keeps the interpreter state it shares between instances in a file-scope
``std::shared_ptr<PyState>`` and resets it from ``finalizePythonInterpreter``, an
exported function its ``__attribute__((destructor))`` calls when the library is
unloaded. The binary cannot be unloaded before exit (``dlclose`` leaves it loaded), so
both run at process exit, in the wrong order: the exit handlers first destroy the
``shared_ptr`` (freeing its control block), then the destructor assigns ``nullptr`` to the
destroyed pointer and decrements a count inside the freed block. valgrind shows the
invalid read in ``finalizePythonInterpreter``; whether the write into freed memory then
aborts the process ("corrupted double-linked list", from a later ``free`` in another
library's exit code) depends on the heap's history: a test creating 25 instances in an
fmpy host aborted in 5 to 20 % of runs, after its last line of output.

The fix. Calling ``finalizePythonInterpreter`` *before* exit empties the pointer, after
which both exit-time paths find nothing to release. :func:`release_at_exit` (called by
each FMU instance with its own resources folder) registers the binary, and a Python
``atexit`` handler, :func:`release_python_states`, calls the function of every registered
binary when the host's interpreter finalizes. Instances still alive at that point keep
their own reference to the state, so this is safe at any time.

The handler acts only in a Python host (fmpy, libcosimpy, the ``bodyvib`` commands), where
it runs on the process's main thread. In a non-Python host (a C host such as the FMU
Compliance Checker, which does not know ``finalizePythonInterpreter``), Python is finalized
by pythonfmu itself on a thread of its own, inside the very teardown this fixes, so there
the Python handler would come too late. There :func:`release_at_exit` registers
``finalizePythonInterpreter`` itself with the C library's exit handlers
(``__cxa_atexit``): registered after the binary was loaded, it runs before the binary's
static destructors, with nothing asked of the host. The binary is never unloaded before
that (its ``STB_GNU_UNIQUE`` symbols make the dynamic loader keep it: 26 of them), so the
handler's address stays valid. Without it the checker ends with SIGABRT ("free():
corrupted unsorted chunks") at exit; with it, 20 of 20 checker runs on HumanBody3DOF.fmu
end cleanly. A host may still call ``finalizePythonInterpreter`` itself after
``fmi2FreeInstance`` (``tests/c_host/fmi2_host.c`` does).

Run-time module of the FMUs: standard library only (ctypes), no numpy, no scipy.
"""

import atexit
import ctypes
import os
import signal
import sys
import threading
from typing import List, Optional

__all__ = [
    "FINALIZE_SYMBOL",
    "binary_path",
    "registered_binaries",
    "release_at_exit",
    "release_python_states",
]

#: The exported C function of pythonfmu's binary that releases its interpreter state.
FINALIZE_SYMBOL = "finalizePythonInterpreter"

_lock = threading.Lock()
_binaries: list[str] = []  # absolute paths of the registered FMU binaries, in registration order


def binary_path(resources: str, model_identifier: str) -> Optional[str]:
    """The binary of the FMU whose resources folder is ``resources``.

    Parameters
    ----------
    resources : str
        The FMU instance's resources folder (``Fmi2Slave.resources``).
    model_identifier : str
        The FMU's model identifier (pythonfmu: the slave class name).

    Returns
    -------
    str or None
        ``<fmu>/binaries/linux64/<model_identifier>.so``, or None on other platforms
        (pythonfmu's Windows binary releases its state from ``DllMain`` in the right
        order).

    Examples
    --------
    >>> binary_path("/tmp/fmu/resources", "HumanBody3DOF")  # doctest: +SKIP
    '/tmp/fmu/binaries/linux64/HumanBody3DOF.so'
    """
    if not sys.platform.startswith("linux"):
        return None
    root = os.path.dirname(os.path.abspath(resources))
    return os.path.join(root, "binaries", "linux64", model_identifier + ".so")


def release_at_exit(resources: str, model_identifier: str) -> bool:
    """Have the FMU binary's interpreter state released when the host's Python exits.

    Idempotent: each binary is registered once, however many instances it has.

    Parameters
    ----------
    resources : str
        The instance's resources folder (``Fmi2Slave.resources``).
    model_identifier : str
        The FMU's model identifier.

    Returns
    -------
    bool
        True if the binary is registered (now or before), False on platforms that do
        not need it.
    """
    path = binary_path(resources, model_identifier)
    if path is None:
        return False
    with _lock:
        if path not in _binaries:
            if not _binaries:
                atexit.register(release_python_states)
            _binaries.append(path)
            if not _python_host():
                _release_at_c_exit(path)
    return True


def _python_host() -> bool:
    """Whether the host process is Python: its interpreter's main thread is the process's.

    In a C host, pythonfmu initializes Python on a thread of its own, which then is
    :func:`threading.main_thread`."""
    return threading.main_thread().native_id == os.getpid()


def _release_at_c_exit(path: str) -> bool:
    """Register the loaded binary's ``finalizePythonInterpreter`` with the C library's exit
    handlers (``__cxa_atexit``, no DSO handle: the binary is never unloaded). False when the
    binary or the function is not there."""
    try:
        library = ctypes.CDLL(path, mode=os.RTLD_NOLOAD | os.RTLD_NOW)
        finalize = ctypes.cast(getattr(library, FINALIZE_SYMBOL), ctypes.c_void_p)
        libc = ctypes.CDLL(None)
        register = libc.__cxa_atexit
    except (OSError, AttributeError):
        return False
    register.restype = ctypes.c_int
    register.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    return register(finalize, None, None) == 0


def registered_binaries() -> List[str]:
    """The binaries :func:`release_python_states` will release, in registration order.

    Returns
    -------
    list of str
    """
    with _lock:
        return list(_binaries)


def release_python_states() -> int:
    """Call ``finalizePythonInterpreter`` of every registered binary loaded in this process.

    The ``atexit`` handler :func:`release_at_exit` installs. Binaries this process has
    not loaded (or has unloaded) are skipped: they are looked up with ``RTLD_NOLOAD``, so
    nothing is ever loaded here. Does nothing off the main thread (a non-Python host,
    whose Python pythonfmu finalizes from its own thread; see the module docstring).

    Returns
    -------
    int
        How many binaries were released.
    """
    if threading.get_native_id() != os.getpid():  # not the process's main thread
        return 0
    for name in ("SIGINT", "SIGTERM", "SIGHUP"):  # the process is exiting: a Ctrl-C or
        try:  # a kill now must not leave a traceback
            signal.signal(getattr(signal, name), signal.SIG_IGN)
        except (AttributeError, ValueError, OSError):
            pass
    released = 0
    for path in registered_binaries():
        try:
            library = ctypes.CDLL(path, mode=os.RTLD_NOLOAD | os.RTLD_NOW)
        except OSError:  # not loaded in this process
            continue
        finalize = getattr(library, FINALIZE_SYMBOL, None)
        if finalize is None:  # a pythonfmu without the function: nothing to release
            continue
        finalize.restype = None
        finalize.argtypes = []
        finalize()
        released += 1
    return released
