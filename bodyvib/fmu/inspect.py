"""Inspecting an FMU before a host loads it: its extracted tree and its binary.

A host that loads an incomplete FMU does not fail cleanly: a pythonfmu binary without
its resources crashes the process, and ``dlopen`` of a truncated shared library dies of
SIGBUS. :func:`check_extracted_fmu` refuses such an FMU in one line, after extraction and
before instantiation; :func:`check_elf` checks that a Linux binary is whole.
"""

import os
import platform
import struct
from typing import Any

from ..process.scratch import uri_unsafe_characters
from ..runtime.errors import BodyvibError

__all__ = ["check_extracted_fmu", "check_elf"]


def check_extracted_fmu(unzipdir: str, md: Any, path: str) -> None:
    """Refuse an extracted FMU that lacks what its binary loads at instantiation.

    pythonfmu's binary reads ``resources/slavemodule.txt`` and imports the module it
    names from ``resources/``; without them it crashed the host (a segfault) instead
    of failing ``fmi2Instantiate``. It finds them from the resource URI, decoding only
    ``%20``: the extracted folder's path must be URI-safe
    (:func:`bodyvib.process.scratch.uri_unsafe_characters`). On Linux the binary must
    also be a whole ELF library (:func:`check_elf`).

    Parameters
    ----------
    unzipdir : str
        The folder the FMU was extracted to.
    md : fmpy.model_description.ModelDescription
        Its model description (FMI 2.0 co-simulation).
    path : str
        The ``.fmu`` file, for the messages.

    Raises
    ------
    BodyvibError
        No binary for this platform, a truncated binary, a pythonfmu FMU without
        ``resources/slavemodule.txt`` or its slave script, or extracted to a folder
        whose path its binary cannot read back.
    """

    system = {"Linux": "linux", "Windows": "win", "Darwin": "darwin"}.get(platform.system(), "")
    ext = {"linux": ".so", "win": ".dll", "darwin": ".dylib"}.get(system, "")
    binary = os.path.join(
        unzipdir, "binaries", f"{system}64", md.coSimulation.modelIdentifier + ext
    )
    if not os.path.isfile(binary):
        raise BodyvibError(
            f"FMU '{path}' has no binary for this platform "
            f"(binaries/{system}64/{md.coSimulation.modelIdentifier}{ext})"
        )
    if system == "linux":
        check_elf(binary, path, f"binaries/linux64/{md.coSimulation.modelIdentifier}.so")
    # pythonfmu writes "PythonFMU x.y"; bodyvib's writer "bodyvib v with PythonFMU x.y"
    if "PythonFMU" not in (md.generationTool or ""):
        return
    resources = os.path.join(unzipdir, "resources")
    listing = os.path.join(resources, "slavemodule.txt")
    try:
        with open(listing, encoding="utf-8") as f:
            module = f.read().strip()
    except OSError:
        raise BodyvibError(
            f"FMU '{path}' is incomplete: no resources/slavemodule.txt (a "
            "pythonfmu FMU needs its resources folder); rebuild it"
        ) from None
    if not module or not any(
        os.path.isfile(os.path.join(resources, module + e)) for e in (".py", "")
    ):
        raise BodyvibError(
            f"FMU '{path}' is incomplete: resources/{module or '?'}.py (its "
            "slave script) is missing; rebuild it"
        )
    bad = uri_unsafe_characters(unzipdir)
    if bad:  # its binary would miss its resources and crash the host
        raise BodyvibError(
            f"FMU '{path}' was extracted to '{unzipdir}', whose "
            f"{' '.join(repr(c) for c in bad)} a pythonfmu FMU cannot read back from its "
            "resource URI; set TMPDIR to a folder without them"
        )


def check_elf(binary: str, path: str, member: str) -> None:
    """Refuse an ELF shared library that is not whole, before ``dlopen`` maps it.

    ``dlopen`` of a truncated library maps pages beyond the end of the file and the
    process dies of SIGBUS (measured: ``cosim --body`` of a native FMU whose binary was
    cut in half), with no message and its temporary folders left behind. The header,
    every program segment and every section (but the ``NOBITS`` ones) must lie inside
    the file.

    Parameters
    ----------
    binary : str
        The extracted shared library.
    path : str
        The ``.fmu`` file it came from, for the message.
    member : str
        The library's name inside the FMU, for the message.

    Raises
    ------
    BodyvibError
        Not an ELF file, or headers, segments or sections that run past its end.

    Examples
    --------
    >>> import os, tempfile
    >>> with tempfile.TemporaryDirectory() as d:
    ...     lib = os.path.join(d, "m.so")
    ...     with open(lib, "wb") as f:
    ...         _ = f.write(b"\x7fELF\x02\x01" + bytes(10))
    ...     check_elf(lib, "M.fmu", "binaries/linux64/m.so")
    Traceback (most recent call last):
    ...
    bodyvib.runtime.errors.BodyvibError: FMU 'M.fmu': its binary binaries/linux64/m.so is not an ELF shared library (16 bytes); rebuild the FMU
    """

    what = f"FMU '{path}': its binary {member}"
    with open(binary, "rb") as f:
        data = f.read()
    size = len(data)
    if size < 64 or data[:4] != b"\x7fELF" or data[4] not in (1, 2) or data[5] not in (1, 2):
        raise BodyvibError(f"{what} is not an ELF shared library ({size} bytes); rebuild the FMU")
    bits64, order = data[4] == 2, "<" if data[5] == 1 else ">"
    if bits64:
        phoff, shoff = struct.unpack_from(order + "QQ", data, 0x20)
        phentsize, phnum, shentsize, shnum = struct.unpack_from(order + "HHHH", data, 0x36)
    else:
        phoff, shoff = struct.unpack_from(order + "II", data, 0x1C)
        phentsize, phnum, shentsize, shnum = struct.unpack_from(order + "HHHH", data, 0x2A)

    def truncated(need: int) -> BodyvibError:
        return BodyvibError(
            f"{what} is truncated: {size} bytes, its headers describe at "
            f"least {need}; the file was cut short (copy or download it "
            "again, or rebuild the FMU)"
        )

    for off, entsize, num in ((phoff, phentsize, phnum), (shoff, shentsize, shnum)):
        if num and off + entsize * num > size:
            raise truncated(off + entsize * num)
    for k in range(phnum):
        base = phoff + k * phentsize
        if bits64:
            p_offset, _, _, p_filesz = struct.unpack_from(order + "QQQQ", data, base + 8)
        else:
            p_offset, _, _, p_filesz = struct.unpack_from(order + "IIII", data, base + 4)
        if p_offset + p_filesz > size:
            raise truncated(p_offset + p_filesz)
    for k in range(shnum):
        base = shoff + k * shentsize
        if bits64:
            (sh_type,) = struct.unpack_from(order + "I", data, base + 4)
            sh_offset, sh_size = struct.unpack_from(order + "QQ", data, base + 24)
        else:
            (sh_type,) = struct.unpack_from(order + "I", data, base + 4)
            sh_offset, sh_size = struct.unpack_from(order + "II", data, base + 16)
        if sh_type != 8 and sh_offset + sh_size > size:  # 8: SHT_NOBITS (.bss), no bytes
            raise truncated(sh_offset + sh_size)
