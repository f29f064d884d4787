"""Entry point of the ``geomech`` command.

geomech (with numpy, scipy, sympy and numba) is imported inside :func:`main`, so that Ctrl-C while that
stack loads is one line and exit status 130, as it is at any later moment of a command.

The objects the imports create live as long as the process, and so do most of those a command makes (sympy's
caches of a derivation): both are moved out of the cyclic garbage collector's sight (``gc.freeze``), after the
imports so that the collections during the command do not traverse them again and again, and at the end so
that the interpreter's shutdown does not (a quarter of a second after a symbolic derivation).
"""

import gc
import sys


def main() -> int:
    try:
        from geomech.cli.main import main as run
    except KeyboardInterrupt:
        sys.stderr.write("geomech: interrupted\n")
        return 130
    gc.freeze()
    try:
        return run()
    finally:
        gc.freeze()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
