"""The two-panel frame of the study and road plots (bodyvib.plotting.stacked_panels)."""

import os

import pytest

from bodyvib.plotting import stacked_panels
from bodyvib.runtime.errors import BodyvibError

plt = pytest.importorskip("matplotlib.pyplot")


def test_the_frame_is_two_stacked_panels_written_to_the_file(tmp_path):
    path = tmp_path / "two.png"
    with stacked_panels(path) as (upper, lower):
        fig = upper.figure
        assert lower.figure is fig and tuple(fig.get_size_inches()) == (8.0, 8.0)
        top, bottom = upper.get_position(), lower.get_position()
        # matplotlib's hspace: the gap as a fraction of the (common) axes height
        assert top.y0 - bottom.y1 == pytest.approx(0.35 * top.height, rel=1e-12)
        assert top.x0 == bottom.x0 and top.width == bottom.width
        upper.plot([0, 1], [0, 1])
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not plt.fignum_exists(fig.number)


def test_a_failure_while_drawing_writes_nothing_and_closes_the_figure(tmp_path):
    path = tmp_path / "two.png"
    with pytest.raises(ZeroDivisionError):
        with stacked_panels(path) as (upper, _):
            fig = upper.figure
            1 / 0
    assert not path.exists() and not plt.fignum_exists(fig.number)


def test_a_bad_extension_is_refused_and_the_figure_closed(tmp_path):
    path = tmp_path / "two.jpg"
    with pytest.raises(BodyvibError, match=r"two\.jpg' must end in \.png, \.pdf or \.svg"):
        with stacked_panels(path) as (upper, _):
            fig = upper.figure
    assert os.listdir(tmp_path) == [] and not plt.fignum_exists(fig.number)
