"""The command line run in-process, as the tests call it."""

from geomech.cli.main import main


def run(capsys, *args):
    """``geomech ARGS``: (exit status, stdout, stderr)."""
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err
