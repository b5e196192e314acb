"""The CLI through its real entry point."""

from __future__ import annotations

import pytest

from skillbank.cli import _main


@pytest.fixture
def cli(capsys):
    """``cli(*argv) -> (exit status, stdout, stderr)`` of ``skillbank argv...``."""

    def call(*argv):
        capsys.readouterr()
        code = _main.main([str(a) for a in argv])
        out, err = capsys.readouterr()
        return code, out, err

    return call
