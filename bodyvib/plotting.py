"""Small plotting helpers shared by the commands (matplotlib, headless)."""

import io
import os

from .runtime.errors import BodyvibError
from .runtime.fileio import atomic_write_bytes

__all__ = ["new_figure", "save_figure"]


def new_figure(nrows: int = 1, ncols: int = 1, **kwargs):
    """A matplotlib figure on the non-interactive Agg backend.

    Returns
    -------
    fig, axes
        As :func:`matplotlib.pyplot.subplots`.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(nrows, ncols, **kwargs)


def save_figure(fig, path) -> None:
    """Save a figure atomically; the format follows the file extension (.png, .pdf, .svg).

    Raises
    ------
    BodyvibError
        If the extension is not a format matplotlib writes.
    """
    import matplotlib.pyplot as plt

    ext = os.path.splitext(os.fspath(path))[1].lower().lstrip(".")
    if ext not in ("png", "pdf", "svg"):
        raise BodyvibError(f"plot file '{path}' must end in .png, .pdf or .svg")
    buf = io.BytesIO()
    fig.savefig(buf, format=ext, dpi=120, bbox_inches="tight")
    plt.close(fig)
    atomic_write_bytes(path, buf.getvalue())
