"""Entry point of the ``geomech`` command.

geomech (with numpy, scipy, sympy and numba) is imported inside :func:`main`, so that Ctrl-C while that
stack loads is one line and exit status 130, as it is at any later moment of a command.
"""

import sys


def main() -> int:
    try:
        from geomech.cli.main import main as run
    except KeyboardInterrupt:
        sys.stderr.write("geomech: interrupted\n")
        return 130
    return run()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
