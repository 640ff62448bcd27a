import pytest

from vehval.cli import main


@pytest.fixture
def cli(capsys):
    """Run ``vehval`` in-process; return (exit code, stdout, stderr)."""
    def run(*args):
        code = main([str(a) for a in args])
        out = capsys.readouterr()
        return code, out.out, out.err
    return run
