"""What a person at a terminal sees while a command works: click's progress bar where the work is counted
(grid points, approaches), and for work of unknown length (a derivation, an integration) a line with the
stage and the elapsed time. Nothing is printed when stderr is not a terminal (scripts, logs, --json pipes)."""

from __future__ import annotations

import itertools
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["activity", "study_progress"]

_DELAY = 1.0  # seconds of work before anything is shown: quick commands stay silent
_PERIOD = 0.2


@contextmanager
def activity(label: str) -> Iterator[None]:
    """Show ``label`` and the elapsed time on stderr (a terminal only) while the block runs."""
    stream = sys.stderr
    if not (hasattr(stream, "isatty") and stream.isatty()):
        yield
        return
    done = threading.Event()
    start = time.monotonic()

    def show() -> None:
        if done.wait(_DELAY):
            return
        for mark in itertools.cycle("|/-\\"):
            stream.write(f"\r{label} {mark} {time.monotonic() - start:5.0f} s")
            stream.flush()
            if done.wait(_PERIOD):
                break
        stream.write("\r" + " " * (len(label) + 12) + "\r")
        stream.flush()

    thread = threading.Thread(target=show, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()


@contextmanager
def study_progress(label: str) -> Iterator[Callable[[int, int], None] | None]:
    """A ``progress(done, total)`` for a study's tasks: click's progress bar on a terminal, None elsewhere."""
    import click

    stream = sys.stderr
    if not (hasattr(stream, "isatty") and stream.isatty()):
        yield None
        return
    bar: list = []

    def progress(done: int, total: int) -> None:
        if not bar:
            bar.append(click.progressbar(length=total, label=f"{label}: tasks", file=stream).__enter__())
        bar[0].update(done - bar[0].pos)

    try:
        yield progress
    finally:
        if bar:
            bar[0].__exit__(None, None, None)
