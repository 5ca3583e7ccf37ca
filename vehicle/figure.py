"""The application's two-panel figure: one panel above the other, written atomically.

``bodyvib cosim --plot`` (:func:`vehicle.plots.plot_study`) and ``bodyvib road --plot``
(:func:`vehicle.road.summary.plot_summary`) draw into the same frame: two stacked axes on an
8 x 8 inch page, 0.35 of an axes' height between them, saved by
:func:`bodyvib.plotting.save_figure` (the format from the file extension, atomically).
"""

import contextlib

__all__ = ["stacked_panels"]


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
        An unsupported plot file extension (on saving, as :func:`bodyvib.plotting.save_figure`).

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
    from bodyvib.plotting import new_figure, save_figure

    fig, (upper, lower) = new_figure(2, 1, figsize=(8, 8))
    import matplotlib.pyplot as plt  # after new_figure has chosen the Agg backend

    try:
        fig.subplots_adjust(hspace=0.35)
        yield upper, lower
        save_figure(fig, path)
    finally:
        plt.close(fig)  # also when drawing or saving failed (save_figure closes it otherwise)
