"""Small plotting helpers shared by the commands (matplotlib, headless).

Every plot the commands write goes through :func:`new_figure` (the Agg backend) and
:func:`save_figure` (the format from the file extension, written atomically);
:func:`stacked_panels` is the two-panel page of ``bodyvib cosim --plot`` and
``bodyvib road --plot``.
"""

import contextlib
import io
import os

from .process.outputs import atomic_write_bytes
from .runtime.errors import BodyvibError

__all__ = ["new_figure", "save_figure", "stacked_panels", "transmissibility_axes"]

#: Label of a seat-to-head transmissibility modulus axis.
MODULUS_LABEL = "|T| = |X_head / X_seat|  [-]"


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


def transmissibility_axes(ax_modulus, ax_phase=None, title=None, ylabel: str = MODULUS_LABEL):
    """Axes of a transmissibility plot: log frequency, modulus (and phase below it).

    Parameters
    ----------
    ax_modulus : matplotlib Axes
        The modulus axes (log frequency axis, grid).
    ax_phase : matplotlib Axes, optional
        The phase axes under it (sharing its x axis), in degrees; if None, the
        frequency label goes on the modulus axes.
    title : str, optional
    ylabel : str
        Label of the modulus axis.
    """
    ax_modulus.set_xscale("log")
    ax_modulus.set_ylabel(ylabel)
    if title is not None:
        ax_modulus.set_title(title)
    ax_modulus.grid(True, which="both", alpha=0.3)
    bottom = ax_modulus if ax_phase is None else ax_phase
    bottom.set_xlabel("frequency [Hz]")
    if ax_phase is not None:
        ax_phase.set_ylabel("phase [deg]")
        ax_phase.grid(True, which="both", alpha=0.3)


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


@contextlib.contextmanager
def stacked_panels(path):
    """Two stacked panels; the figure is saved to ``path`` when the block ends.

    Parameters
    ----------
    path : str or os.PathLike
        Plot file: ``.png``, ``.pdf`` or ``.svg``, written atomically when the block
        ends without an exception; nothing is written otherwise.

    Yields
    ------
    (matplotlib.axes.Axes, matplotlib.axes.Axes)
        The upper and the lower panel.

    Raises
    ------
    BodyvibError
        An unsupported plot file extension (on saving, as :func:`save_figure`).

    Examples
    --------
    >>> import os, tempfile
    >>> folder = tempfile.mkdtemp()
    >>> with stacked_panels(os.path.join(folder, "two.png")) as (top, bottom):
    ...     _ = top.plot([0, 1], [0, 1]); _ = bottom.plot([0, 1], [1, 0])
    >>> os.listdir(folder)
    ['two.png']
    >>> import shutil; shutil.rmtree(folder)
    """
    fig, (upper, lower) = new_figure(2, 1, figsize=(8, 8))
    import matplotlib.pyplot as plt  # after new_figure has chosen the Agg backend

    try:
        fig.subplots_adjust(hspace=0.35)
        yield upper, lower
        save_figure(fig, path)
    finally:
        plt.close(fig)  # also when drawing or saving failed (save_figure closes it otherwise)
