"""Progress off a terminal: a long command's bar becomes plain lines in its log."""

import io
import sys

from bodyvib.process.progress import LogLines, progress_bar


def test_log_lines_count_the_work_and_estimate_the_rest():
    out = io.StringIO()
    log = LogLines(400, "sweep", "case", initial=100, every=0.0, file=out)
    log.update(100)
    log.set_postfix_str("J=1.5 1/s")
    log.update(200)
    log.close()  # the last line already shows the end: nothing more
    first, last = out.getvalue().splitlines()
    assert first.startswith("sweep: 200/400 cases (50 %), ") and ", about " in first
    assert first.endswith(" s left")  # 100 done, 200 to go: twice the time so far
    assert last.startswith("sweep: 400/400 cases (100 %), ") and last.endswith(", J=1.5 1/s")
    assert "left" not in last


def test_a_short_run_prints_nothing_and_a_long_one_ends_with_its_state():
    out = io.StringIO()
    short = LogLines(10, "fit", every=3600.0, file=out)
    short.update(10)
    short.close()
    assert out.getvalue() == ""
    long = LogLines(10, "fit", every=0.0, file=out)
    long.update(3)
    long.every = 3600.0  # the next updates fall between two lines
    long.update(4)
    long.close()
    assert [ln.split(" (")[0] for ln in out.getvalue().splitlines()] == [
        "fit: 3/10 steps",
        "fit: 7/10 steps",
    ]


def test_off_a_terminal_a_bar_is_hidden_or_lines(capsys):
    assert not sys.stderr.isatty()  # pytest captures stderr
    assert isinstance(progress_bar(10, True, "sweep", "case", log_every=10.0), LogLines)
    bar = progress_bar(10, True, "co-simulation")  # no lines asked for: tqdm, hidden
    assert bar.disable
    bar.close()
    assert progress_bar(10, False, "sweep", log_every=10.0) is None
    assert capsys.readouterr().err == ""
