"""Progress bars of the long-running commands (tqdm on stderr, hidden off a terminal)."""

import sys

__all__ = ["progress_bar"]


def progress_bar(total: int, enabled: bool, desc: str, unit: str = "step"):
    """A tqdm bar on stderr, or None when not wanted.

    Parameters
    ----------
    total : int
        Units of work of the whole run.
    enabled : bool
        False gives None (no bar, no tqdm import).
    desc : str
        The bar's title.
    unit : str
        The unit of work.

    Returns
    -------
    tqdm.tqdm or None
        Hidden when stderr is not a terminal (``disable=None``); refreshed at most every
        0.5 s; not left on the screen when closed.
    """
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(
        total=total,
        unit=unit,
        file=sys.stderr,
        disable=None,
        leave=False,
        desc=desc,
        mininterval=0.5,
    )
