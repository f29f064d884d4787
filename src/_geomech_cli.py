"""Entry point of the ``geomech`` command.

geomech (with numpy, scipy, sympy and numba) is imported inside :func:`main`, so that Ctrl-C while that
stack loads is one line and exit status 130, as it is at any later moment of a command.

Python raises the KeyboardInterrupt of Ctrl-C wherever the interpreter is, and where that is code whose exceptions
it ignores (a weak reference's callback during an import, a ``__del__``) the interrupt is lost and the command runs
on. So the handler also records the interrupt: one lost during the imports is honoured once they end, and a
process still running a few seconds after an interrupt ends with the same line and status.

The objects the imports create live as long as the process, and so do most of those a command makes (sympy's
caches of a derivation): both are moved out of the cyclic garbage collector's sight (``gc.freeze``), after the
imports so that the collections during the command do not traverse them again and again, and at the end so
that the interpreter's shutdown does not (a quarter of a second after a symbolic derivation).
"""

import gc
import os
import signal
import sys
import threading

#: Seconds a process may run on after Ctrl-C (its interrupt lost) before it is ended.
GRACE = 5.0
_INTERRUPTED: list[threading.Timer] = []


def _interrupted() -> None:
    sys.stderr.write("geomech: interrupted\n")
    sys.stderr.flush()
    os._exit(130)


def _on_sigint(signum: int, frame: object) -> None:
    if not _INTERRUPTED:
        timer = threading.Timer(GRACE, _interrupted)
        timer.daemon = True
        timer.start()
        _INTERRUPTED.append(timer)
    raise KeyboardInterrupt


def main() -> int:
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, _on_sigint)
    try:
        try:
            from geomech.cli.main import main as run
        except KeyboardInterrupt:
            sys.stderr.write("geomech: interrupted\n")
            return 130
        if _INTERRUPTED:  # an interrupt the imports swallowed
            sys.stderr.write("geomech: interrupted\n")
            return 130
        gc.freeze()
        try:
            return run()
        finally:
            gc.freeze()
    finally:
        for timer in _INTERRUPTED:
            timer.cancel()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
