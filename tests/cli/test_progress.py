"""Long work shows its stage and elapsed time on a terminal, and nothing elsewhere."""

import io
import time

from geomech.cli import _progress


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_terminal_sees_the_stage_and_the_time_then_a_clean_line(monkeypatch):
    term = Terminal()
    monkeypatch.setattr(_progress.sys, "stderr", term)
    monkeypatch.setattr(_progress, "_DELAY", 0.05)
    with _progress.activity("deriving snakeboard"):
        time.sleep(0.4)
    text = term.getvalue()
    assert "\rderiving snakeboard" in text and " s" in text
    assert text.endswith("\r")  # the line is cleared for what the command prints next


def test_quick_work_and_pipes_see_nothing(monkeypatch):
    term = Terminal()
    monkeypatch.setattr(_progress.sys, "stderr", term)
    with _progress.activity("quick"):
        pass
    assert term.getvalue() == ""
    pipe = io.StringIO()
    monkeypatch.setattr(_progress.sys, "stderr", pipe)
    monkeypatch.setattr(_progress, "_DELAY", 0.0)
    with _progress.activity("in a script"):
        time.sleep(0.1)
    assert pipe.getvalue() == ""
