"""A command's progress: a bar on a terminal, plain lines (no carriage returns) in a log, each tenth of the runs
once, and nothing at all in a log for a command that does not count runs."""

from __future__ import annotations

import io

from agvctl.cli.progress import Progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_in_a_log_each_tenth_of_the_runs_is_one_plain_line():
    log = io.StringIO()
    with Progress("fuzz", unit="runs", stream=log) as progress:
        for done in range(1, 21):
            progress(done, 20)
    lines = log.getvalue().splitlines()
    assert "\r" not in log.getvalue()
    assert [line.split(",")[0] for line in lines] == [f"fuzz: {2 * k} of 20 runs" for k in range(1, 11)]


def test_in_a_log_a_fraction_shows_nothing():
    log = io.StringIO()
    with Progress("figure8", stream=log) as progress:
        for k in range(11):
            progress(k / 10)
    assert log.getvalue() == ""


def test_on_a_terminal_a_bar_reaches_the_whole_and_ends_its_line():
    terminal = _Terminal()
    with Progress("check", stream=terminal) as progress:
        for done in range(1, 5):
            progress(done, 4)
    text = terminal.getvalue()
    assert "\r" in text and text.endswith("\n")
    assert "check:" in text and "100%" in text.rsplit("\r", 1)[-1]
