"""The commands' output files: what each option accepts (checked before any work starts) and
how they are written (all together or none, each named once written)."""

from bodyvib.process import interrupts
from bodyvib.process.outputs import atomic_write_text, check_outputs, staged_writes, write_json

__all__ = [
    "PLOT_EXTENSIONS",
    "JSON_EXTENSIONS",
    "CSV_EXTENSIONS",
    "OUTPUT_OPTIONS",
    "check_files",
    "write_outputs",
    "write_result",
]

#: Plot files: the formats :func:`bodyvib.plotting.save_figure` writes.
PLOT_EXTENSIONS = (".png", ".pdf", ".svg")
#: JSON documents (figures, parameter files).
JSON_EXTENSIONS = (".json",)
#: Time histories.
CSV_EXTENSIONS = (".csv",)

#: The output options a command may have, in the order their files are checked:
#: option name, its metavar in the help and the file extensions it accepts.
OUTPUT_OPTIONS = {
    "json": ("FILE", JSON_EXTENSIONS),
    "plot": ("FILE.png", PLOT_EXTENSIONS),
    "csv": ("FILE", CSV_EXTENSIONS),
}


def check_files(args, outputs, inputs=()) -> None:
    """Refuse a command's output files that cannot be written, before any work.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    outputs : collection of str
        The command's output options among :data:`OUTPUT_OPTIONS` (``"json"``, ``"plot"``,
        ``"csv"``); those not given on the command line are skipped.
    inputs : iterable of (str, str)
        ``(option, path)`` of the command's input files, which no output may overwrite.

    Raises
    ------
    BodyvibError
        An output with the wrong extension, in a folder that cannot be written, naming an
        input or another output (:func:`bodyvib.process.outputs.check_outputs`).
    """
    check_outputs(
        [
            (f"--{name}", getattr(args, name), exts)
            for name, (_, exts) in OUTPUT_OPTIONS.items()
            if name in outputs
        ],
        inputs=list(inputs),
    )


def write_outputs(writes) -> list:
    """Write a command's output files all together or none of them, then print ``wrote PATH``.

    Ctrl-C (or SIGTERM, SIGHUP) while a file is rendered discards every new file and keeps
    the old ones; once all are written they are committed together.

    Parameters
    ----------
    writes : iterable of (str or None, callable)
        ``(path, write)``: ``write(path)`` writes one file through the atomic writers of
        :mod:`bodyvib.process.outputs`; entries whose path is None or empty (an option not
        given) are skipped.

    Returns
    -------
    list of str
        The files written, in the order written.

    Examples
    --------
    >>> write_outputs([(None, print)])
    []
    """
    with staged_writes(guard=interrupts.critical) as written:  # all outputs or none
        for path, write in writes:
            if path:
                write(path)
        interrupts.check()  # Ctrl-C while rendering: discard, keep the old files
    for path in written.paths:
        print(f"wrote {path}")
    return list(written.paths)


def write_result(args, result, plot, csv_text=None) -> list:
    """Write a command's typed result to the files its ``--json``, ``--csv`` and ``--plot`` name.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line, with ``json`` and ``plot`` (and ``csv`` when ``csv_text`` is
        given): paths, or None for an option not given.
    result : object
        The result; ``result.to_dict()`` is its JSON document.
    plot : callable
        ``plot(result, path)`` draws it into a plot file.
    csv_text : callable, optional
        ``csv_text(result)``: its time histories as CSV text.

    Returns
    -------
    list of str
        The files written (:func:`write_outputs`: all of them or none).
    """
    return write_outputs(
        [
            (args.json, lambda path: write_json(path, result.to_dict())),
            (
                args.csv if csv_text else None,
                lambda path: atomic_write_text(path, csv_text(result)),
            ),
            (args.plot, lambda path: plot(result, path)),
        ]
    )
